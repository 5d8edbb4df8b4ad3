"""`LipRobotPlant`: the reduced-order (LIP) robot as a Drake system, one step per T.

Input port:
    command (2): (u_v [m/s], u_Δθ [rad]), the command of the walking step in progress — in
        the navigation diagram the `NavigationPlanner`'s held command, u_k during step k
        (t_k ≤ t < t_{k+1}; before the updates at t_k still u_{k−1}). It must be held for
        the whole step. Out-of-range commands are clipped to the paper's bounds (Eq. 2),
        with a warning once per step; a NaN command raises `CommandError`.
Output port:
    robot_state (4): (x [m], y [m], θ [rad], v [m/s]) of the CoM in the world frame at the
        current time, from the step's start state, the command and the time elapsed since
        the step started: at the crowd's sample times the state the Gymnasium env's crowd
        sees (`navigation.lip_world.robot_at_substep`: the start itself at the foot switch, the
        next foot switch `lip_step` at the step's end), in between the LIP CoM trajectory
        of Eq. 1 (`robot.lip.lip_in_step`). Direct feedthrough from `command` (the planner's
        command output is a state output, so there is no algebraic loop).
Discrete state (5): [x_s, y_s, θ_s, v_s, t_s] — the start state of the step in progress
    (at its foot switch) and its start time [s]; initially the scenario's start at rest
    with t_s = 0.

Timing. A periodic unrestricted update every T from t = 0 (like every navigation update,
so at t_k all of them read the same pre-update state). At t_k, before the update, the
output shows the end of step k − 1, `lip_step(start, u_{k−1})`; the update stores that
state as the start of step k with t_s = t_k (at t = 0 nothing has been walked: the start
stays). During step k the output follows the command then in force, u_k.
"""

from __future__ import annotations

import logging

import numpy as np
from pydrake.systems.framework import BasicVector, Context, LeafSystem, State

from emonav_drake.navigation.lip_world import check_command, robot_at_substep
from emonav_drake.params import EmoNavConfig
from emonav_drake.robot.lip import LipState, lip_in_step
from emonav_drake.scenarios.scenario import Scenario

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
        self._state = self.DeclareDiscreteState(np.array([x0, y0, th0, 0.0, 0.0]))
        self._command = self.DeclareVectorInputPort("command", 2)
        self.DeclareVectorOutputPort(
            "robot_state",
            4,
            self._calc_robot_state,
            {
                self.time_ticket(),
                self.xd_ticket(),
                self.input_port_ticket(self._command.get_index()),
            },
        )
        self.DeclarePeriodicUnrestrictedUpdateEvent(config.robot.step_time, 0.0, self._step)

    def _robot(self, context: Context) -> LipState:
        """The CoM state now (see `robot_state`)."""
        s = context.get_discrete_state(self._state).get_value()
        u, _ = check_command(self._command.Eval(context), self._config.robot, clip=True)
        start = LipState(*s[0:4])
        elapsed = context.get_time() - s[4]
        j = round(elapsed / self._dt)
        if abs(elapsed - j * self._dt) < 1e-9 and 0 <= j <= self._substeps:
            # On the crowd's clock: exactly the state the fast world uses.
            return robot_at_substep(start, u, j, self._config)
        r = self._config.robot
        return lip_in_step(
            start,
            float(u[0]),
            float(u[1]),
            r.omega,
            r.step_time,
            min(max(elapsed, 0.0), r.step_time),
        )

    def _step(self, context: Context, state: State) -> None:
        s = context.get_discrete_state(self._state).get_value()
        t = context.get_time()
        command = self._command.Eval(context)
        u, clipped = check_command(command, self._config.robot, clip=True)
        if clipped and t > s[4]:
            log.warning(
                "LipRobotPlant %s: command %s of the step from t = %.2f s to %.2f s out of "
                "bounds, clipped to %s",
                self.GetSystemPathname(),
                np.asarray(command).tolist(),
                s[4],
                t,
                u.tolist(),
            )
        end = self._robot(context)
        state.get_mutable_discrete_state(self._state).set_value(np.array([*end, t]))

    def _calc_robot_state(self, context: Context, output: BasicVector) -> None:
        output.SetFromVector(np.array(self._robot(context)))


def lip_state_from_vector(v: np.ndarray) -> LipState:
    """A `LipState` from the 4-vector of the `robot_state` port."""
    if v.shape != (4,) or not np.all(np.isfinite(v)):
        raise ValueError(f"robot_state must be 4 finite numbers, got {v}")
    return LipState(float(v[0]), float(v[1]), float(v[2]), float(v[3]))
