"""`ReplayPlanner`: plays a fixed sequence of commands, one per walking step.

Used to replay a recorded episode (e.g. the actions taken in the Gymnasium
environment) through the Drake diagram, and as a scripted command source.
"""

from __future__ import annotations

import numpy as np

from emonav_drake.navigation.lip_world import PlannerInput


class ReplayPlanner:
    """Command k of `commands` at walking step k; (0, 0) (stand still) after the end.

    Args:
        commands: (K, 2) array of (u_v [m/s], u_Δθ [rad]).
    """

    name = "replay"

    def __init__(self, commands: np.ndarray) -> None:
        self.commands = np.asarray(commands, dtype=float).reshape(-1, 2)

    def initial_memory(self) -> None:
        """No memory: the step index comes with the planner input."""
        return None

    def reset(self) -> None:
        """No memory: the step index comes with the planner input."""

    def plan_with_memory(self, obs: PlannerInput, memory: None) -> tuple[np.ndarray, None]:
        """`plan(obs)` and the (empty) memory: the planner interface of the diagram."""
        return self.plan(obs), None

    def plan(self, obs: PlannerInput) -> np.ndarray:
        """Command `obs.step` of the sequence (u_v [m/s], u_Δθ [rad]), (0, 0) after it."""
        if obs.step < len(self.commands):
            return self.commands[obs.step].copy()
        return np.zeros(2)
