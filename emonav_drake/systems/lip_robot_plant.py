"""`LipRobotPlant`: the reduced-order (LIP) robot as a Drake system, one step per T.

Input port:
    command (2): (u_v [m/s], u_Δθ [rad]) for the walking step that starts now. Read at
        each foot switch t_k = kT. Out-of-range commands are clipped to the paper's
        bounds with a warning; a NaN command raises `CommandError`.
Output ports:
    robot_state (4): (x [m], y [m], θ [rad], v [m/s]) of the CoM in the world frame at
        the current time: at a foot switch the state reached by the step just ended,
        within a step the LIP CoM trajectory of Eq. 1 (`core.lip.lip_in_step`).
    last_command (2): the command of the step in progress (at t_k, before the update:
        the previous step's command u_{k−1}).
Discrete state (11), set by a periodic unrestricted update every T from t = 0:
    [x_s, y_s, θ_s, v_s, u_v, u_Δθ, x_e, y_e, θ_e, v_e, t_s] — the step's start state, its
    command, its end state and its start time.
"""

from __future__ import annotations

import logging

import numpy as np
from pydrake.systems.framework import BasicVector, Context, LeafSystem, State

from emonav_drake.core.lip import LipState, lip_in_step, lip_step
from emonav_drake.core.navigation import check_command, robot_at_substep
from emonav_drake.core.scenario import Scenario
from emonav_drake.params import EmoNavConfig

log = logging.getLogger(__name__)


class LipRobotPlant(LeafSystem):
    """The LIP robot stepping every T = 0.4 s.

    Args:
        scenario: gives the initial CoM position and heading (at rest).
        config: robot parameters (T, H, g, bounds) and the crowd period for sampling.
    """

    def __init__(self, scenario: Scenario, config: EmoNavConfig) -> None:
        super().__init__()
        self._config = config
        self._dt = config.crowd.dt
        self._substeps = round(config.robot.step_time / self._dt)
        x0, y0 = (float(v) for v in scenario.robot_start)
        th0 = float(scenario.robot_heading)
        T = config.robot.step_time
        init = [x0, y0, th0, 0.0, 0.0, 0.0, x0, y0, th0, 0.0, -T]
        self._state = self.DeclareDiscreteState(np.array(init))
        self.DeclareVectorInputPort("command", 2)
        self.DeclareVectorOutputPort(
            "robot_state", 4, self._calc_robot_state, {self.time_ticket(), self.xd_ticket()}
        )
        self.DeclareVectorOutputPort("last_command", 2, self._calc_last_command, {self.xd_ticket()})
        # Unrestricted like every other update of the navigation diagram: Drake applies all
        # unrestricted updates of one instant together (each reads the pre-update state),
        # before any discrete update, so mixing the two kinds would skew the timing.
        self.DeclarePeriodicUnrestrictedUpdateEvent(T, 0.0, self._step)

    def _step(self, context: Context, state: State) -> None:
        s = context.get_discrete_state(self._state).get_value()
        command = self.get_input_port(0).Eval(context)
        u, clipped = check_command(command, self._config.robot, clip=True)
        if clipped:
            log.warning(
                "LipRobotPlant: command %s out of bounds at t = %.2f s, clipped to %s",
                np.asarray(command).tolist(),
                context.get_time(),
                u.tolist(),
            )
        start = LipState(*s[6:10])
        r = self._config.robot
        end = lip_step(start, float(u[0]), float(u[1]), r.omega, r.step_time)
        state.get_mutable_discrete_state(self._state).set_value(
            np.array([*start, u[0], u[1], *end, context.get_time()])
        )

    def _calc_robot_state(self, context: Context, output: BasicVector) -> None:
        s = context.get_discrete_state(self._state).get_value()
        elapsed = context.get_time() - s[10]
        start, u = LipState(*s[0:4]), s[4:6]
        j = round(elapsed / self._dt)
        if abs(elapsed - j * self._dt) < 1e-9 and 0 <= j <= self._substeps:
            # On the crowd's clock: exactly the state the fast world uses.
            if j == self._substeps:
                state = LipState(*s[6:10])
            else:
                state = robot_at_substep(start, u, j, self._config)
        else:
            r = self._config.robot
            state = lip_in_step(
                start,
                float(u[0]),
                float(u[1]),
                r.omega,
                r.step_time,
                min(max(elapsed, 0.0), r.step_time),
            )
        output.SetFromVector(np.array(state))

    def _calc_last_command(self, context: Context, output: BasicVector) -> None:
        output.SetFromVector(context.get_discrete_state(self._state).get_value()[4:6])


def lip_state_from_vector(v: np.ndarray) -> LipState:
    """A `LipState` from the 4-vector of the `robot_state` port."""
    if v.shape != (4,) or not np.all(np.isfinite(v)):
        raise ValueError(f"robot_state must be 4 finite numbers, got {v}")
    return LipState(float(v[0]), float(v[1]), float(v[2]), float(v[3]))
