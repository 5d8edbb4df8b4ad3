"""`NavigationObservation`: the Gymnasium observation of the navigation task as a port.

Input ports:
    robot_state (4): (x [m], y [m], θ [rad], v [m/s]) of the robot CoM, world frame.
    lgm_stack (abstract numpy array): the map observation (`LidarGridMapBuilder`), robot
        frame, oldest frame first.
    last_action (2): the command held since the last planner instant, (u_v [m/s],
        u_Δθ [rad]) — the planner's `command` output.
Output port:
    observation (abstract dict): {map key: the stack, "goal": float32 (2,) goal distance
        [m] and bearing [rad, CCW from the heading], "last_action": float32 (2,)}, the
        observation of `EmoNavLIP-v0` (`learning.env.observation_dict`), so a policy
        trained on one environment runs on the other.

No state; the output is a function of the inputs at the time it is evaluated (at t_k,
before the updates at t_k: what a planner sees).
"""

from __future__ import annotations

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import Context, LeafSystem

from emonav_drake.navigation.lip_world import goal_state
from emonav_drake.params import EmoNavConfig
from emonav_drake.robot.lip import LipState


class NavigationObservation(LeafSystem):
    """The env's observation dict from the diagram's ports (see the module).

    Args:
        goal_xy: the robot's goal, world frame [m].
        config: command bounds (the clip of the goal and last-action boxes).
        grid_kind: which map observation arrives on `lgm_stack` (sets its key).
    """

    def __init__(self, goal_xy: np.ndarray, config: EmoNavConfig, grid_kind: str) -> None:
        super().__init__()
        from emonav_drake.navigation.observations import map_key

        self._goal = np.asarray(goal_xy, float)
        self._key = map_key(grid_kind)
        r = config.robot
        self._low = np.array([0.0, -r.max_heading_change], np.float32)
        self._high = np.array([r.max_speed, r.max_heading_change], np.float32)
        self._robot = self.DeclareVectorInputPort("robot_state", 4)
        self._lgm = self.DeclareAbstractInputPort("lgm_stack", AbstractValue.Make(object()))
        self._last = self.DeclareVectorInputPort("last_action", 2)
        self.DeclareAbstractOutputPort("observation", lambda: AbstractValue.Make({}), self._calc)

    def _calc(self, context: Context, output: AbstractValue) -> None:
        x, y, th, v = self._robot.Eval(context)
        goal = goal_state(LipState(x, y, th, v), self._goal)
        output.set_value(
            {
                self._key: self._lgm.Eval(context),
                "goal": np.clip(goal, [0.0, -np.pi], [1000.0, np.pi]).astype(np.float32),
                "last_action": np.clip(self._last.Eval(context), self._low, self._high).astype(
                    np.float32
                ),
            }
        )
