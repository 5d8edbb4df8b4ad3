"""The contact solver's implicit joint damping (`walking.implicit_damping`): the joints it
names get a PD controller of proportional gain 0 and derivative gain K_D on the real Drake
plant, the controller leaves their K_D s to the solver and sends it the reference velocity,
and Digit walks on it at a plant step the explicit damping cannot take."""

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator

from emonav_drake.configs import CONFIG_DIR
from emonav_drake.diagrams.walking import build_walking_diagram, run_walk
from emonav_drake.params import ConfigError, load_config
from emonav_drake.systems.digit_plant import LEG_JOINTS
from emonav_drake.systems.walking_command_source import command_sequence

IMPLICIT = "walking: {implicit_damping: [hip_yaw, knee]}\n"  # the default's
EXPLICIT_10MS = "walking: {implicit_damping: []}\n"  # the 10 ms default, every K_D explicit
EXPLICIT_4MS = str(CONFIG_DIR / "walking_4ms.yaml")  # the 4 ms stack (every K_D explicit)


def _walking_at(cfg, seconds: float, seed: int = 3):
    """A walking diagram of `cfg` simulated for `seconds` of random commands: (diagram,
    its station, the root context)."""
    seq = command_sequence("random", int(seconds / cfg.robot.step_time) + 5, cfg.robot, seed=seed)
    wd = build_walking_diagram(cfg, seq)
    sim = Simulator(wd.diagram)
    sim.AdvanceTo(seconds)
    return wd, wd.station, sim.get_mutable_context()


@pytest.mark.parametrize(
    "yaml, field, words",
    [
        ("walking: {implicit_damping: [ankle]}\n", "implicit_damping", "'ankle' is not one"),
        ("walking: {implicit_damping: [knee, knee]}\n", "implicit_damping", "each joint once"),
        (
            "walking: {implicit_damping: [knee], time_step: 0.004, controller_period: 0.008}\n",
            "controller_period",
            "implicit_damping names joints",
        ),
    ],
)
def test_a_bad_implicit_damping_names_the_field(yaml, field, words):
    with pytest.raises(ConfigError, match=rf"walking\.{field}.*{words}"):
        load_config(data=yaml)


def test_the_named_joints_and_only_they_get_the_solvers_damping():
    cfg = load_config(data=IMPLICIT)
    wd, station, ctx = _walking_at(cfg, 0.1)
    plant, model = station.plant, station.model
    assert list(model.implicit_legs) == [j in ("hip_yaw", "knee") for j in LEG_JOINTS]
    for side in ("left", "right"):
        for k, joint in enumerate(LEG_JOINTS):
            actuator = plant.GetJointActuatorByName(f"{side}_{joint}_motor")
            assert actuator.has_controller() == (joint in ("hip_yaw", "knee"))
            if actuator.has_controller():
                gains = actuator.get_controller_gains()
                assert gains.p == 0.0 and gains.d == cfg.walking.kd_leg[k]
    # the desired-state port is wired to the controller: [q; v_r] in actuator order
    port = plant.get_desired_state_input_port(model.instance)
    desired = port.Eval(plant.GetMyContextFromRoot(ctx))
    x = station.GetOutputPort("plant_state").Eval(station.GetMyContextFromRoot(ctx))
    assert np.array_equal(desired[: plant.num_actuators()], x[model.actuated_q])
    # the 4 ms stack's plant has no PD controller at all
    _, plain, _ = _walking_at(load_config(EXPLICIT_4MS), 0.1)
    assert not any(
        plain.plant.get_joint_actuator(i).has_controller()
        for i in plain.plant.GetJointActuatorIndices()
    )


def test_the_controller_leaves_to_the_solver_exactly_the_damping_of_those_joints():
    """At one state, the implicit controller's feed-forward minus K_D (v − v_r) of the
    solver-damped joints is the explicit controller's torque, joint for joint."""
    cfg_i = load_config(data=IMPLICIT)
    _, station, ctx = _walking_at(cfg_i, 1.37)  # mid-step, one foot in stance
    ci = station.controller
    cctx = ci.GetMyContextFromRoot(ctx)
    x = ci.GetInputPort("state").Eval(cctx)
    targets = ci.GetInputPort("targets").Eval(cctx)
    t = cctx.get_time()
    u_ff = ci.GetOutputPort("actuation").Eval(cctx)
    desired = ci.GetOutputPort("desired_state").Eval(cctx)
    model = station.model
    nu = len(u_ff)
    v_r = desired[nu:]
    _, explicit_station, _ = _walking_at(load_config(data=EXPLICIT_10MS), 0.0)
    u_explicit = explicit_station.controller.compute(x, targets, t)
    kd = np.array(cfg_i.walking.kd_leg)
    expected = u_ff.copy()
    for leg_u in model.leg_u:
        for k in np.flatnonzero(model.implicit_legs):
            a = leg_u[k]
            v = x[model.plant.num_positions() + model.actuated_v[a]]
            expected[a] = u_ff[a] - kd[k] * (v - v_r[a])
    assert 0 <= targets.phase <= 1
    np.testing.assert_allclose(expected, u_explicit, rtol=0, atol=1e-9)
    # the feed-forward differs from the explicit torque where the damping acts
    assert np.max(np.abs(u_ff - u_explicit)) > 1e-3


@pytest.mark.slow
def test_digit_walks_at_10_ms_with_the_solvers_damping_and_falls_without_it():
    """The default (10 ms, hip yaws and knees damped by the solver) tracks as the 4 ms
    stack with every K_D explicit; at 10 ms without the solver's damping it does not."""
    walked = run_walk(10.0, seed=7)
    assert not walked.fell, walked.fall_reason
    base = run_walk(10.0, seed=7, config=load_config(EXPLICIT_4MS))
    for key in ("x", "y"):  # within 10 % of the 4 ms stack's tracking
        assert walked.tracking_rms[key] < 1.1 * base.tracking_rms[key], key
    assert walked.tracking_rms["heading"] < 2.0 * base.tracking_rms["heading"]
    explicit = run_walk(10.0, seed=7, config=load_config(data=EXPLICIT_10MS))
    # the explicit K_D at 10 ms: the robot falls or its heading sways tens of times more
    assert explicit.fell or explicit.tracking_rms["heading"] > 10 * base.tracking_rms["heading"]
