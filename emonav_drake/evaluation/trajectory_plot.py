"""Top-view pictures of one episode (`emonav plot`): a PNG of the whole run and an animation.

Both read a `Trajectory` (`evaluation/trajectory.py`, the `"trajectory"` section of
`emonav sim --json`) and draw in the world frame (x towards the goal, y left, metres),
with the shared palette (`core/palette.py`, Okabe–Ito): the robot blue, pedestrians bluish
green / orange / vermillion for happy / neutral / negative, static discs grey, the goal a
black star in its dotted goal-radius ring.

* `render_trajectory_figure`: the robot's path coloured by time (dots at every walking
  step t_k), every pedestrian's path coloured by the emotion in force along it (a
  time-varying emotion changes colour, a diamond marks each change), the robot and the
  pedestrians with their discomfort zones at chosen times, the static discs with their
  discomfort rings, start, goal, and where the robot collided (or fell).
* `render_trajectory_animation`: the episode step by step (one frame per t_k) as a GIF
  (Pillow) or, when ffmpeg is on the PATH, an MP4.

matplotlib's object API with the Agg canvas: no screen, no pyplot state.
"""

from __future__ import annotations

import math
import shutil
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.collections import LineCollection
from matplotlib.colors import LinearSegmentedColormap, Normalize
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Circle

from emonav_drake.core.palette import (
    EMOTION_RGB,
    GOAL_RADIUS_RGB,
    GOAL_RGB,
    INK_RGB,
    PAPER_RGB,
    ROBOT_DARK_RGB,
    ROBOT_LIGHT_RGB,
    ROBOT_RGB,
    STATIC_RGB,
    TEXT_RGB,
    ZONE_EDGE_RGB,
)
from emonav_drake.evaluation.trajectory import Trajectory
from emonav_drake.params import EMOTION_NAMES

# The robot's path: light → dark blue with time (no green or orange: those are emotions).
ROBOT_TIME_CMAP = LinearSegmentedColormap.from_list(
    "robot_time", [ROBOT_LIGHT_RGB, ROBOT_RGB, ROBOT_DARK_RGB]
)
_OUTCOME_TEXT = {
    "success": "reached the goal",
    "collision": "collision",
    "timeout": "timeout",
    "fall": "fall",
}


# The per-step arrays of a trajectory and the names of their last index, as in the JSON.
_STEP_FIELDS = (
    ("t", ()),
    ("robot", ("x", "y", "heading", "v")),
    ("pedestrians", ("x", "y")),
    ("command", ("u_v", "u_dtheta")),
)


def _not_finite_text(value: float) -> str:
    if math.isnan(value):
        return "null or NaN"
    return "Infinity" if value > 0 else "-Infinity"


def check_drawable(traj: Trajectory, source: str) -> None:
    """`TrajectoryFileError` naming the first number of `traj` that is not finite (a
    JSON `null`, `NaN` or `Infinity`): its field and index as in the JSON's trajectory
    section, and for a per-step field the step and its time.

    Nothing is drawn of such a trajectory: a path with gaps would show an episode other
    than the one run, and matplotlib's own message named neither the file nor the field.
    """
    from emonav_drake.evaluation.trajectory import TrajectoryFileError

    def refuse(where: str) -> TrajectoryFileError:
        return TrajectoryFileError(
            f"{source}: {where}: not a finite number; a trajectory with missing numbers "
            "is not drawn"
        )

    for name, columns in _STEP_FIELDS:
        values = np.asarray(getattr(traj, name), dtype=float)
        bad = np.argwhere(~np.isfinite(values))
        if not len(bad):
            continue
        index = tuple(int(i) for i in bad[0])
        k = index[0]
        where = name + "".join(f"[{i}]" for i in index)
        if columns:
            where += f" ({columns[index[-1]]})"
        where += f" = {_not_finite_text(float(values[index]))} at step {k}"
        if name != "t":
            where += f" (t = {float(traj.t[k]):g} s)"
        raise refuse(where)

    fixed = {
        "step_time": traj.step_time,
        "scenario.start": traj.start,
        "scenario.heading": traj.heading,
        "scenario.goal": traj.goal,
        "scenario.goal_radius": traj.goal_radius,
        "scenario.robot_radius": traj.robot_radius,
        "scenario.pedestrian_radius": traj.pedestrian_radius,
        **{f"scenario.discomfort.{k}": v for k, v in traj.discomfort.items()},
        **{f"scenario.obstacles[{i}].center": c for i, c in enumerate(traj.obstacle_centers)},
        **{f"scenario.obstacles[{i}].radius": r for i, r in enumerate(traj.obstacle_radii)},
    }
    for name, value in fixed.items():
        values = np.asarray(value, dtype=float).reshape(-1)
        bad = np.flatnonzero(~np.isfinite(values))
        if len(bad):
            where = name if np.ndim(value) == 0 else f"{name}[{bad[0]}]"
            raise refuse(f"{where} = {_not_finite_text(float(values[bad[0]]))}")


