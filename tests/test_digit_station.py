"""The Digit station: default context standing, one fall monitor, typed targets, gravity."""

import dataclasses as dc
import math

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator

from emonav_drake.diagrams.digit_station import DigitStation
from emonav_drake.diagrams.walking import build_walking_diagram, run_walk
from emonav_drake.params import ConfigError, load_config
from emonav_drake.robot.walking_targets import DOUBLE_SUPPORT, WalkingTargets
from emonav_drake.systems.digit_plant import standing_state
from emonav_drake.systems.fall_monitor import FallStatus
from emonav_drake.systems.walking_command_source import command_sequence


def kneeling_positions(station: DigitStation, torso_height: float = 0.615) -> np.ndarray:
    """Both thighs vertical, shins back along the ground, feet flat: the knees (shin
    capsules) touch the ground while the torso stays above the fall height (0.6 m)."""
    plant, model = station.plant, station.model
    q = station.initial_state()[: plant.num_positions()].copy()
    q[model.base_q[6]] = torso_height
    for leg in model.leg_q:  # hip roll, hip yaw, hip pitch, knee, toe pitch, toe roll
        q[leg] = [0.0, 0.0, 0.0, math.pi / 2, -math.pi / 2, 0.0]
    return q


def test_a_default_context_starts_standing_and_walks():
    cfg = load_config()
    wd = build_walking_diagram(cfg, command_sequence("straight", 40, cfg.robot, speed=0.3))
    station = wd.station
    sim = Simulator(wd.diagram)  # nothing set by hand: the default context
    ctx = sim.get_mutable_context()
    plant_ctx = station.plant.GetMyContextFromRoot(ctx)
    x0 = station.plant.GetPositionsAndVelocities(plant_ctx)
    # the standing pose computed independently of the plant's defaults
    np.testing.assert_array_equal(x0, standing_state(station.model))
    com0 = station.GetOutputPort("robot_state").Eval(station.GetMyContextFromRoot(ctx))
    sim.AdvanceTo(4.0)
    fall = station.GetOutputPort("fall").Eval(station.GetMyContextFromRoot(ctx))
    assert fall == FallStatus()  # never fell
    com = station.GetOutputPort("robot_state").Eval(station.GetMyContextFromRoot(ctx))
    assert com[0] - com0[0] > 0.6  # ~3.6 s of walking at 0.3 m/s (LIP-like speed)
    assert abs(com[1] - com0[1]) < 0.2
    q = station.plant.GetPositions(station.plant.GetMyContextFromRoot(ctx))
    assert q[station.model.base_q[6]] == pytest.approx(cfg.walking.torso_height, abs=0.05)


def test_the_station_stands_at_its_pose():
    cfg = load_config()
    station = DigitStation(cfg, pose=(-4.0, 0.5, 0.3))
    ctx = station.CreateDefaultContext()
    x, y, th, v = station.GetOutputPort("robot_state").Eval(ctx)
    assert math.hypot(x + 4.0, y - 0.5) < 0.05 and th == pytest.approx(0.3) and v == 0.0


def test_the_targets_port_is_typed_and_standing_at_the_start():
    cfg = load_config()
    station = DigitStation(cfg)
    sim = Simulator(station)
    station.GetInputPort("command").FixValue(sim.get_mutable_context(), [0.0, 0.0])
    sim.Initialize()
    tg = station.GetOutputPort("targets").Eval(sim.get_context())
    assert isinstance(tg, WalkingTargets) and tg.phase == DOUBLE_SUPPORT
    assert tg.timing.step_time == cfg.robot.step_time and tg.timing.gravity == cfg.robot.gravity
    assert tg.timing.swing_finish == cfg.walking.swing_finish_fraction
    assert tg.height == pytest.approx(station.com_height)
    # the feet are where the plant has them: 2 × 0.091 m apart
    assert math.dist(tg.stance[:2], tg.swing_start[:2]) == pytest.approx(0.182, abs=1e-3)


def test_gravity_from_yaml_reaches_the_plant_the_alip_planner_and_the_controller():
    runs = {}
    for g in (9.81, 9.0):
        cfg = load_config(data=f"robot: {{gravity: {g}}}\n")
        station = DigitStation(cfg)
        assert station.plant.gravity_field().gravity_vector()[2] == -g
        ctx = station.CreateDefaultContext()
        station.GetInputPort("command").FixValue(ctx, [0.3, 0.0])
        x = station.initial_state()
        tg = station.planner.GetOutputPort("targets").Eval(
            station.planner.GetMyContextFromRoot(ctx)
        )
        assert tg.timing.gravity == g
        # the controller: its pendulum model (g/H) and its gravity compensation
        moved = dc.replace(tg, phase=0, stance=(-0.05, 0.0, 0.05))
        assert moved.pendulum_acceleration(0.0, 0.0)[0] == pytest.approx(0.05 * g / tg.height)
        tau = station.controller.compute(x, tg, 0.0)
        r = run_walk(1.6, seed=3, config=cfg)
        assert not r.fell
        runs[g] = (tau, [s.predicted for s in r.steps if not math.isnan(s.predicted[0])])
    assert not np.allclose(runs[9.81][0], runs[9.0][0])  # the controller's torques
    # the ALIP planner's end-of-step predictions (its model uses g)
    assert not np.allclose(runs[9.81][1][0], runs[9.0][1][0])


def test_the_digit_gait_rejects_a_step_time_it_cannot_walk():
    with pytest.raises(ConfigError, match="robot.step_time"):
        DigitStation(load_config(data="robot: {step_time: 0.1}\ncrowd: {dt: 0.05}\n"))
    with pytest.raises(ConfigError, match="walking.controller_period"):
        load_config(data="walking: {controller_period: 0.0015}\n")


def test_a_shove_is_a_fall_outcome():
    r = run_walk(3.0, command="stand", push=(0.0, 2.5, 0.0))
    assert r.fell and r.outcome == "fall" and r.to_json()["outcome"] == "fall"
    assert r.sim_seconds < 3.0  # the run stopped at the fall


def test_a_knee_on_the_ground_is_a_fall_even_with_the_torso_high():
    cfg = load_config()
    wd = build_walking_diagram(cfg, command_sequence("stand", 5, cfg.robot))
    station = wd.station
    sim = Simulator(wd.diagram)
    ctx = sim.get_mutable_context()
    q = kneeling_positions(station)
    assert q[station.model.base_q[6]] > cfg.walking.fall_height
    station.plant.SetPositions(station.plant.GetMyMutableContextFromRoot(ctx), q)
    monitor_ctx = station.fall_monitor.GetMyContextFromRoot(ctx)
    assert "shin touched the ground" in station.fall_monitor.fall_reason(monitor_ctx)
    sim.AdvanceTo(0.01)
    fall = station.GetOutputPort("fall").Eval(station.GetMyContextFromRoot(ctx))
    assert fall.fallen and "shin" in fall.reason and fall.time == 0.0


def test_a_slower_controller_holds_its_torque_between_ticks():
    # the 4 ms stack with every K_D explicit, its controller at every 2nd plant step
    cfg = load_config(
        data="walking: {time_step: 0.004, controller_period: 0.008, fall_check_period: 0.008, "
        "implicit_damping: []}\n"
    )
    r = run_walk(2.0, seed=5, config=cfg, record_timing=True)
    assert not r.fell
    assert len(r.tick_seconds) == pytest.approx(250, abs=2)  # 125 Hz for 2 s
