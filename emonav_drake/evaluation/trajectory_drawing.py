"""The pieces of an episode's top view shared by its figure (`trajectory_plot.py`) and its
animation (`trajectory_animation.py`): the plot's extent and axes, the static scene (discs,
walls, start, goal), the pedestrians' paths by emotion, the end of the episode (collision
or fall), the title, the legend and the figure with its key panel.

They draw a `Trajectory` (`evaluation/trajectory.py`) in the world frame (x towards the
goal, y left, metres) with the shared palette (`palette.py`, Okabe–Ito), with
matplotlib's object API and the Agg canvas: no screen, no pyplot state.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Circle

from emonav_drake.evaluation.trajectory import Trajectory
from emonav_drake.palette import (
    EMOTION_RGB,
    GOAL_RADIUS_RGB,
    GOAL_RGB,
    INK_RGB,
    PAPER_RGB,
    ROBOT_RGB,
    STATIC_RGB,
    ZONE_EDGE_RGB,
)
from emonav_drake.params import EMOTION_NAMES

_OUTCOME_TEXT = {
    "success": "reached the goal",
    "collision": "collision",
    "timeout": "timeout",
    "fall": "fall",
    "no_route": "no route left",
}


def fmt_time(t: float) -> str:
    """A time label: 2.5 → "2.5 s", 3.0 → "3 s"."""
    return f"{t:.1f}".rstrip("0").rstrip(".") + " s"


def view_bounds(traj: Trajectory, pad: float = 0.6) -> tuple[float, float, float, float]:
    """x and y limits [m] that hold the paths, the discs with their rings, start and goal."""
    pts = [traj.robot[:, :2], traj.start[None], traj.goal[None]]
    reach = traj.pedestrian_radius + max(traj.discomfort.get(n, 0.0) for n in EMOTION_NAMES)
    if traj.pedestrians.size:
        flat = traj.pedestrians.reshape(-1, 2)
        pts += [flat - reach, flat + reach]
    if len(traj.obstacle_radii):
        ring = (traj.obstacle_radii + traj.discomfort.get("static", 0.0))[:, None]
        pts += [traj.obstacle_centers - ring, traj.obstacle_centers + ring]
    if len(traj.walls):
        pts.append(traj.walls.reshape(-1, 2))
    allp = np.vstack(pts)
    lo, hi = allp.min(axis=0) - pad, allp.max(axis=0) + pad
    return float(lo[0]), float(hi[0]), float(lo[1]), float(hi[1])


def draw_static(ax, traj: Trajectory) -> None:
    """The static discs and walls with their discomfort rings, the start and the goal in its
    goal-radius ring."""
    ring = traj.discomfort.get("static", 0.0)
    for c, r in zip(traj.obstacle_centers, traj.obstacle_radii, strict=True):
        ax.add_patch(Circle(c, r, color=STATIC_RGB, zorder=2))
        ax.add_patch(Circle(c, r + ring, fill=False, ls="--", ec=STATIC_RGB, lw=1.0, zorder=2))
    for a, b in traj.walls:
        ax.plot([a[0], b[0]], [a[1], b[1]], color=STATIC_RGB, lw=4, solid_capstyle="butt", zorder=2)
    ax.plot(*traj.start, "s", color=ROBOT_RGB, mec=INK_RGB, ms=8, zorder=7)
    ax.add_patch(
        Circle(
            traj.goal, traj.goal_radius, fill=False, ls=":", ec=GOAL_RADIUS_RGB, lw=1.2, zorder=6
        )
    )
    # above the robot's path (which ends in it), a white rim against the path's dark end
    ax.plot(*traj.goal, "*", color=GOAL_RGB, mec=PAPER_RGB, mew=0.8, ms=16, zorder=8.5)


def pedestrian_segments(traj: Trajectory, i: int, upto: int | None = None):
    """Segments k → k + 1 of pedestrian i's path, each with the emotion in force at t_k."""
    end = traj.steps if upto is None else upto
    path = traj.pedestrians[: end + 1, i]
    segments = np.stack([path[:-1], path[1:]], axis=1)
    colors = [EMOTION_RGB[int(e)] for e in traj.emotions[:end, i]]
    return segments, colors


def mark_end(ax, traj: Trajectory) -> str | None:
    """The collision point or the fall; returns a note for the title, if any."""
    if traj.outcome == "collision" and traj.collision:
        px, py = traj.collision["point"]
        ax.plot(px, py, "X", color=INK_RGB, mec=PAPER_RGB, mew=1.2, ms=14, zorder=9)
        with_ = traj.collision.get("with") or ""
        what = {"static": "a static disc", "wall": "a wall", "": "an object"}.get(
            with_, f"a {with_} pedestrian"
        )
        return f"collided with {what} at t = {fmt_time(float(traj.collision['t']))}"
    if traj.outcome == "fall":
        x, y = traj.robot[-1, :2]
        ax.plot(x, y, "v", color=INK_RGB, mec=PAPER_RGB, mew=1.2, ms=13, zorder=9)
        return f"fell at t = {fmt_time(float(traj.t[-1]))}"
    return None