def default_times(traj: Trajectory, count: int = 4) -> list[float]:
    """`count` evenly spaced instants t_k from the start to the end of the episode [s]."""
    rows = np.unique(np.round(np.linspace(0, traj.steps, count)).astype(int))
    return [float(traj.t[k]) for k in rows]


def _rows(traj: Trajectory, times: Sequence[float] | None) -> list[int]:
    times = default_times(traj) if times is None else times
    return sorted({traj.index_at(float(t)) for t in times})


def _fmt_time(t: float) -> str:
    return f"{t:.1f}".rstrip("0").rstrip(".") + " s"


def _bounds(traj: Trajectory, pad: float = 0.6) -> tuple[float, float, float, float]:
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


def _draw_static(ax, traj: Trajectory) -> None:
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


def _pedestrian_segments(traj: Trajectory, i: int, upto: int | None = None):
    """Segments k → k + 1 of pedestrian i's path, each with the emotion in force at t_k."""
    end = traj.steps if upto is None else upto
    path = traj.pedestrians[: end + 1, i]
    segments = np.stack([path[:-1], path[1:]], axis=1)
    colors = [EMOTION_RGB[int(e)] for e in traj.emotions[:end, i]]
    return segments, colors


TIME_LABEL_SIZE = 8  # [pt] the "t s" labels of the snapshots


def _label(ax, xy, text: str, above: bool, color, z: int, gap: float = 0.03) -> None:
    """A time label `gap` [m] above or below `xy` (inside a disc for a small gap; two
    snapshots of one body at one place keep readable labels), on a light ground so that
    paths, rings and markers under it do not hide it."""
    x, y = xy
    ax.text(
        x,
        y + (gap if above else -gap),
        text,
        ha="center",
        va="bottom" if above else "top",
        fontsize=TIME_LABEL_SIZE,
        color=color,
        zorder=z,
        bbox={"boxstyle": "round,pad=0.12", "fc": (*PAPER_RGB, 0.75), "ec": "none"},
    )


def _draw_person(ax, xy, radius: float, margin: float, rgb, label: str | None, above: bool):
    """A pedestrian's body and discomfort zone (margin beyond the body [m])."""
    ax.add_patch(Circle(xy, radius, fc=(*rgb, 0.45), ec=rgb, lw=1.4, zorder=4))
    ax.add_patch(Circle(xy, radius + margin, fill=False, ls="--", ec=rgb, lw=1.1, zorder=4))
    if label:
        _label(ax, xy, label, above, TEXT_RGB, 9)


