"""Per-step tracking of the LIP step map (paper Eq. 1): desired vs achieved, and statistics.

A walking step runs from `t_start` to `t`. From the robot's state s = (x, y, θ, v) at
`t_start` (CoM position [m], heading [rad], sagittal CoM speed [m/s]; world frame W) and
the step's command u = (u_v [m/s], u_Δθ [rad]), the LIP step map (`robot.lip.lip_step`)
predicts the CoM position and heading at `t`: the *desired* step. The robot's measured CoM
and heading at `t` are the *achieved* step; the errors are achieved − desired.

Two kinds of step use this table (`COLUMNS`, one row per step):

* open-loop walking (`emonav walk`, `diagrams.walking.walk_tracking`): a step runs from
  one foot switch to the next; the LIP starts from the measured CoM and speed at the
  first switch and from the *accumulated commanded* heading, so heading errors do not
  reset every step (the paper's "desired vs actual" figure);
* navigation (`emonav sim --steps-out`, `trace_tracking` of an episode's `EpisodeTrace`
  on either plant): a step runs from the planner instant t_k = kT to t_{k+1}; the LIP
  starts from the robot exactly as the planner saw it at t_k and u is the command u_k the
  planner computed there and held until t_{k+1}: the step the planner expected. Headings
  are unwrapped along the episode.

Everything here is NumPy; `error_statistics` summarises the error columns (mean, std,
RMS, median / 95th percentile / maximum of the absolute error).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from emonav_drake.navigation.episode_trace import EpisodeTrace, trace_columns
from emonav_drake.robot.lip import lip_steps, wrap_angles

COLUMNS = (
    "step",  # k: the step's index (foot switch k / planner instant t_k where it starts)
    "t_start",  # start of the step [s]
    "t",  # end of the step, where desired and achieved are compared [s]
    "u_v",  # the step's commanded sagittal speed [m/s]
    "u_dtheta",  # the step's commanded heading change [rad]
    "u_v_prev",  # the previous step's command [m/s] (0 before the first step)
    "u_dtheta_prev",  # [rad]
    "x_start",  # the state the LIP starts from: CoM x [m]
    "y_start",  # CoM y [m]
    "heading_start",  # heading [rad]
    "v_start",  # sagittal CoM speed [m/s]
    "x_des",  # the LIP step (Eq. 1) at t: CoM x [m]
    "y_des",  # CoM y [m]
    "heading_des",  # heading_start + u_dtheta [rad] (not wrapped)
    "x",  # achieved at t: CoM x [m]
    "y",  # CoM y [m]
    "heading",  # torso yaw [rad]
    "err_x",  # x − x_des [m], world frame
    "err_y",  # y − y_des [m]
    "err_heading",  # heading − heading_des wrapped to (−π, π] [rad]
    "err_forward",  # (err_x, err_y) along heading_des [m]
    "err_lateral",  # (err_x, err_y) across heading_des, to its left [m]
)
UNITS = {
    "step": "",
    "t_start": "s",
    "t": "s",
    "u_v": "m/s",
    "u_dtheta": "rad",
    "u_v_prev": "m/s",
    "u_dtheta_prev": "rad",
    "v_start": "m/s",
}
UNITS |= {c: "rad" for c in COLUMNS if "heading" in c}
UNITS |= {c: "m" for c in COLUMNS if c not in UNITS}
ERROR_COLUMNS = ("err_x", "err_y", "err_heading", "err_forward", "err_lateral")
STATISTICS = ("mean", "std", "rms", "p50", "p95", "max")
_INDEX = {name: i for i, name in enumerate(COLUMNS)}


def column(table: np.ndarray, name: str) -> np.ndarray:
    """The column `name` (one of `COLUMNS`) of a tracking table (n, len(COLUMNS))."""
    if name not in _INDEX:
        raise KeyError(f"{name!r} is not a tracking column ({', '.join(COLUMNS)})")
    return np.asarray(table, float).reshape(-1, len(COLUMNS))[:, _INDEX[name]]


def step_tracking(
    start: np.ndarray,
    commands: np.ndarray,
    achieved: np.ndarray,
    omega: float,
    step_time: float,
    *,
    t_start: np.ndarray,
    t: np.ndarray,
    previous: np.ndarray | None = None,
    steps: np.ndarray | None = None,
) -> np.ndarray:
    """The tracking table (n, len(`COLUMNS`)) of n steps.

    Args:
        start: (n, 4) the LIP's starting states (x [m], y [m], θ [rad], v [m/s]), world frame.
        commands: (n, 2) each step's command (u_v [m/s], u_Δθ [rad]).
        achieved: (n, 3) the measured CoM x, y [m] and heading [rad] at each step's end.
        omega: the LIP's ω = √(g/H) [1/s]; step_time: T [s].
        t_start, t: (n,) start and end times of the steps [s].
        previous: (n, 2) the command of the step before each (default: zeros).
        steps: (n,) step indices (default 0 … n − 1).
    """
    s = np.asarray(start, float).reshape(-1, 4)
    u = np.asarray(commands, float).reshape(-1, 2)
    a = np.asarray(achieved, float).reshape(-1, 3)
    n = len(s)
    prev = np.zeros((n, 2)) if previous is None else np.asarray(previous, float).reshape(-1, 2)
    k = np.arange(n, dtype=float) if steps is None else np.asarray(steps, float).reshape(-1)
    t0, t1 = np.asarray(t_start, float).reshape(-1), np.asarray(t, float).reshape(-1)
    if not (len(u) == len(a) == len(prev) == len(k) == len(t0) == len(t1) == n):
        raise ValueError("start, commands, achieved, previous, steps, t_start, t: lengths differ")
    desired = lip_steps(s, u, omega, step_time)
    heading_des = s[:, 2] + u[:, 1]  # = desired[:, 2] up to wrapping
    ex, ey = a[:, 0] - desired[:, 0], a[:, 1] - desired[:, 1]
    c, sn = np.cos(heading_des), np.sin(heading_des)
    return np.column_stack(
        [
            k,
            t0,
            t1,
            u,
            prev,
            s,
            desired[:, :2],
            heading_des,
            a,
            ex,
            ey,
            wrap_angles(a[:, 2] - heading_des),
            c * ex + sn * ey,
            -sn * ex + c * ey,
        ]
    ).reshape(-1, len(COLUMNS))


def sequence_tracking(
    times: np.ndarray,
    states: np.ndarray,
    commands: np.ndarray,
    omega: float,
    step_time: float,
    *,
    initial_command: Sequence[float] = (0.0, 0.0),
    first_step: int = 0,
) -> np.ndarray:
    """The tracking table of a sequence of steps: states (N + 1, 4) = (x, y, θ, v) at the
    instants times (N + 1,) [s], commands (N, 2) = u_0 … u_{N−1}, step k from states[k]
    under u_k to states[k + 1]. The headings are unwrapped along the sequence first;
    `initial_command` is the command before u_0 (zero: the robot stood)."""
    x = np.asarray(states, float).reshape(-1, 4).copy()
    u = np.asarray(commands, float).reshape(-1, 2)
    ts = np.asarray(times, float).reshape(-1)
    if len(x) != len(u) + 1 or len(ts) != len(x):
        raise ValueError(
            f"{len(x)} states and {len(ts)} times for {len(u)} commands (need N + 1 each)"
        )
    x[:, 2] = np.unwrap(x[:, 2])
    prev = np.vstack([np.asarray(initial_command, float).reshape(1, 2), u[:-1]])
    return step_tracking(
        x[:-1],
        u,
        x[1:, :3],
        omega,
        step_time,
        t_start=ts[:-1],
        t=ts[1:],
        previous=prev[: len(u)],
        steps=first_step + np.arange(len(u)),
    )


def trace_tracking(
    trace: EpisodeTrace | Sequence[dict], omega: float, step_time: float
) -> np.ndarray:
    """The tracking table of a navigation episode's trace, on either plant: an
    `EpisodeTrace` (`navigation/episode_trace.py`, one row per planner instant t_k) or its row
    dicts ("k", "t" [s], "robot" [x, y, θ, v] at t_k, "held" = u_{k−1}; other keys are
    ignored).

    Step k goes from row k to row k + 1 under u_k = row k + 1's "held". The last row is
    the episode's end; after a fall it is the instant of the fall, so the last step can be
    shorter than T (its `t` says so)."""
    if len(trace) < 2:
        return np.empty((0, len(COLUMNS)))
    k, times, robot, held = trace_columns(trace, "k", "t", "robot", "held")
    return sequence_tracking(
        times,
        robot,
        held[1:],
        omega,
        step_time,
        initial_command=held[0],
        first_step=int(k[0]),
    )


def error_statistics(
    table: np.ndarray, columns: Sequence[str] = ERROR_COLUMNS
) -> dict[str, dict[str, float]]:
    """Per error column: mean and std (population) of the signed error, RMS, and the
    median (p50), 95th percentile (p95) and maximum of the absolute error, in the column's
    unit (m or rad). NaN for an empty table."""
    out: dict[str, dict[str, float]] = {}
    for name in columns:
        e = column(table, name)
        if len(e) == 0:
            out[name] = {s: float("nan") for s in STATISTICS}
            continue
        a = np.abs(e)
        out[name] = {
            "mean": float(e.mean()),
            "std": float(e.std()),
            "rms": float(np.sqrt(np.mean(e**2))),
            "p50": float(np.percentile(a, 50)),
            "p95": float(np.percentile(a, 95)),
            "max": float(a.max()),
        }
    return out
