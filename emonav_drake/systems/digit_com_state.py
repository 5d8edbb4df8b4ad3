"""`DigitComState`: the navigation-level robot state of the full-order Digit.

Input port:
    state (nq + nv): the Digit plant's (q, v).
Output port:
    robot_state (4): (x, y) [m] of the CoM in the world frame W, θ [rad] the torso's yaw,
        v [m/s] the CoM velocity along that heading — the same meaning as
        `LipRobotPlant`'s robot_state, so the crowd, grid maps, planner and episode
        monitor run unchanged on either robot.
"""

from __future__ import annotations

import math

import numpy as np
from pydrake.systems.framework import BasicVector, Context, LeafSystem

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
        p_WC = self._plant.CalcCenterOfMassPositionInWorld(self._ctx)
        v_WC = self._plant.CalcCenterOfMassTranslationalVelocityInWorld(self._ctx)
        w, qx, qy, qz = x[self._quat]
        # the form that holds for a quaternion of any norm (the discrete plant's grows
        # slowly as the robot turns; 1 − 2(qy² + qz²) would assume it is one)
        yaw = math.atan2(2.0 * (w * qz + qx * qy), w * w + qx * qx - qy * qy - qz * qz)
        speed = v_WC[0] * math.cos(yaw) + v_WC[1] * math.sin(yaw)
        output.SetFromVector(np.array([p_WC[0], p_WC[1], yaw, speed]))