def _draw_robot(ax, traj: Trajectory, k: int, label: str | None):
    """The robot at t_k with a heading tick and a time label."""
    x, y, th = traj.robot[k, :3]
    r = traj.robot_radius
    ax.add_patch(Circle((x, y), r, fc=(*ROBOT_RGB, 0.30), ec=ROBOT_RGB, lw=1.6, zorder=5))
    ax.plot([x, x + r * math.cos(th)], [y, y + r * math.sin(th)], color=INK_RGB, lw=1.2, zorder=5)
    if label:  # under the disc: the start and goal markers at its centre stay visible
        _label(ax, (x, y), label, False, ROBOT_DARK_RGB, 10, gap=r + 0.04)


def _mark_end(ax, traj: Trajectory) -> str | None:
    """The collision point or the fall; returns a note for the title, if any."""
    if traj.outcome == "collision" and traj.collision:
        px, py = traj.collision["point"]
        ax.plot(px, py, "X", color=INK_RGB, mec=PAPER_RGB, mew=1.2, ms=14, zorder=9)
        with_ = traj.collision.get("with") or ""
        what = {"static": "a static disc", "wall": "a wall", "": "an object"}.get(
            with_, f"a {with_} pedestrian"
        )
        return f"collided with {what} at t = {_fmt_time(float(traj.collision['t']))}"
    if traj.outcome == "fall":
        x, y = traj.robot[-1, :2]
        ax.plot(x, y, "v", color=INK_RGB, mec=PAPER_RGB, mew=1.2, ms=13, zorder=9)
        return f"fell at t = {_fmt_time(float(traj.t[-1]))}"
    return None


def title_of(traj: Trajectory) -> str:
    """'<outcome> after <t> s (<K> steps) — planner …, plant …, seed …'."""
    what = _OUTCOME_TEXT.get(traj.outcome, traj.outcome)
    return (
        f"{what} after {_fmt_time(traj.duration)} ({traj.steps} steps) — planner "
        f"{traj.planner}, plant {traj.plant}, seed {traj.seed}"
    )


def _legend_handles(traj: Trajectory, snapshot_note: str, still: bool = True) -> list[Line2D]:
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


def plot_trajectory(ax, traj: Trajectory, times: Sequence[float] | None = None):
    """Draw one episode on a matplotlib axes (module docstring); returns the robot path's
    `LineCollection` (its colours map time [s], for a colour bar).

    Args:
        ax: the axes (world frame, equal aspect is set).
        traj: the episode.
        times: instants [s] at which the robot and the pedestrians are drawn with their
            discomfort zones (each moved to the nearest walking instant t_k); default
            `default_times(traj)`.
    """
    rows = _rows(traj, times)
    _draw_static(ax, traj)
    for i in range(traj.pedestrians.shape[1]):
        segments, colors = _pedestrian_segments(traj, i)
        ax.add_collection(LineCollection(segments, colors=colors, lw=1.6, alpha=0.9, zorder=3))
        first = traj.pedestrians[0, i]
        ax.plot(*first, "o", ms=3.5, color=EMOTION_RGB[int(traj.emotions[0, i])], zorder=3)
        changes = np.flatnonzero(np.diff(traj.emotions[:, i]) != 0) + 1
        for k in changes:
            ax.plot(
                *traj.pedestrians[k, i],
                "D",
                ms=5.5,
                mfc=PAPER_RGB,
                mew=1.4,
                mec=EMOTION_RGB[int(traj.emotions[k, i])],
                zorder=6,
            )
    for j, k in enumerate(rows):
        label = _fmt_time(float(traj.t[k]))
        for i in range(traj.pedestrians.shape[1]):
            e = int(traj.emotions[k, i])
            margin = traj.discomfort.get(EMOTION_NAMES[e], 0.0)
            rgb = EMOTION_RGB[e]
            _draw_person(
                ax, traj.pedestrians[k, i], traj.pedestrian_radius, margin, rgb, label, j % 2 == 0
            )
        _draw_robot(ax, traj, k, label)
    xy = traj.robot[:, :2]
    norm = Normalize(float(traj.t[0]), max(float(traj.t[-1]), float(traj.t[0]) + 1e-9))
    path = LineCollection(
        np.stack([xy[:-1], xy[1:]], axis=1), cmap=ROBOT_TIME_CMAP, norm=norm, lw=2.6, zorder=8
    )
    path.set_array(0.5 * (traj.t[:-1] + traj.t[1:]))
    ax.add_collection(path)
    ax.scatter(xy[:, 0], xy[:, 1], c=traj.t, cmap=ROBOT_TIME_CMAP, norm=norm, s=7, zorder=8)
    x0, x1, y0, y1 = _bounds(traj)
    _frame_axes(ax, (x0, x1, y0, y1))
    return path


