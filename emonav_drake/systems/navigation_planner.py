"""`NavigationPlanner`: any planner (DWA, MPC, learned policy) as one Drake system.

Input ports:
    robot_state (4): (x, y, θ, v) of the robot CoM, world frame [m, rad, m/s].
    crowd (abstract `CrowdSnapshot`): privileged crowd state (used by DWA / MPC).
    lgm_stack (abstract uint8 (N, M, M)): the grid-map stack (used by learned policies).
    last_command (2): the previous step's command (u_v [m/s], u_Δθ [rad]).
Output port:
    command (2): (u_v, u_Δθ) for the walking step starting now. Computed directly from
        the inputs (no delay): the robot plant reads it at each foot switch t_k = kT,
        i.e. the planner runs at 1/T = 2.5 Hz.

The wrapped planner is any object with ``plan(PlannerInput) -> (2,) array`` and
``reset()``; swapping DWA for MPC or a policy changes nothing else in the diagram.
"""

from __future__ import annotations

from typing import Protocol

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import BasicVector, Context, LeafSystem

from emonav_drake.core.navigation import PlannerInput
from emonav_drake.params import EmoNavConfig
from emonav_drake.systems.lip_robot_plant import lip_state_from_vector


class Planner(Protocol):
    """What the navigation diagram needs of a planner."""

    name: str

    def reset(self) -> None: ...

    def plan(self, obs: PlannerInput) -> np.ndarray: ...


class NavigationPlanner(LeafSystem):
    """A planner wrapped as a system.

    Args:
        planner: the planner (see `Planner`).
        goal_xy: the robot's goal in the world frame [m].
        config: for the step time T.
    """

    def __init__(self, planner: Planner, goal_xy: np.ndarray, config: EmoNavConfig) -> None:
        super().__init__()
        self.planner = planner
        self._goal = np.asarray(goal_xy, dtype=float)
        self._step_time = config.robot.step_time
        self._robot = self.DeclareVectorInputPort("robot_state", 4)
        self._crowd = self.DeclareAbstractInputPort("crowd", AbstractValue.Make(object()))
        self._lgm = self.DeclareAbstractInputPort("lgm_stack", AbstractValue.Make(object()))
        self._last = self.DeclareVectorInputPort("last_command", 2)
        self.DeclareVectorOutputPort(
            "command", 2, self._calc_command, {self.all_input_ports_ticket(), self.time_ticket()}
        )

    def planner_input(self, context: Context) -> PlannerInput:
        """The `PlannerInput` the planner sees in `context`."""
        lgm = self._lgm.Eval(context) if self._lgm.HasValue(context) else None
        return PlannerInput(
            robot=lip_state_from_vector(self._robot.Eval(context)),
            goal_xy=self._goal,
            last_command=self._last.Eval(context).copy(),
            crowd=self._crowd.Eval(context),
            lgm_stack=lgm,
            step=round(context.get_time() / self._step_time),
        )

    def _calc_command(self, context: Context, output: BasicVector) -> None:
        output.SetFromVector(
            np.asarray(self.planner.plan(self.planner_input(context)), dtype=float)
        )
