"""Top-view picture of one episode (`emonav plot --png`): a PNG of the whole run.

It reads a `Trajectory` (`evaluation/trajectory.py`, the `"trajectory"` section of
`emonav sim --json`) and draws in the world frame (x towards the goal, y left, metres),
with the shared palette (`palette.py`, Okabe–Ito): the robot blue, pedestrians bluish
green / orange / vermillion for happy / neutral / negative, static discs grey, the goal a
black star in its dotted goal-radius ring.

`render_trajectory_figure` (`plot_trajectory` on axes of your own): the robot's path
coloured by time (dots at every walking step t_k), every pedestrian's path coloured by the
emotion in force along it (a time-varying emotion changes colour, a diamond marks each
change), the robot and the pedestrians with their discomfort zones at chosen times, the
static discs with their discomfort rings, start, goal, and where the robot collided (or
fell). The same episode step by step: `trajectory_animation.py`; the pieces both draw:
`trajectory_drawing.py`; which trajectories can be drawn: `trajectory_check.py`.

matplotlib's object API with the Agg canvas: no screen, no pyplot state.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np
from matplotlib.collections import LineCollection
from matplotlib.colors import LinearSegmentedColormap, Normalize
from matplotlib.patches import Circle

from emonav_drake.evaluation.trajectory import Trajectory
from emonav_drake.evaluation.trajectory_drawing import (
    draw_static,
    figure_with_key,
    fmt_time,
    frame_axes,
    legend_handles,
    mark_end,
    pedestrian_segments,
    title_of,
    view_bounds,
)
from emonav_drake.palette import (
    EMOTION_RGB,
    INK_RGB,
    PAPER_RGB,
    ROBOT_DARK_RGB,
    ROBOT_LIGHT_RGB,
    ROBOT_RGB,
    TEXT_RGB,
)
from emonav_drake.params import EMOTION_NAMES

# The robot's path: light → dark blue with time (no green or orange: those are emotions).
ROBOT_TIME_CMAP = LinearSegmentedColormap.from_list(
    "robot_time", [ROBOT_LIGHT_RGB, ROBOT_RGB, ROBOT_DARK_RGB]
)


def default_times(traj: Trajectory, count: int = 4) -> list[float]:
    """`count` evenly spaced instants t_k from the start to the end of the episode [s]."""
    rows = np.unique(np.round(np.linspace(0, traj.steps, count)).astype(int))
    return [float(traj.t[k]) for k in rows]


def _rows(traj: Trajectory, times: Sequence[float] | None) -> list[int]:
    times = default_times(traj) if times is None else times
    return sorted({traj.index_at(float(t)) for t in times})


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
    draw_static(ax, traj)
    for i in range(traj.pedestrians.shape[1]):
        segments, colors = pedestrian_segments(traj, i)
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
        label = fmt_time(float(traj.t[k]))
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
    x0, x1, y0, y1 = view_bounds(traj)
    frame_axes(ax, (x0, x1, y0, y1))
    return path


def render_trajectory_figure(
    path: str | Path,
    traj: Trajectory,
    times: Sequence[float] | None = None,
    dpi: int = 110,
) -> Path:
    """Write the episode's top view (`plot_trajectory`) with title, colour bar and legend
    as a PNG; returns `path` (parent directories are created)."""
    rows = _rows(traj, times)
    fig, ax, key = figure_with_key(traj, 7.5, (4.0, 9.0), (4.3, 1.4), (1.1, 3.0))
    line = plot_trajectory(ax, traj, [float(traj.t[k]) for k in rows])
    # in the axes' own coordinates: as tall as the equal-aspect plot, not its layout cell
    fig.colorbar(line, cax=ax.inset_axes((1.015, 0.0, 0.025, 1.0)), label="robot: time [s]")
    when = ", ".join(fmt_time(float(traj.t[k])) for k in rows)
    note = mark_end(ax, traj)
    ax.set_title(
        title_of(traj) + ("\n" + note if note else "") + f"\nrobot and pedestrians at t = {when}",
        fontsize=10,
    )
    key.legend(
        handles=legend_handles(traj, "at the times shown (label: t)"),
        loc="upper left",
        fontsize=8,
        frameon=False,
    )
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=dpi, format="png")
    return out
