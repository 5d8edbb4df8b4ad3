"""An episode's top view as an animation (`emonav plot --animation`): the episode step by
step (one frame per walking instant t_k) as a GIF (Pillow) or, when ffmpeg is on the PATH,
an MP4.

Each frame shows the pedestrians with their discomfort zones, coloured by their emotion
now, and the paths walked so far, the robot with its heading, and in the title the time,
step and speed; the static scene, legend and end marks are `trajectory_drawing.py`'s, as in
the still figure (`trajectory_plot.py`).
"""

from __future__ import annotations

import math
import shutil
from pathlib import Path

from matplotlib.collections import LineCollection
from matplotlib.patches import Circle

from emonav_drake.evaluation.trajectory import Trajectory
from emonav_drake.evaluation.trajectory_drawing import (
    draw_static,
    figure_with_key,
    frame_axes,
    legend_handles,
    mark_end,
    pedestrian_segments,
    title_of,
    view_bounds,
)
from emonav_drake.palette import EMOTION_RGB, INK_RGB, ROBOT_RGB
from emonav_drake.params import EMOTION_NAMES


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
    fig, ax, key = figure_with_key(traj, 6.0, (3.5, 7.0), (2.9, 1.0), (0.0, 2.8))
    draw_static(ax, traj)
    frame_axes(ax, view_bounds(traj))
    key.legend(
        handles=legend_handles(traj, "now", still=False),
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
            segments, colors = pedestrian_segments(traj, i, k)
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
                end_marks.append(mark_end(ax, traj))
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
