"""A walking person as a 2-D LiDAR sees them: two legs that swing with the gait (numpy only).

The crowd's pedestrian is a disc of `crowd.pedestrian_radius` (0.3 m) for ORCA, collisions,
discomfort zones and the maps' inflated (127) scan. A real planar LiDAR mounted at leg
height sees two small discs instead, whose spacing changes with every step. With
`sensor.people_as: legs` the real scan (the maps' 255 layer, the `scan` port, the "scan"
observation) casts these two discs per pedestrian; nothing else changes.

The model (docs/perception.md, "People as the LiDAR sees them"), in the pedestrian's frame
(x along the direction it faces, y to its left), at gait phase φ and speed v:

    left leg   ( +A(v)·sin φ, +HIP_HALF_WIDTH )
    right leg  ( −A(v)·sin φ, −HIP_HALF_WIDTH )
    A(v) = STRIDE_AMPLITUDE · min(v / REFERENCE_SPEED, 1)

both of radius `LEG_RADIUS`. The legs pass each other twice per gait cycle (φ = 0, π) and
are `2·STRIDE_AMPLITUDE` apart fore-aft at full stride (φ = ±π/2, at 1 m/s); a standing
pedestrian (v = 0) has them side by side, 2·HIP_HALF_WIDTH apart. Both legs stay inside
the 0.3 m disc: √(0.2² + 0.1²) + 0.07 = 0.294 m.

The phase advances with the distance walked, one cycle (two steps) per `GAIT_CYCLE_LENGTH`
metres, from a per-pedestrian offset drawn from the scenario's seed (`gait_offsets`); the
`Crowd` keeps each pedestrian's walked distance in its state, so the phase is a pure
function of the crowd's state and the diagram and the environment agree.

Frames: world frame, metres, radians, m/s.
"""

from __future__ import annotations

import math

import numpy as np

LEG_RADIUS = 0.07  # [m]: a shin/knee ≈ 0.12–0.16 m across at a leg-height scan plane
HIP_HALF_WIDTH = 0.1  # [m]: each leg this far left/right of the centre (hip width ≈ 0.2 m)
# [m]: fore-aft offset of each leg from the centre at full stride at the scan plane (the
# feet are ≈ one step, 0.65 m, apart at 1 m/s; at a plane ≈ 0.35 m up the legs, swinging
# from hips ≈ 0.9 m up, that shrinks to ≈ 0.65·(0.9 − 0.35)/0.9 ≈ 0.4 m between the legs)
STRIDE_AMPLITUDE = 0.2
REFERENCE_SPEED = 1.0  # [m/s]: the stride reaches STRIDE_AMPLITUDE at this speed
GAIT_CYCLE_LENGTH = 1.3  # [m] walked per gait cycle (two steps of 0.65 m at 1 m/s)
# salt of the gait offsets' seed: default_rng([GAIT_SEED_SALT, scenario seed])
GAIT_SEED_SALT = 0x6A17


def gait_offsets(seed: int, count: int) -> np.ndarray:
    """Each pedestrian's gait phase at the start [rad], (count,) uniform in [0, 2π), drawn
    from the scenario's `seed` (its own stream: no other draw changes)."""
    rng = np.random.default_rng([GAIT_SEED_SALT, int(seed) % 2**64])
    return rng.uniform(0.0, 2.0 * math.pi, int(count))


def gait_phase(walked: np.ndarray, offsets: np.ndarray) -> np.ndarray:
    """Gait phase [rad] in [0, 2π) of pedestrians that walked `walked` (P,) metres from
    their start phases `offsets` (P,) [rad]."""
    phase = offsets + (2.0 * math.pi / GAIT_CYCLE_LENGTH) * np.asarray(walked, dtype=float)
    return np.mod(phase, 2.0 * math.pi)


def leg_centers(
    positions: np.ndarray, velocities: np.ndarray, facing: np.ndarray, phase: np.ndarray
) -> np.ndarray:
    """Centres of the two legs of each pedestrian, (P, 2, 2) [m], world frame: [p, 0] the
    left leg, [p, 1] the right leg (module docstring).

    Args:
        positions: (P, 2) pedestrian centres [m].
        velocities: (P, 2) [m/s]; their norm sets the stride.
        facing: (P,) yaw each pedestrian faces [rad] (its walking direction).
        phase: (P,) gait phase [rad].
    """
    c = np.asarray(positions, dtype=float).reshape(-1, 2)
    v = np.asarray(velocities, dtype=float).reshape(-1, 2)
    yaw = np.asarray(facing, dtype=float).reshape(-1)
    speed = np.hypot(v[:, 0], v[:, 1])
    along = STRIDE_AMPLITUDE * np.minimum(speed / REFERENCE_SPEED, 1.0) * np.sin(phase)
    fwd = np.stack([np.cos(yaw), np.sin(yaw)], axis=1)  # (P, 2)
    left = np.stack([-fwd[:, 1], fwd[:, 0]], axis=1)
    offset = along[:, None] * fwd + HIP_HALF_WIDTH * left
    return np.stack([c + offset, c - offset], axis=1)


def leg_discs(
    positions: np.ndarray, velocities: np.ndarray, facing: np.ndarray, phase: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The legs of every pedestrian as discs: (centres (2P, 2) [m], radii (2P,) [m]),
    pedestrian p's left leg at row 2p, its right leg at 2p + 1 (`leg_centers`)."""
    centers = leg_centers(positions, velocities, facing, phase).reshape(-1, 2)
    return centers, np.full(len(centers), LEG_RADIUS)