def _frame_axes(ax, bounds: tuple[float, float, float, float]) -> None:
    """Limits (x0, x1, y0, y1) [m], equal aspect, world-frame labels and a light grid."""
    x0, x1, y0, y1 = bounds
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)
    ax.set_aspect("equal")
    ax.set_xlabel("x [m] (world)")
    ax.set_ylabel("y [m] (world)")
    ax.grid(alpha=0.25)


def render_trajectory_figure(
    path: str | Path,
    traj: Trajectory,
    times: Sequence[float] | None = None,
    dpi: int = 110,
) -> Path:
    """Write the episode's top view (`plot_trajectory`) with title, colour bar and legend
    as a PNG; returns `path` (parent directories are created)."""
    rows = _rows(traj, times)
    fig, ax, key = _figure_with_key(traj, 7.5, (4.0, 9.0), (4.3, 1.4), (1.1, 3.0))
    line = plot_trajectory(ax, traj, [float(traj.t[k]) for k in rows])
    # in the axes' own coordinates: as tall as the equal-aspect plot, not its layout cell
    fig.colorbar(line, cax=ax.inset_axes((1.015, 0.0, 0.025, 1.0)), label="robot: time [s]")
    when = ", ".join(_fmt_time(float(traj.t[k])) for k in rows)
    note = _mark_end(ax, traj)
    ax.set_title(
        title_of(traj) + ("\n" + note if note else "") + f"\nrobot and pedestrians at t = {when}",
        fontsize=10,
    )
    key.legend(
        handles=_legend_handles(traj, "at the times shown (label: t)"),
        loc="upper left",
        fontsize=8,
        frameon=False,
    )
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=dpi, format="png")
    return out


def animation_writer(path: str | Path, fps: float):
    """The matplotlib writer for `path`'s suffix: .gif (Pillow) or .mp4 (ffmpeg, which must
    be on the PATH); `ValueError` otherwise."""
    from matplotlib.animation import FFMpegWriter, PillowWriter

    suffix = Path(path).suffix.lower()
    if suffix == ".gif":
        return PillowWriter(fps=fps)
    if suffix == ".mp4":
        if shutil.which("ffmpeg") is None:
            raise ValueError(f"{path}: an .mp4 needs ffmpeg on the PATH; write a .gif instead")
        return FFMpegWriter(fps=fps)
    raise ValueError(f"{path}: the animation must end in .gif or .mp4")


