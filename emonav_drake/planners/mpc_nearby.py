"""A categorical policy steered by the MPC: the "mpc_nearby" DAgger expert.

At every walking step the OSQP MPC (`planners/mpc.py`, with the privileged crowd state and,
on Digit, its fitted step response) plans its command; the policy scores its 99 grid
commands from its own LGM; the planner walks the best-scored command within `cells` grid
steps of the MPC's (`planning/nearby_labels.py`). `last_distribution` is the policy's softmax
over those commands — the soft label a distilling route learns (`DaggerConfig.expert`
"mpc_nearby"). Not the paper's method: a teacher that keeps the student's own ranking and
takes from the MPC only where to go. With a `shield` (an LGM shield around the same
policy) only the commands it admits may be chosen: the MPC's guidance, restricted to what
is safe as the policy's own LGM shows it; where none of the nearby commands is admitted,
the shield's own distribution (safety first).
"""

from __future__ import annotations

import dataclasses as dc

import numpy as np

from emonav_drake.navigation.lip_world import PlannerInput
from emonav_drake.planners.mpc import MpcMemory, MpcPlanner
from emonav_drake.planners.policy import (
    PolicyError,
    PolicyPlanner,
    WrappedPolicy,
    describe_policy,
)
from emonav_drake.planners.shield import ShieldedPolicy, ShieldMemory
from emonav_drake.planning.lgm_shield import shield_distribution
from emonav_drake.planning.nearby_labels import nearby_mask, restricted_softmax


@dc.dataclass(frozen=True)
class NearbyMemory:
    """The MPC's memory and, with a shield, the shield's."""

    mpc: MpcMemory
    shield: ShieldMemory | None = None


class MpcNearbyPolicy(WrappedPolicy):
    """A categorical `PolicyPlanner` choosing among the commands next to the MPC's.

    Args:
        policy: the policy (categorical; with a shield, reading an "lgm" observation).
        mpc: the MPC whose command sets where to go (its memory is this planner's).
        cells: grid steps around the MPC's command, in u_v and in u_Δθ, the choice may take.
        shield: None, or the LGM shield around `policy` whose admissible commands bound
            the choice.

    The planner input's `lgm_stack` is the policy's observation (for an LGM policy uint8
    (N, M, M), oldest first, robot frame at the foot switch), its `crowd` the MPC's (world
    frame); the command is (u_v [m/s], u_Δθ [rad]). `last_mpc_command` and
    `last_distribution` (C,) are written by every planning step and never read back.
    """

    name = "policy_mpc_nearby"

    def __init__(
        self,
        policy: PolicyPlanner,
        mpc: MpcPlanner,
        cells: int = 1,
        shield: ShieldedPolicy | None = None,
    ) -> None:
        if policy.meta["kind"] != "categorical":
            raise PolicyError(
                f"mpc_nearby needs a categorical policy; {policy.path.name} is a "
                f"{describe_policy(policy.meta)}"
            )
        if not isinstance(cells, int) or cells < 0:
            raise ValueError(f"cells must be an int >= 0, got {cells!r}")
        if shield is not None and shield.policy is not policy:
            raise ValueError("the shield must wrap the same policy object")
        self.policy, self.mpc, self.cells, self.shield = policy, mpc, cells, shield
        self.last_mpc_command: np.ndarray | None = None
        self.last_distribution: np.ndarray | None = None
        self._memory = self.initial_memory()

    def describe(self) -> str:
        """The policy and how far from the MPC's command it may choose."""
        within = " among the LGM shield's admissible commands" if self.shield else ""
        return (
            f"{self.policy.describe()} choosing within {self.cells} grid step(s) of the "
            f"MPC's command{within}"
        )

    def initial_memory(self) -> NearbyMemory:
        """The MPC's (and the shield's) memory at the start of an episode."""
        shield = self.shield.initial_memory() if self.shield is not None else None
        return NearbyMemory(self.mpc.initial_memory(), shield)

    def reset(self) -> None:
        """Back to `initial_memory()` (a new episode)."""
        self._memory = self.initial_memory()

    def plan_with_memory(
        self, obs: PlannerInput, memory: NearbyMemory | None
    ) -> tuple[np.ndarray, NearbyMemory]:
        """The command next to the MPC's that the policy scores best (and the shield
        admits), and the next memory."""
        memory = memory if memory is not None else self.initial_memory()
        target, mpc_memory = self.mpc.plan_with_memory(obs, memory.mpc)
        stack = self.policy.check_observation(obs.lgm_stack)
        scores = self.policy.command_scores(stack, self.policy.goal_state(obs), obs.last_command)
        allowed = nearby_mask(self.policy.commands, target, self.cells)
        shield_memory = None
        if self.shield is None:
            dist = restricted_softmax(scores, allowed)
        else:
            gaps, scores, shield_memory = self.shield.gaps(obs, stack, scores, memory.shield)
            clearance = self.shield.config.robot.radius
            safe = allowed & (gaps >= clearance)
            dist = (
                restricted_softmax(scores, safe)
                if safe.any()
                else shield_distribution(scores, gaps, clearance)
            )
        self.last_mpc_command = np.asarray(target, float).copy()
        self.last_distribution = dist
        command = self.policy.commands[int(np.argmax(dist))].copy()
        return command, NearbyMemory(mpc_memory, shield_memory)

    def plan(self, obs: PlannerInput) -> np.ndarray:
        """The command (u_v [m/s], u_Δθ [rad]) for this walking step."""
        command, self._memory = self.plan_with_memory(obs, self._memory)
        return command
