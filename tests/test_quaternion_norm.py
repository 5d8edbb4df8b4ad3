"""The torso's quaternion in the discrete Digit plant's state is not kept at unit norm
(Drake's kinematics normalise it; its norm grows a little as the robot turns). What we
compute from it ourselves — the controller's torso orientation error, the robot state's
yaw — must not depend on its norm."""

import math

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator

from emonav_drake.diagrams.walking import build_walking_diagram
from emonav_drake.params import load_config
from emonav_drake.systems.walking_command_source import command_sequence


def _mid_walk():
    cfg = load_config()
    wd = build_walking_diagram(cfg, command_sequence("turn", 20, cfg.robot, heading_change=0.3))
    sim = Simulator(wd.diagram)
    sim.AdvanceTo(2.2)  # turning, one foot in stance
    return wd.station, sim.get_mutable_context()


def _scaled(x: np.ndarray, quat: np.ndarray, factor: float) -> np.ndarray:
    y = x.copy()
    y[quat] *= factor
    return y


def test_the_walking_turns_and_its_quaternion_is_not_unit_norm():
    """The premise: after 2.2 s of turning the plant's quaternion is off unit norm by more
    than rounding (so code that assumes |q| = 1 errs)."""
    station, ctx = _mid_walk()
    x = station.GetOutputPort("plant_state").Eval(station.GetMyContextFromRoot(ctx))
    q = x[station.model.base_q[:4]]
    assert abs(float(q @ q) - 1.0) > 1e-6


def test_the_controller_torque_does_not_depend_on_the_quaternions_norm():
    station, ctx = _mid_walk()
    c = station.controller
    cctx = c.GetMyContextFromRoot(ctx)
    x = c.GetInputPort("state").Eval(cctx)
    targets, t = c.GetInputPort("targets").Eval(cctx), cctx.get_time()
    quat = station.model.base_q[:4]
    unit = _scaled(x, quat, 1.0 / np.linalg.norm(x[quat]))
    u_unit = c.compute(unit, targets, t).copy()
    u_long = c.compute(_scaled(unit, quat, 1.02), targets, t)
    # 2 % off unit norm moved the torques by tens of N·m before the normalisation
    np.testing.assert_allclose(u_long, u_unit, rtol=0, atol=1e-8)


def test_the_robot_states_yaw_does_not_depend_on_the_quaternions_norm():
    station, ctx = _mid_walk()
    model = station.model
    quat = model.base_q[:4]
    com = station.com
    cctx = com.GetMyContextFromRoot(ctx)
    x = com.GetInputPort("state").Eval(cctx).copy()
    yaw = 1.2
    x[quat] = [math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)]
    for factor in (1.0, 1.02):
        com.GetInputPort("state").FixValue(cctx, _scaled(x, quat, factor))
        state = com.GetOutputPort("robot_state").Eval(cctx)
        assert state[2] == pytest.approx(yaw, abs=1e-12), factor
