"""ALIP (Gong & Grizzle) prediction, foot placement and swing-foot trajectories (numpy only).

Per horizontal axis of the heading frame (sagittal s along the heading, lateral l to its
left), the angular-momentum LIP about the stance contact reads

    ẋ_c = ℒ / (m H),   ℒ̇ = m g x_c,

with x_c the CoM relative to the contact [m] and ℒ a "momentum velocity" [kg·m²/s]:
sagittally ℒ = L_y of the heading frame (= m H v_s for a CoM at height H), laterally
ℒ = −L_x (= m H v_l). Writing both axes the same way lets one formula serve both
(docs/walking.md). L about the contact is continuous through an impact, so the state just
before touchdown predicts the next step's start.

Foot placement: at the end of the current step (state x̂_c, ℒ̂), place the new contact so
that ℒ reaches ℒ_des at the end of the *next* step:

    x_c^des = (ℒ_des − cosh(ℓT) ℒ̂) / (m H ℓ sinh(ℓT)),   foot = x̂_c − x_c^des,

foot being measured from the current stance contact. ℒ_des = m H v_des sagittally and
±½ m H W ℓ tanh(ℓT/2) laterally (W the step width; + when the next stance is the right
foot, whose step ends with the CoM moving left).
"""

from __future__ import annotations

import math

import numpy as np

from emonav_drake.params import pendulum_frequency


def alip_predict(
    xc: float | np.ndarray,
    momentum: float | np.ndarray,
    elapsed: float,
    mass: float,
    height: float,
    gravity: float,
) -> tuple[float | np.ndarray, float | np.ndarray]:
    """ALIP state `elapsed` seconds later: (x_c [m], ℒ [kg·m²/s]), per axis."""
    ell = pendulum_frequency(height, gravity)
    c, s = math.cosh(ell * elapsed), math.sinh(ell * elapsed)
    mhl = mass * height * ell
    return c * xc + s * momentum / mhl, mhl * s * xc + c * momentum


def lateral_momentum_target(
    width: float,
    next_stance_right: bool,
    mass: float,
    height: float,
    step_time: float,
    gravity: float,
) -> float:
    """ℒ_l at the end of the next step for a periodic gait of step width W [kg·m²/s]."""
    ell = pendulum_frequency(height, gravity)
    mag = 0.5 * mass * height * width * ell * math.tanh(0.5 * ell * step_time)
    return mag if next_stance_right else -mag


def foot_placement(
    xc: float | np.ndarray,
    momentum: float | np.ndarray,
    remaining: float,
    momentum_target: float | np.ndarray,
    mass: float,
    height: float,
    step_time: float,
    gravity: float,
) -> float | np.ndarray:
    """Next contact relative to the current one [m], per axis (see the module docstring).

    Args:
        xc: CoM relative to the stance contact now [m].
        momentum: ℒ about the stance contact now [kg·m²/s].
        remaining: time left in the current step [s] (clipped at 0).
        momentum_target: ℒ_des at the end of the next step.
        mass, height, step_time, gravity: m [kg], H [m], T [s], g [m/s²].
    """
    x_end, m_end = alip_predict(xc, momentum, max(remaining, 0.0), mass, height, gravity)
    ell = pendulum_frequency(height, gravity)
    xc_des = (momentum_target - math.cosh(ell * step_time) * m_end) / (
        mass * height * ell * math.sinh(ell * step_time)
    )
    return x_end - xc_des


def mean_speed_factor(omega: float, step_time: float) -> float:
    """Mean speed of the periodic LIP gait over its switch speed, tanh(ωT/2)/(ωT/2)."""
    half = 0.5 * omega * step_time
    return math.tanh(half) / half


def quintic_blend(s: float) -> tuple[float, float, float]:
    """b(s) = 10s³ − 15s⁴ + 6s⁵ on [0, 1] (clamped) and its first two derivatives in s."""
    if s <= 0.0:
        return 0.0, 0.0, 0.0
    if s >= 1.0:
        return 1.0, 0.0, 0.0
    s2 = s * s
    return (
        s2 * s * (10.0 - 15.0 * s + 6.0 * s2),
        30.0 * s2 * (1.0 - 2.0 * s + s2),
        60.0 * s * (1.0 - 3.0 * s + 2.0 * s2),
    )


def swing_height(
    t: float, step_time: float, start_z: float, clearance: float, touchdown_speed: float
) -> tuple[float, float, float]:
    """Swing-foot height above its landing height: (z [m], ż [m/s], z̈ [m/s²]) at time t.

    Rises from `start_z` (zero velocity) to `clearance` at T/2 on a quintic, then falls
    on a cubic to 0 at T arriving with vertical speed −`touchdown_speed`; after T it keeps
    descending at that speed, so a late foot still reaches the ground.
    """
    half = 0.5 * step_time
    if t >= step_time:
        return -touchdown_speed * (t - step_time), -touchdown_speed, 0.0
    if t <= half:
        b, db, ddb = quintic_blend(t / half)
        dz = clearance - start_z
        return start_z + dz * b, dz * db / half, dz * ddb / half**2
    # Hermite cubic on u ∈ [0, 1]: z(0) = h, z'(0) = 0, z(1) = 0, z'(1) = −v_td·half.
    u = (t - half) / half
    h, m1 = clearance, -touchdown_speed * half
    # (the basis for the end value is dropped: it is 0)
    h00, h11 = 2 * u**3 - 3 * u**2 + 1, u**3 - u**2
    dh00, dh11 = 6 * u**2 - 6 * u, 3 * u**2 - 2 * u
    ddh00, ddh11 = 12 * u - 6, 6 * u - 2
    z = h * h00 + m1 * h11
    dz = (h * dh00 + m1 * dh11) / half
    ddz = (h * ddh00 + m1 * ddh11) / half**2
    return z, dz, ddz


def swing_horizontal(
    t: float, step_time: float, start: np.ndarray, target: np.ndarray, finish: float = 0.85
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Horizontal swing-foot reference: a quintic blend from `start` to `target` that
    arrives at `finish`·T and stays there. Returns position, velocity, acceleration."""
    duration = finish * step_time
    b, db, ddb = quintic_blend(t / duration)
    d = np.asarray(target) - np.asarray(start)
    return start + d * b, d * (db / duration), d * (ddb / duration**2)


def smooth_angle(
    t: float, duration: float, start: float, target: float
) -> tuple[float, float, float]:
    """Angle moving from `start` to `target` over `duration` on a quintic: θ, θ̇, θ̈."""
    b, db, ddb = quintic_blend(t / duration)
    d = target - start
    return start + d * b, d * db / duration, d * ddb / duration**2
