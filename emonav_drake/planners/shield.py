"""A categorical policy behind the LGM safety shield (`planning/lgm_shield.py`).

`--planner policy_shield` runs a policy checkpoint (by default the MPC route's student,
`emobipednav_digit_mpc`, on which it was tuned and measured) and walks, of its 99 grid
commands, the best-scored one after which the robot can still stop
clear of every LiDAR hit of its newest LGM frame, predicting with the LIP of Eq. 1.
`policy_shield_digit` predicts with the full-order Digit's fitted step response instead
(it remembers u_{k−2} and the previous pose, as `dwa_digit` does). Neither is the paper's
method: both are the paper's policy plus a layer that reads nothing the policy does not.
"""

from __future__ import annotations

import dataclasses as dc

import numpy as np

from emonav_drake.navigation.lip_world import PlannerInput
from emonav_drake.navigation.observations import observation_kind
from emonav_drake.params import EmoNavConfig
from emonav_drake.planners.policy import (
    PolicyError,
    PolicyPlanner,
    WrappedPolicy,
    describe_policy,
)
from emonav_drake.planning.dwa import ResponseMemory
from emonav_drake.planning.lgm_shield import (
    ShieldParams,
    body_velocities,
    brake_plans,
    lgm_hit_points,
    moving_points,
    path_gaps,
    shield_choice,
    shield_distribution,
    to_world,
    zone_intrusion,
)
from emonav_drake.robot.lip import LipState, lip_rollout
from emonav_drake.robot.step_response import StepResponseModel


def default_shield_params(response: StepResponseModel | str | None) -> ShieldParams:
    """The registered shields' settings for a prediction model: Digit answers a command a
    step late, so with a response model it brakes two steps and keeps 0.1 m from moving
    hits; the LIP brakes one step and keeps 0.2 m (the best of 0.1 / 0.2 / 0.3 m on tuning
    seeds, docs/shield.md)."""
    if response:
        return ShieldParams(margin=0.1, brake_steps=2)
    return ShieldParams(margin=0.2)


# Observation kinds whose stack begins with the LGM frames (the shield reads the newest).
LGM_KINDS = ("lgm", "lgm_vel", "lgm_tracks")


@dc.dataclass(frozen=True)
class ShieldMemory:
    """What the shield carries from one walking step to the next.

    Attributes:
        response: u_{k−2} and the previous pose for a response-model prediction, else None.
        seen: the previous frame's LiDAR hits in the world frame (n, 2) [m], None at the
            first step or when every point keeps the same margin.
    """

    response: ResponseMemory | None = None
    seen: np.ndarray | None = None


