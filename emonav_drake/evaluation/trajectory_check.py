"""Whether an episode's trajectory can be drawn (`emonav plot`): every number finite.

`check_drawable` names the first number of a `Trajectory` (`evaluation/trajectory.py`)
that is not (a JSON `null`, `NaN` or `Infinity`) by its field, index and step; `emonav plot`
checks a trajectory with it before the figure (`trajectory_plot.py`) or the animation
(`trajectory_animation.py`) draws it.
"""

from __future__ import annotations

import math

import numpy as np

from emonav_drake.evaluation.trajectory import Trajectory

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
