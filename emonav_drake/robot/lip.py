"""The linear inverted pendulum (LIP) step map of the paper's Eq. 1, in the world frame.

The reduced-order robot is a point CoM at constant height H walking in steps of
duration T. At each foot switch (step k) the navigation command u_k = (u_v, u_Δθ)
arrives:

* the heading turns at the switch: θ_{k+1} = θ_k + u_Δθ (wrapped to (−π, π]), and the
  whole step is walked along θ_{k+1} (the sagittal direction of the new stance);
* the foot is placed d_k ahead of the CoM (Eq. 1) so that the sagittal speed at the next
  switch equals u_v:  d_k = (v_k cosh ωT − u_v) / (ω sinh ωT);
* within the step the CoM moves Δx(t) = v_k sinh(ωt)/ω + d_k (1 − cosh ωt) along θ_{k+1},
  with speed v(t) = v_k cosh(ωt) − d_k ω sinh(ωt); at t = T this is Eq. 1's Δx^loc and
  v(T) = u_v exactly.

`LipState` is (x, y, θ, v): CoM position in the world frame [m], heading [rad] and
sagittal speed [m/s].
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np


class LipState(NamedTuple):
    """Reduced-order robot state at a foot switch (world frame)."""

    x: float  # CoM x [m]
    y: float  # CoM y [m]
    heading: float  # θ [rad]
    speed: float  # sagittal speed v [m/s]


def wrap_angle(a: float) -> float:
    """Wrap an angle to (−π, π]."""
    return math.atan2(math.sin(a), math.cos(a))


def wrap_angles(a: np.ndarray) -> np.ndarray:
    """`wrap_angle` element-wise on an array of angles [rad]."""
    return np.arctan2(np.sin(a), np.cos(a))


def foot_offset(speed: float, target_speed: float, omega: float, step_time: float) -> float:
    """Paper Eq. 1, first line: sagittal foot position ahead of the CoM, d_k [m]."""
    wt = omega * step_time
    return (speed * math.cosh(wt) - target_speed) / (omega * math.sinh(wt))


def sagittal_displacement(speed: float, d: float, omega: float, elapsed: float) -> float:
    """Paper Eq. 1, second line, at any time within the step: Δx(t) [m]."""
    wt = omega * elapsed
    return speed * math.sinh(wt) / omega + d * (1.0 - math.cosh(wt))


def sagittal_speed(speed: float, d: float, omega: float, elapsed: float) -> float:
    """Sagittal CoM speed within the step, v(t) = v cosh ωt − d ω sinh ωt [m/s]."""
    wt = omega * elapsed
    return speed * math.cosh(wt) - d * omega * math.sinh(wt)


def lip_step(
    state: LipState, u_speed: float, u_heading: float, omega: float, step_time: float
) -> LipState:
    """One walking step of the LIP model: the state at the next foot switch."""
    heading = wrap_angle(state.heading + u_heading)
    d = foot_offset(state.speed, u_speed, omega, step_time)
    dx = sagittal_displacement(state.speed, d, omega, step_time)
    return LipState(
        state.x + dx * math.cos(heading), state.y + dx * math.sin(heading), heading, float(u_speed)
    )


def lip_in_step(
    state: LipState,
    u_speed: float,
    u_heading: float,
    omega: float,
    step_time: float,
    elapsed: float,
) -> LipState:
    """The CoM `elapsed` s into a step: position, heading (the new one) and sagittal speed.

    `state` is the state at the start of the step, (u_speed, u_heading) the step's command.
    """
    if not 0.0 <= elapsed <= step_time + 1e-12:
        raise ValueError(f"elapsed = {elapsed} s is outside the step [0, {step_time}] s")
    heading = wrap_angle(state.heading + u_heading)
    d = foot_offset(state.speed, u_speed, omega, step_time)
    dx = sagittal_displacement(state.speed, d, omega, elapsed)
    v = sagittal_speed(state.speed, d, omega, elapsed)
    return LipState(state.x + dx * math.cos(heading), state.y + dx * math.sin(heading), heading, v)


def lip_velocity(state: LipState) -> np.ndarray:
    """World-frame CoM velocity (2,) [m/s]: the sagittal speed along the heading."""
    return np.array([state.speed * math.cos(state.heading), state.speed * math.sin(state.heading)])


def lip_steps(
    states: np.ndarray, commands: np.ndarray, omega: float, step_time: float
) -> np.ndarray:
    """`lip_step` row by row: the states (n, 4) = (x, y, θ, v) at the next switch of
    starting states (n, 4) under commands (n, 2) = (u_v [m/s], u_Δθ [rad]); world frame,
    headings wrapped to (−π, π]."""
    s = np.asarray(states, float).reshape(-1, 4)
    u = np.asarray(commands, float).reshape(-1, 2)
    if len(s) != len(u):
        raise ValueError(f"{len(s)} states but {len(u)} commands")
    out = [
        tuple(lip_step(LipState(*map(float, a)), float(c[0]), float(c[1]), omega, step_time))
        for a, c in zip(s, u, strict=True)
    ]
    return np.array(out, float).reshape(-1, 4)


def lip_rollout(state: LipState, plans: np.ndarray, omega: float, step_time: float) -> np.ndarray:
    """CoM positions (C, 2·H, 2) at the middle and the end of each of H steps of the LIP
    (Eq. 1) from `state`, for C command plans (C, H, 2) = (u_v [m/s], u_Δθ [rad]) per step
    (world frame, or whichever frame `state` is written in)."""
    plan = np.asarray(plans, float)
    if plan.ndim != 3 or plan.shape[2] != 2:
        raise ValueError(f"plans must be (C, H, 2), got {plan.shape}")
    c, steps = plan.shape[:2]
    wt, wh = omega * step_time, omega * step_time / 2
    ch, sh, ch_mid, sh_mid = math.cosh(wt), math.sinh(wt), math.cosh(wh), math.sinh(wh)
    out = np.empty((c, 2 * steps, 2))
    x, y = np.full(c, state.x), np.full(c, state.y)
    th, v = np.full(c, state.heading), np.full(c, state.speed)
    for h in range(steps):
        v_cmd = plan[:, h, 0]
        th = th + plan[:, h, 1]
        d = (v * ch - v_cmd) / (omega * sh)
        dx_mid = v * sh_mid / omega + d * (1.0 - ch_mid)
        dx_end = v * sh / omega + d * (1.0 - ch)
        cos, sin = np.cos(th), np.sin(th)
        out[:, 2 * h, 0], out[:, 2 * h, 1] = x + dx_mid * cos, y + dx_mid * sin
        x, y = x + dx_end * cos, y + dx_end * sin
        out[:, 2 * h + 1, 0], out[:, 2 * h + 1, 1] = x, y
        v = v_cmd
    return out


def held_plans(candidates: np.ndarray, steps: int) -> np.ndarray:
    """Plans (C, steps, 2) that hold each candidate command (C, 2) for `steps` steps."""
    cand = np.asarray(candidates, float).reshape(-1, 2)
    return np.repeat(cand[:, None, :], steps, axis=1)
