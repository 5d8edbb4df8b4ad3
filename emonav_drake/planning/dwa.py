"""The Dynamic Window Approach on the LIP model — the paper's DWA baseline (§IV-D).

The classic DWA (Fox et al.) samples a wheeled robot's (v, ω) and rolls its kinematics
forward; here the samples are the walking-step commands (u_v, u_Δθ) within the paper's
bounds and the rollout is the LIP step map of Eq. 1 (`robot/lip.py`), holding the command
for `horizon_steps` steps. Pedestrians are predicted at constant velocity, static discs
stay put (privileged crowd state, as the baseline is model-based).

Each candidate is checked at the middle and the end of every step:

* it is rejected if it comes within `safety_margin` of a static disc anywhere or of a
  pedestrian within the first `hard_steps` steps (the prediction is good that far);
  later predicted contacts cost a penalty;
* score = goal progress + clearance (capped) − discomfort intrusion + speed, weighted by
  `DwaParams`. Discomfort intrusion is how far the robot would enter the emotion-sized
  discomfort zones (pedestrian: d_emo; static: d_static) summed over the samples.

Ties break towards the first candidate in a fixed order (slow → fast, right → left), so
the choice is deterministic.
"""

from __future__ import annotations

import dataclasses as dc
import math

import numpy as np

from emonav_drake.navigation.lip_world import PlannerInput
from emonav_drake.params import DwaParams, EmoNavConfig
from emonav_drake.robot.lip import LipState, held_plans, lip_rollout


@dc.dataclass(frozen=True)
class ResponseMemory:
    """What a planner with a response model remembers from the previous planner instant.

    Attributes:
        command: u_{k−2}, the command that was the previous command one step ago.
        pose: (x [m], y [m], θ [rad]) of the robot then, or None at the first step.
    """

    command: np.ndarray = dc.field(default_factory=lambda: np.zeros(2))
    pose: np.ndarray | None = None

    def committed(self, obs: PlannerInput) -> np.ndarray:
        """(u_{k−2}, u_{k−1}) (2, 2): the commands already sent when `obs` is planned."""
        return np.stack([self.command, np.asarray(obs.last_command, float)])

    @staticmethod
    def after(obs: PlannerInput) -> ResponseMemory:
        """What the next planner instant remembers of this one: u_{k−1} (which will then be
        u_{k−2}) and the robot's pose now."""
        rb = obs.robot
        return ResponseMemory(
            np.asarray(obs.last_command, float).copy(), np.array([rb.x, rb.y, rb.heading])
        )

    def step_speed(self, robot: LipState, step_time: float) -> float:
        """v̄: the forward displacement since then over T (the robot's own speed at the
        first step) — the speed the response model is written in."""
        if self.pose is None:
            return float(robot.speed)
        dx, dy = robot.x - self.pose[0], robot.y - self.pose[1]
        th = self.pose[2]
        return float((math.cos(th) * dx + math.sin(th) * dy) / step_time)


_LATE_COLLISION_PENALTY = 5.0


def command_candidates(config: EmoNavConfig) -> np.ndarray:
    """The candidate commands (C, 2) of (u_v [m/s], u_Δθ [rad]): `dwa.speed_samples` speeds
    in [0, ū_v] × `dwa.heading_samples` heading changes in [−ū_Δθ, ū_Δθ], slow → fast,
    right → left (the tie-breaking order)."""
    p: DwaParams = config.dwa
    r = config.robot
    speeds = np.linspace(0.0, r.max_speed, p.speed_samples)
    turns = np.linspace(-r.max_heading_change, r.max_heading_change, p.heading_samples)
    grid_v, grid_t = np.meshgrid(speeds, turns, indexing="ij")
    return np.stack([grid_v.ravel(), grid_t.ravel()], axis=1)


def lip_candidate_positions(
    config: EmoNavConfig, candidates: np.ndarray, start: LipState
) -> np.ndarray:
    """CoM positions (C, 2·H, 2) [m], world frame, at the middle and end of each of the
    H = `dwa.horizon_steps` steps of every candidate held, walked by the LIP (Eq. 1)."""
    r, p = config.robot, config.dwa
    plans = held_plans(candidates, p.horizon_steps)
    return lip_rollout(start, plans, r.omega, r.step_time)


def choose_candidate(
    config: EmoNavConfig, obs: PlannerInput, candidates: np.ndarray, traj: np.ndarray
) -> np.ndarray:
    """The best of `candidates` (C, 2) given their predicted CoM positions `traj` (C, S, 2)
    at the middle and end of each step (see the module: rejection, score, tie-breaking)."""
    p = config.dwa
    r_robot, step_time = config.robot.radius, config.robot.step_time
    rb = obs.robot
    samples = traj.shape[1]
    times = step_time * (np.arange(samples) + 1) / 2  # mid and end of each step
    crowd = obs.crowd

    # Pedestrians at constant velocity: (S, P, 2); gaps robot centre → surface (C, S, P).
    ped = crowd.positions[None, :, :] + times[:, None, None] * crowd.velocities[None, :, :]
    ped_gap = np.linalg.norm(traj[:, :, None, :] - ped[None], axis=-1) - crowd.radius
    st_gap = (
        np.linalg.norm(traj[:, :, None, :] - crowd.static_centers[None, None], axis=-1)
        - crowd.static_radii
    )
    margin, hard = r_robot + p.safety_margin, 2 * p.hard_steps
    hit_static = (st_gap <= margin).any(axis=(1, 2))
    ped_hit = ped_gap <= margin  # (C, S, P)
    hit_early = ped_hit[:, :hard].any(axis=(1, 2))  # the first `hard_steps` steps
    hit_late = ped_hit[:, hard:].any(axis=(1, 2))
    feasible = ~(hit_static | hit_early)

    all_gap = np.concatenate([ped_gap, st_gap], axis=2)
    if all_gap.shape[2]:
        clearance = np.clip(all_gap.min(axis=(1, 2)) - r_robot, 0.0, p.clearance_cap)
        zone = np.concatenate([crowd.discomfort, np.full(st_gap.shape[2], crowd.static_discomfort)])
        intrusion = np.clip(zone + r_robot - all_gap, 0.0, None).sum(axis=(1, 2)) / samples
    else:
        clearance = np.full(len(traj), p.clearance_cap)
        intrusion = np.zeros(len(traj))

    d_now = math.hypot(obs.goal_xy[0] - rb.x, obs.goal_xy[1] - rb.y)
    d_end = np.linalg.norm(traj[:, -1, :] - obs.goal_xy, axis=1)
    reach = config.robot.max_speed * step_time * p.horizon_steps
    score = (
        p.goal_weight * (d_now - d_end) / reach
        + p.clearance_weight * clearance / p.clearance_cap
        - p.discomfort_weight * intrusion
        + p.speed_weight * candidates[:, 0] / config.robot.max_speed
        - _LATE_COLLISION_PENALTY * hit_late
    )
    if feasible.any():
        best = int(np.argmax(np.where(feasible, score, -np.inf)))
    else:  # everything collides: take the candidate that stays farthest away
        best = int(np.argmax(all_gap.min(axis=(1, 2)) if all_gap.shape[2] else score))
    return candidates[best].copy()
