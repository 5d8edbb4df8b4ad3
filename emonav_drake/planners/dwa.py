"""The DWA planner: the paper's Dynamic Window Approach baseline (§IV-D) as a planner.

The algorithm (candidates, rollouts, rejection, score, tie-breaking) is `planning/dwa.py`'s;
this is the planner object around it (`planners.protocol.Planner`): its memory when it
plans with a fitted step-response model, `plan_with_memory` for the diagram and `plan` /
`reset` for the Gymnasium environment.
"""

from __future__ import annotations

import numpy as np

from emonav_drake.navigation.lip_world import PlannerInput
from emonav_drake.params import EmoNavConfig
from emonav_drake.planning.dwa import (
    ResponseMemory,
    choose_candidate,
    command_candidates,
    lip_candidate_positions,
)
from emonav_drake.robot.lip import LipState
from emonav_drake.robot.step_response import StepResponseModel


class DwaPlanner:
    """DWA over LIP walking steps, or over the steps of a fitted response model.

    Args:
        config: robot bounds and LIP constants, and the `dwa` weights.
        response: None rolls out the LIP (Eq. 1) from the robot's state; a
            `StepResponseModel` rolls out the calibrated robot instead, with the commands
            already sent (u_{k−2} from the memory, u_{k−1} = `obs.last_command`) first and
            the step-averaged speed measured from the memory's previous pose.

    Attributes:
        candidates: the commands it chooses among (C, 2) of (u_v [m/s], u_Δθ [rad]), in
            the tie-breaking order (`planning.dwa.command_candidates`).
    """

    name = "dwa"

    def __init__(self, config: EmoNavConfig, response: StepResponseModel | None = None) -> None:
        self.config = config
        self.response = response
        self._memory = self.initial_memory()
        self.candidates = command_candidates(config)  # (C, 2)

    def initial_memory(self) -> ResponseMemory | None:
        """None on the LIP; with a response model, what the robot did one step ago."""
        return None if self.response is None else ResponseMemory()

    def reset(self) -> None:
        """Back to `initial_memory()` (a new episode)."""
        self._memory = self.initial_memory()

    def plan_with_memory(
        self, obs: PlannerInput, memory: ResponseMemory | None
    ) -> tuple[np.ndarray, ResponseMemory | None]:
        """The command and the next memory: the planner interface of the diagram."""
        rb = obs.robot
        if self.response is None:
            start = LipState(rb.x, rb.y, rb.heading, rb.speed)
            traj = lip_candidate_positions(self.config, self.candidates, start)
            return choose_candidate(self.config, obs, self.candidates, traj), None
        memory = memory if memory is not None else ResponseMemory()
        speed = memory.step_speed(rb, self.config.robot.step_time)
        start = type(rb)(rb.x, rb.y, rb.heading, speed)
        traj = self.response.rollout(
            start, memory.committed(obs), self.candidates, self.config.dwa.horizon_steps
        )
        chosen = choose_candidate(self.config, obs, self.candidates, traj)
        return chosen, ResponseMemory.after(obs)

    def plan(self, obs: PlannerInput) -> np.ndarray:
        """The command (u_v [m/s], u_Δθ [rad]) for this walking step."""
        command, self._memory = self.plan_with_memory(obs, self._memory)
        return command