def title_of(traj: Trajectory) -> str:
    """'<outcome> after <t> s (<K> steps) — planner …, plant …, seed …'."""
    what = _OUTCOME_TEXT.get(traj.outcome, traj.outcome)
    return (
        f"{what} after {fmt_time(traj.duration)} ({traj.steps} steps) — planner "
        f"{traj.planner}, plant {traj.plant}, seed {traj.seed}"
    )


def legend_handles(traj: Trajectory, snapshot_note: str, still: bool = True) -> list[Line2D]:
    """The legend: `still` for the PNG (step dots, emotion-change diamonds)."""
    path = "robot path (dots: steps)" if still else "robot path"
    h = [
        Line2D([], [], color=ROBOT_RGB, lw=2.5, marker="." if still else None, label=path),
        Line2D(
            [],
            [],
            ls="none",
            marker="o",
            ms=9,
            mfc=(*ROBOT_RGB, 0.3),
            mec=ROBOT_RGB,
            label=f"robot {snapshot_note}",
        ),
        Line2D([], [], ls="none", marker="s", color=ROBOT_RGB, mec=INK_RGB, ms=7, label="start"),
        Line2D([], [], ls="none", marker="*", color=GOAL_RGB, ms=12, label="goal"),
        Line2D([], [], ls=":", color=GOAL_RADIUS_RGB, lw=1.2, label="goal radius"),
    ]
    for name, rgb in zip(EMOTION_NAMES, EMOTION_RGB, strict=True):
        h.append(
            Line2D(
                [],
                [],
                color=rgb,
                lw=1.8,
                marker="o",
                ms=7,
                mfc=(*rgb, 0.45),
                label=f"{name} pedestrian (zone {traj.discomfort.get(name, 0):g} m)",
            )
        )
    h.append(Line2D([], [], color=ZONE_EDGE_RGB, ls="--", lw=1.1, label="discomfort zone edge"))
    if still and np.any(np.diff(traj.emotions, axis=0) != 0):
        h.append(
            Line2D(
                [],
                [],
                ls="none",
                marker="D",
                ms=6,
                mfc=PAPER_RGB,
                mec=ZONE_EDGE_RGB,
                label="emotion change",
            )
        )
    if len(traj.obstacle_radii):
        h.append(
            Line2D(
                [],
                [],
                ls="none",
                marker="o",
                ms=9,
                color=STATIC_RGB,
                label=f"static disc (zone {traj.discomfort.get('static', 0):g} m)",
            )
        )
    if len(traj.walls):
        h.append(Line2D([], [], color=STATIC_RGB, lw=4, label="wall"))
    if traj.outcome == "collision":
        h.append(
            Line2D(
                [],
                [],
                ls="none",
                marker="X",
                color=INK_RGB,
                mec=PAPER_RGB,
                ms=11,
                label="collision",
            )
        )
    if traj.outcome == "fall":
        h.append(
            Line2D([], [], ls="none", marker="v", color=INK_RGB, mec=PAPER_RGB, ms=10, label="fall")
        )
    return h


def frame_axes(ax, bounds: tuple[float, float, float, float]) -> None:
    """Limits (x0, x1, y0, y1) [m], equal aspect, world-frame labels and a light grid."""
    x0, x1, y0, y1 = bounds
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)
    ax.set_aspect("equal")
    ax.set_xlabel("x [m] (world)")
    ax.set_ylabel("y [m] (world)")
    ax.grid(alpha=0.25)


def figure_with_key(
    traj: Trajectory,
    width: float,
    height_limits: tuple[float, float],
    margins: tuple[float, float],
    columns: tuple[float, float],
) -> tuple[Figure, Any, Any]:
    """A figure of the top-view axes (`width` [in] wide, height from the data's aspect,
    clipped to `height_limits`) beside a key panel: figure size = axes + `margins` [in],
    grid columns (axes `width` + columns[0], key columns[1])."""
    x0, x1, y0, y1 = view_bounds(traj)
    height = min(max(width * (y1 - y0) / (x1 - x0), height_limits[0]), height_limits[1])
    fig = Figure(figsize=(width + margins[0], height + margins[1]), layout="constrained")
    FigureCanvasAgg(fig)
    grid = fig.add_gridspec(1, 2, width_ratios=[width + columns[0], columns[1]])
    ax, key = fig.add_subplot(grid[0]), fig.add_subplot(grid[1])
    key.axis("off")
    return fig, ax, key
