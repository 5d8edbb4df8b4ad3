"""Systems that put the full-order Digit under the navigation stack.

`DigitComState` — the navigation-level robot state of the Digit plant.
    Input port:  state (nq + nv): the Digit plant's (q, v).
    Output port: robot_state (4): (x, y [m] of the CoM in the world frame, θ [rad] the
        torso's yaw, v [m/s] the CoM velocity along the heading) — the same meaning as
        `LipRobotPlant`'s robot_state, so crowd, grid maps, planner and monitor are unchanged.

`CommandHold` — the 2.5 Hz zero-order hold between the navigation planner and the ALIP
footstep planner.
    Input port:  command (2): (u_v [m/s], u_Δθ [rad]) from the navigation planner.
    Output port: command (2): the command sampled at the last walking-step instant kT.
    It is a periodic *unrestricted* update, like every update of the navigation diagram,
    so it samples the planner from the same pre-update state as the crowd and grid maps.
"""

from __future__ import annotations

import math

import numpy as np
from pydrake.systems.framework import BasicVector, Context, LeafSystem, State

from emonav_drake.systems.digit_plant import DigitModel


class DigitComState(LeafSystem):
    """Digit's CoM, heading and sagittal speed from its plant state.

    Args:
        model: the Digit plant and its index maps.
    """

    def __init__(self, model: DigitModel) -> None:
        super().__init__()
        self._plant = model.plant
        self._ctx = self._plant.CreateDefaultContext()
        self._quat = model.base_q[:4]
        nx = self._plant.num_positions() + self._plant.num_velocities()
        self._state_in = self.DeclareVectorInputPort("state", nx)
        self.DeclareVectorOutputPort("robot_state", 4, self._calc_robot_state)

    def _calc_robot_state(self, context: Context, output: BasicVector) -> None:
        x = self._state_in.Eval(context)
        self._plant.SetPositionsAndVelocities(self._ctx, x)
        p = self._plant.CalcCenterOfMassPositionInWorld(self._ctx)
        v = self._plant.CalcCenterOfMassTranslationalVelocityInWorld(self._ctx)
        w, qx, qy, qz = x[self._quat]
        yaw = math.atan2(2.0 * (w * qz + qx * qy), 1.0 - 2.0 * (qy * qy + qz * qz))
        speed = v[0] * math.cos(yaw) + v[1] * math.sin(yaw)
        output.SetFromVector(np.array([p[0], p[1], yaw, speed]))


class CommandHold(LeafSystem):
    """Holds the navigation command between walking steps.

    Args:
        period: the walking step T [s].
    """

    def __init__(self, period: float) -> None:
        super().__init__()
        self._in = self.DeclareVectorInputPort("command", 2)
        self._held = self.DeclareDiscreteState(2)
        self.DeclareStateOutputPort("command", self._held)
        self.DeclarePeriodicUnrestrictedUpdateEvent(period, 0.0, self._sample)

    def _sample(self, context: Context, state: State) -> None:
        state.get_mutable_discrete_state(self._held).set_value(self._in.Eval(context))