def render_trajectory_animation(
    path: str | Path,
    traj: Trajectory,
    fps: float | None = None,
    dpi: int = 110,
) -> Path:
    """Write the episode frame by frame (one frame per walking instant t_k, plus a still
    second at the end) as a GIF or MP4 (`animation_writer`).

    Args:
        path: output file, .gif or .mp4.
        traj: the episode.
        fps: frames per second; default 1/T (real time).
        dpi: resolution.
    """
    fps = 1.0 / traj.step_time if fps is None else float(fps)
    if not (fps > 0 and math.isfinite(fps)):
        raise ValueError(f"fps {fps}: must be > 0")
    writer = animation_writer(path, fps)
    fig, ax, key = _figure_with_key(traj, 6.0, (3.5, 7.0), (2.9, 1.0), (0.0, 2.8))
    _draw_static(ax, traj)
    _frame_axes(ax, _bounds(traj))
    key.legend(
        handles=_legend_handles(traj, "now", still=False),
        loc="upper left",
        fontsize=9,
        frameon=False,
    )
    title = ax.set_title("", fontsize=10)

    p = traj.pedestrians.shape[1]
    rp, rr = traj.pedestrian_radius, traj.robot_radius
    trails = [ax.add_collection(LineCollection([], lw=1.4, zorder=3)) for _ in range(p)]
    bodies = [ax.add_patch(Circle((0, 0), rp, lw=1.4, zorder=4)) for _ in range(p)]
    rings = [
        ax.add_patch(Circle((0, 0), rp, fill=False, ls="--", lw=1.1, zorder=4)) for _ in range(p)
    ]
    (robot_trail,) = ax.plot([], [], color=ROBOT_RGB, lw=2.2, zorder=8)
    robot = ax.add_patch(Circle((0, 0), rr, fc=(*ROBOT_RGB, 0.35), ec=ROBOT_RGB, lw=1.6, zorder=8))
    (nose,) = ax.plot([], [], color=INK_RGB, lw=1.4, zorder=8)
    end_marks: list = []
    head = title_of(traj)

    def frame(k: int):
        for i in range(p):
            segments, colors = _pedestrian_segments(traj, i, k)
            trails[i].set_segments(segments)
            trails[i].set_colors(colors)
            e = int(traj.emotions[k, i])
            rgb = EMOTION_RGB[e]
            centre = traj.pedestrians[k, i]
            bodies[i].set_center(centre)
            bodies[i].set_facecolor((*rgb, 0.45))
            bodies[i].set_edgecolor(rgb)
            rings[i].set_center(centre)
            rings[i].set_radius(rp + traj.discomfort.get(EMOTION_NAMES[e], 0.0))
            rings[i].set_edgecolor(rgb)
        x, y, th, v = traj.robot[k]
        robot_trail.set_data(traj.robot[: k + 1, 0], traj.robot[: k + 1, 1])
        robot.set_center((x, y))
        nose.set_data([x, x + rr * math.cos(th)], [y, y + rr * math.sin(th)])
        status = f"t = {float(traj.t[k]):.1f} s, step {k}/{traj.steps}, v = {v:.2f} m/s"
        if k == traj.steps:
            if not end_marks:  # drawn once, kept on the still frames
                end_marks.append(_mark_end(ax, traj))
            if end_marks[0]:
                status += f" — {end_marks[0]}"
        title.set_text(f"{head}\n{status}")

    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    frame(0)
    fig.canvas.draw()  # lay the figure out once, then keep it: one draw per frame
    fig.set_layout_engine("none")
    hold = max(1, round(fps))  # one still second on the last frame
    with writer.saving(fig, str(out), dpi):
        for k in [*range(traj.steps + 1), *[traj.steps] * hold]:
            frame(k)
            writer.grab_frame()
    return out


def _figure_with_key(
    traj: Trajectory,
    width: float,
    height_limits: tuple[float, float],
    margins: tuple[float, float],
    columns: tuple[float, float],
) -> tuple[Figure, Any, Any]:
    """A figure of the top-view axes (`width` [in] wide, height from the data's aspect,
    clipped to `height_limits`) beside a key panel: figure size = axes + `margins` [in],
    grid columns (axes `width` + columns[0], key columns[1])."""
    x0, x1, y0, y1 = _bounds(traj)
    height = min(max(width * (y1 - y0) / (x1 - x0), height_limits[0]), height_limits[1])
    fig = Figure(figsize=(width + margins[0], height + margins[1]), layout="constrained")
    FigureCanvasAgg(fig)
    grid = fig.add_gridspec(1, 2, width_ratios=[width + columns[0], columns[1]])
    ax, key = fig.add_subplot(grid[0]), fig.add_subplot(grid[1])
    key.axis("off")
    return fig, ax, key
