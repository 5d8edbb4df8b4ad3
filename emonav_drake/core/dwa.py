"""The Dynamic Window Approach on the LIP model — the paper's DWA baseline (§IV-D).

The classic DWA (Fox et al.) samples a wheeled robot's (v, ω) and rolls its kinematics
forward; here the samples are the walking-step commands (u_v, u_Δθ) within the paper's
bounds and the rollout is the LIP step map of Eq. 1 (`core/lip.py`), holding the command
for `horizon_steps` steps. Pedestrians are predicted at constant velocity, static discs
stay put (privileged crowd state, as the baseline is model-based).

Each candidate is checked at the middle and the end of every step:

* it is rejected if it hits a static disc anywhere or a pedestrian within the first two
  steps (the prediction is good that far); later predicted contacts cost a penalty;
* score = goal progress + clearance (capped) − discomfort intrusion + speed, weighted by
  `DwaParams`. Discomfort intrusion is how far the robot would enter the emotion-sized
  discomfort zones (pedestrian: d_emo; static: d_static) summed over the samples.

Ties break towards the first candidate in a fixed order (slow → fast, right → left), so
the choice is deterministic.
"""

from __future__ import annotations

import math

import numpy as np

from emonav_drake.core.navigation import PlannerInput
from emonav_drake.params import DwaParams, EmoNavConfig

_SAFETY = 0.05  # extra collision margin in the rollout [m]
_LATE_COLLISION_PENALTY = 5.0


class DwaPlanner:
    """DWA over LIP walking steps.

    Args:
        config: robot bounds and LIP constants, and the `dwa` weights.
    """

    name = "dwa"

    def __init__(self, config: EmoNavConfig) -> None:
        self.config = config
        p: DwaParams = config.dwa
        r = config.robot
        speeds = np.linspace(0.0, r.max_speed, p.speed_samples)
        turns = np.linspace(-r.max_heading_change, r.max_heading_change, p.heading_samples)
        grid_v, grid_t = np.meshgrid(speeds, turns, indexing="ij")
        self.candidates = np.stack([grid_v.ravel(), grid_t.ravel()], axis=1)  # (C, 2)
        wt = r.omega * r.step_time
        self._ch, self._sh = math.cosh(wt), math.sinh(wt)
        wh = r.omega * r.step_time / 2
        self._ch_mid, self._sh_mid = math.cosh(wh), math.sinh(wh)

    def initial_memory(self) -> None:
        """DWA keeps no memory between steps."""
        return None

    def reset(self) -> None:
        """DWA keeps no memory between steps."""

    def plan_with_memory(self, obs: PlannerInput, memory: None) -> tuple[np.ndarray, None]:
        """`plan(obs)` and the (empty) memory: the planner interface of the diagram."""
        return self.plan(obs), None

    def _rollout(self, x0: float, y0: float, th0: float, v0: float) -> np.ndarray:
        """CoM positions (C, 2·H, 2) at the middle and end of each of H steps."""
        r, p = self.config.robot, self.config.dwa
        om = r.omega
        v_cmd, turn = self.candidates[:, 0], self.candidates[:, 1]
        c = len(v_cmd)
        out = np.empty((c, 2 * p.horizon_steps, 2))
        x, y = np.full(c, x0), np.full(c, y0)
        th, v = np.full(c, th0), np.full(c, v0)
        for h in range(p.horizon_steps):
            th = th + turn
            d = (v * self._ch - v_cmd) / (om * self._sh)
            dx_mid = v * self._sh_mid / om + d * (1.0 - self._ch_mid)
            dx_end = v * self._sh / om + d * (1.0 - self._ch)
            cos, sin = np.cos(th), np.sin(th)
            out[:, 2 * h, 0], out[:, 2 * h, 1] = x + dx_mid * cos, y + dx_mid * sin
            x, y = x + dx_end * cos, y + dx_end * sin
            out[:, 2 * h + 1, 0], out[:, 2 * h + 1, 1] = x, y
            v = v_cmd
        return out

    def plan(self, obs: PlannerInput) -> np.ndarray:
        """The command (u_v [m/s], u_Δθ [rad]) for this walking step."""
        cfg, p = self.config, self.config.dwa
        r_robot, step_time = cfg.robot.radius, cfg.robot.step_time
        rb = obs.robot
        traj = self._rollout(rb.x, rb.y, rb.heading, rb.speed)  # (C, S, 2)
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
        hit_static = (st_gap <= r_robot + _SAFETY).any(axis=(1, 2))
        ped_hit = ped_gap <= r_robot + _SAFETY  # (C, S, P)
        hit_early = ped_hit[:, :4].any(axis=(1, 2))  # first two steps
        hit_late = ped_hit[:, 4:].any(axis=(1, 2))
        feasible = ~(hit_static | hit_early)

        all_gap = np.concatenate([ped_gap, st_gap], axis=2)
        if all_gap.shape[2]:
            clearance = np.clip(all_gap.min(axis=(1, 2)) - r_robot, 0.0, p.clearance_cap)
            zone = np.concatenate(
                [crowd.discomfort, np.full(st_gap.shape[2], crowd.static_discomfort)]
            )
            intrusion = np.clip(zone + r_robot - all_gap, 0.0, None).sum(axis=(1, 2)) / samples
        else:
            clearance = np.full(len(traj), p.clearance_cap)
            intrusion = np.zeros(len(traj))

        d_now = math.hypot(obs.goal_xy[0] - rb.x, obs.goal_xy[1] - rb.y)
        d_end = np.linalg.norm(traj[:, -1, :] - obs.goal_xy, axis=1)
        reach = cfg.robot.max_speed * step_time * p.horizon_steps
        score = (
            p.goal_weight * (d_now - d_end) / reach
            + p.clearance_weight * clearance / p.clearance_cap
            - p.discomfort_weight * intrusion
            + p.speed_weight * self.candidates[:, 0] / cfg.robot.max_speed
            - _LATE_COLLISION_PENALTY * hit_late
        )
        if feasible.any():
            best = int(np.argmax(np.where(feasible, score, -np.inf)))
        else:  # everything collides: take the candidate that stays farthest away
            best = int(np.argmax(all_gap.min(axis=(1, 2)) if all_gap.shape[2] else score))
        return self.candidates[best].copy()