class ShieldedPolicy(WrappedPolicy):
    """A categorical `PolicyPlanner` whose command passes the LGM shield.

    Args:
        policy: the policy (categorical, reading an "lgm" observation).
        config: robot radius, LIP constants (ω, T) and the LiDAR (K, L) the LGM was built with.
        response: None predicts with the LIP; a `StepResponseModel` with the fitted response
            of the full-order robot (commands u_{k−2}, u_{k−1} already sent come first).
        params: the shield's margin and braking steps.

    The planner input's `lgm_stack` is the policy's observation (uint8 (N, M, M), oldest
    first, robot frame at the foot switch); the command is (u_v [m/s], u_Δθ [rad]).
    `last_admissible` says whether the last command passed the shield (False: no command
    did, and the one keeping the largest gap was walked); it is a diagnostic written by
    every planning step and never read back, so the command stays a function of
    (input, memory) alone. `last_distribution` (C,), written with it, is the shield as a
    distribution over the commands (`shield_distribution`): a distilling route's soft label.
    """

    name = "policy_shield"

    @classmethod
    def registered(
        cls,
        policy: PolicyPlanner,
        config: EmoNavConfig,
        response: StepResponseModel | None = None,
    ) -> ShieldedPolicy:
        """`policy` behind the shield with the registered shields' settings for `response`
        (`default_shield_params`): the one way the package builds a shield (the
        `*_shield` planners, the "shield" DAgger expert, the shielded MPC-nearby expert)."""
        return cls(policy, config, response, default_shield_params(response))

    def __init__(
        self,
        policy: PolicyPlanner,
        config: EmoNavConfig,
        response: StepResponseModel | None = None,
        params: ShieldParams | None = None,
    ) -> None:
        if policy.meta["kind"] != "categorical" or policy.grid_kind not in LGM_KINDS:
            raise PolicyError(
                f"the LGM shield needs a categorical policy reading the LGM; {policy.path.name} "
                f"is a {describe_policy(policy.meta)} reading {policy.grid_kind!r}"
            )
        self.policy = policy
        self._newest_lgm = -1 - observation_kind(policy.grid_kind).extra_planes  # stack row
        self.config = config
        self.response = response
        self.params = params if params is not None else ShieldParams()
        self.plans = brake_plans(policy.commands, self.params.brake_steps)
        self.last_admissible = True
        self.last_distribution: np.ndarray | None = None
        self._memory = self.initial_memory()

    def describe(self) -> str:
        """The policy, and the shield's prediction, margins and braking steps."""
        model = "LIP" if self.response is None else "Digit's step response"
        p = self.params
        margins = (
            f"margin {p.margin:g} m"
            if p.static_margin is None
            else f"margin {p.margin:g} m from moving hits, {p.static_margin:g} m from still ones"
        )
        motion = ", moving hits at their velocity" if p.predict_motion else ""
        comfort = (
            f", {p.comfort_weight:g}/m off the score per metre into still discs' zones"
            if p.comfort_weight
            else ""
        )
        return (
            f"{self.policy.describe()} behind the LGM shield ({model} prediction, {margins}"
            f"{motion}{comfort}, {p.brake_steps} braking step(s))"
        )

    def initial_memory(self) -> ShieldMemory:
        """Nothing seen yet (and, with a response model, no command sent before)."""
        return ShieldMemory(None if self.response is None else ResponseMemory())

    def reset(self) -> None:
        """Back to `initial_memory()` (a new episode)."""
        self._memory = self.initial_memory()

    def predicted_paths(self, obs: PlannerInput, memory: ShieldMemory | None) -> np.ndarray:
        """CoM positions (C, 2·(1 + brake_steps), 2) in the robot frame of the foot switch
        (x forward, y left) [m], for every command followed by the braking steps."""
        r = self.config.robot
        if self.response is None:
            start = LipState(0.0, 0.0, 0.0, float(obs.robot.speed))
            return lip_rollout(start, self.plans, r.omega, r.step_time)
        mem = memory.response if memory is not None and memory.response else ResponseMemory()
        start = LipState(0.0, 0.0, 0.0, mem.step_speed(obs.robot, r.step_time))
        return self.response.rollout_plans(start, mem.committed(obs), self.plans)

    def point_margins(
        self, points: np.ndarray, pose: np.ndarray, memory: ShieldMemory | None
    ) -> tuple[np.ndarray, np.ndarray | None, np.ndarray]:
        """(each point's margin (n,) [m], the points in the world frame to remember — None
        when every point keeps `margin` —, which points move (n,) bool)."""
        p = self.params
        if p.static_margin is None:
            return np.full(len(points), p.margin), None, np.ones(len(points), bool)
        world = to_world(points, pose)
        seen = memory.seen if memory is not None else None
        moving = moving_points(world, seen, p.static_match, p.body)
        return np.where(moving, p.margin, p.static_margin), world, moving

    def point_velocities(
        self,
        world: np.ndarray | None,
        moving: np.ndarray,
        pose: np.ndarray,
        memory: ShieldMemory | None,
        samples: int,
    ) -> tuple[np.ndarray | None, np.ndarray | None]:
        """(each point's velocity (n, 2) in the robot frame [m/s], the path samples' times
        (S,) [s]) with `predict_motion`, else (None, None): still points never move."""
        p = self.params
        seen = memory.seen if memory is not None else None
        if not p.predict_motion or world is None or seen is None:
            return None, None
        step_time = self.config.robot.step_time
        v = body_velocities(world, seen, p.body, step_time, p.max_body_speed)
        v[~moving] = 0.0
        c, s = np.cos(pose[2]), np.sin(pose[2])
        v_robot = np.stack([c * v[:, 0] + s * v[:, 1], -s * v[:, 0] + c * v[:, 1]], axis=1)
        return v_robot, step_time * (np.arange(samples) + 1) / 2

    def static_intrusion(
        self, paths: np.ndarray, points: np.ndarray, moving: np.ndarray
    ) -> np.ndarray:
        """How deep (C,) [m] each path (robot frame) reaches into the discomfort zones of the
        still points among `points` (n, 2) (r_robot + d_static around each; `zone_intrusion`)."""
        reach = self.config.robot.radius + self.config.reward.static_discomfort
        return zone_intrusion(paths, points[~moving], reach)

    def plan_with_memory(
        self, obs: PlannerInput, memory: ShieldMemory | None
    ) -> tuple[np.ndarray, ShieldMemory]:
        """The shielded command and the next memory (the planner interface of the diagram)."""
        stack = self.policy.check_observation(obs.lgm_stack)
        scores = self.policy.command_scores(stack, self.policy.goal_state(obs), obs.last_command)
        gaps, scores, next_memory = self.gaps(obs, stack, scores, memory)
        clearance = self.config.robot.radius
        best, self.last_admissible = shield_choice(scores, gaps, clearance)
        self.last_distribution = shield_distribution(scores, gaps, clearance)
        return self.policy.commands[best].copy(), next_memory

    def gaps(
        self,
        obs: PlannerInput,
        stack: np.ndarray,
        scores: np.ndarray,
        memory: ShieldMemory | None,
    ) -> tuple[np.ndarray, np.ndarray, ShieldMemory]:
        """(each command's gap (C,) [m] — admissible where ≥ the robot's radius —, the
        scores less the comfort penalty (`comfort_weight`), the next memory) for the
        checked observation `stack` and the policy's `scores` (C,)."""
        li = self.config.lidar
        points = lgm_hit_points(stack[self._newest_lgm], li.num_beams, li.max_range)
        rb = obs.robot
        pose = np.array([rb.x, rb.y, rb.heading])
        margins, world, moving = self.point_margins(points, pose, memory)
        paths = self.predicted_paths(obs, memory)
        velocities, times = self.point_velocities(world, moving, pose, memory, paths.shape[1])
        gaps = path_gaps(paths, points, margins, velocities, times)
        if self.params.comfort_weight:
            intrusion = self.static_intrusion(paths, points, moving)
            scores = scores - self.params.comfort_weight * intrusion
        sent = None if self.response is None else ResponseMemory.after(obs)
        return gaps, scores, ShieldMemory(sent, world)

    def plan(self, obs: PlannerInput) -> np.ndarray:
        """The command (u_v [m/s], u_Δθ [rad]) for this walking step."""
        command, self._memory = self.plan_with_memory(obs, self._memory)
        return command
