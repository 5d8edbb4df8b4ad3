"""`CrowdSystem`: pedestrians (ORCA, emotions) and static discs, updated at 10 Hz.

Input port:
    robot_state (4): (x, y, θ, v) of the robot CoM, world frame [m, rad, m/s]; its
        velocity v·(cos θ, sin θ) is what ORCA sees.
Output port:
    crowd (abstract `CrowdSnapshot`): pedestrian positions [m] and velocities [m/s] in
        the world frame, radius, emotions and discomfort distances in force, and the
        static discs.
Abstract state: the `CrowdState`, advanced every `crowd.dt` from t = 0 by
`crowd.crowd.Crowd.step` (the same function the Gymnasium environment calls).
"""

from __future__ import annotations

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import Context, LeafSystem, State

from emonav_drake.crowd.crowd import Crowd
from emonav_drake.params import EmoNavConfig
from emonav_drake.robot.lip import lip_velocity
from emonav_drake.scenarios.scenario import Scenario
from emonav_drake.systems.lip_robot_plant import lip_state_from_vector


class CrowdSystem(LeafSystem):
    """The crowd of one scenario.

    Args:
        scenario: pedestrians (start, goal, emotion) and static discs.
        config: crowd (ORCA) parameters and discomfort distances.
    """

    def __init__(self, scenario: Scenario, config: EmoNavConfig) -> None:
        super().__init__()
        self.crowd = Crowd(scenario, config)
        self._state = self.DeclareAbstractState(AbstractValue.Make(self.crowd.initial_state()))
        self.DeclareVectorInputPort("robot_state", 4)
        self.DeclareAbstractOutputPort(
            "crowd",
            lambda: AbstractValue.Make(self.crowd.snapshot(self.crowd.initial_state())),
            self._calc_crowd,
            {self.abstract_state_ticket(self._state)},
        )
        self.DeclarePeriodicUnrestrictedUpdateEvent(config.crowd.dt, 0.0, self._update)

    def _update(self, context: Context, state: State) -> None:
        current = context.get_abstract_state(self._state).get_value()
        robot = lip_state_from_vector(self.get_input_port(0).Eval(context))
        new = self.crowd.step(current, np.array([robot.x, robot.y]), lip_velocity(robot))
        state.get_mutable_abstract_state(self._state).set_value(new)

    def _calc_crowd(self, context: Context, output: AbstractValue) -> None:
        output.set_value(self.crowd.snapshot(context.get_abstract_state(self._state).get_value()))
