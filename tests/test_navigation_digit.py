"""Navigation with the full-order Digit: the station under the navigation stack."""

import json
import math

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator

from emonav_drake.cli import main
from emonav_drake.diagrams.episode import simulate_episode
from emonav_drake.diagrams.navigation_digit import build_digit_navigation_diagram
from emonav_drake.params import EmoNavConfig
from emonav_drake.planners.dwa import DwaPlanner
from emonav_drake.scenarios.scenario import Scenario, StaticDiscSpec, sample_scenario
from tests.test_digit_station import kneeling_positions


def _short_config(steps: int) -> EmoNavConfig:
    cfg = EmoNavConfig()
    cfg.episode.max_steps = steps
    return cfg


def test_digit_stands_at_the_scenario_start_in_a_default_context():
    cfg = EmoNavConfig()
    sc = Scenario(
        robot_start=[-4.0, 0.5],
        robot_heading=0.3,
        obstacles=[StaticDiscSpec(center=[0.0, 0.0], radius=0.3)],
    )
    nd = build_digit_navigation_diagram(sc, cfg, DwaPlanner(cfg))
    ctx = nd.diagram.CreateDefaultContext()
    x, y, th, v = nd.station.GetOutputPort("robot_state").Eval(nd.station.GetMyContextFromRoot(ctx))
    assert np.hypot(x + 4.0, y - 0.5) < 0.05 and abs(th - 0.3) < 1e-9 and v == 0.0


@pytest.mark.slow
def test_two_runs_from_fresh_default_contexts_give_identical_records():
    cfg = _short_config(5)
    nd = build_digit_navigation_diagram(sample_scenario(3, cfg), cfg, DwaPlanner(cfg))
    records = []
    for _ in range(2):
        sim = Simulator(nd.diagram)  # a fresh default context; no reset() anywhere
        record, _ = simulate_episode(sim, nd.systems(), cfg)
        records.append(record.to_json())
    assert records[0] == records[1]
    assert records[0]["steps"] == 5 and records[0]["path_length"] > 0.3


def _fall_episode(setup) -> tuple[str, str, float]:
    """Outcome, fall reason (from the station's fall port; the record must agree) and
    the time the simulation stopped."""
    cfg = _short_config(10)
    nd = build_digit_navigation_diagram(sample_scenario(0, cfg), cfg, DwaPlanner(cfg))
    sim = Simulator(nd.diagram)
    plant = nd.station.plant
    setup(nd, plant, plant.GetMyMutableContextFromRoot(sim.get_mutable_context()))
    record, _ = simulate_episode(sim, nd.systems(), cfg)
    ctx = sim.get_context()
    fall = nd.station.GetOutputPort("fall").Eval(nd.station.GetMyContextFromRoot(ctx))
    assert record.to_json()["fall_reason"] == fall.reason
    return record.outcome, fall.reason, ctx.get_time()


def test_a_shove_ends_the_navigation_episode_as_a_fall():
    def shove(nd, plant, plant_ctx):
        v = np.zeros(plant.num_velocities())
        v[nd.model.base_v[3:]] = [0.0, 2.5, 0.0]  # sideways, 2.5 m/s
        plant.SetVelocities(plant_ctx, v)

    outcome, reason, t = _fall_episode(shove)
    assert outcome == "fall" and reason and t < 4.0


def test_a_knee_on_the_ground_ends_the_navigation_episode_as_a_fall():
    def kneel(nd, plant, plant_ctx):
        q = kneeling_positions(nd.station)
        q[nd.model.base_q[4:6]] = [-4.0, 0.0]  # at the scenario's start
        plant.SetPositions(plant_ctx, q)

    outcome, reason, t = _fall_episode(kneel)
    # the torso is above the fall height: only the contact check can see this fall
    assert outcome == "fall" and "shin touched the ground" in reason
    assert math.isclose(t, 0.0, abs_tol=0.0051)


def test_sim_with_the_full_order_digit(tmp_path):
    cfg = tmp_path / "c.yaml"
    cfg.write_text("episode: {max_steps: 6}\n")
    out = tmp_path / "r.json"
    args = ["sim", "--plant", "digit", "--planner", "dwa", "--seed", "0", "--config", str(cfg)]
    assert main([*args, "--json", str(out)]) == 0
    r = json.loads(out.read_text())
    assert r["outcome"] == "timeout" and r["steps"] == 6  # walking, not fallen
    assert 0.3 < r["path_length"] < 6 * 0.4 * 0.45  # Digit walked forward, at LIP-like speed


def test_digit_episode_records_a_meshcat_replay(tmp_path):
    cfg = tmp_path / "c.yaml"
    cfg.write_text("episode: {max_steps: 3}\n")
    html = tmp_path / "digit.html"
    args = ["sim", "--plant", "digit", "--seed", "1", "--config", str(cfg), "--record", str(html)]
    assert main(args) == 0
    text = html.read_text()
    assert len(text) > 50_000 and "<html" in text.lower()


def test_sim_rates_reports_every_systems_rate_and_wall_time_share(tmp_path, capsys):
    cfg = tmp_path / "c.yaml"
    cfg.write_text("episode: {max_steps: 3}\n")
    out = tmp_path / "r.json"
    args = ["sim", "--plant", "digit", "--seed", "2", "--config", str(cfg), "--rates"]
    assert main([*args, "--json", str(out)]) == 0
    r = json.loads(out.read_text())
    rates, shares = r["rates"], r["wall_time_share"]
    # 1.2 s simulated: the counts include the instants at both ends, the footstep
    # planner's initialization and the simulator's extra step at each of the three
    # AdvanceTo boundaries (the plant's count), so allow four events over the run
    w = EmoNavConfig().walking  # the configured rates are the measured ones
    expected = {"planner": 2.5, "crowd": 10.0, "digit/alip": 1 / w.planner_period}
    expected |= {"digit/fall_monitor": 1 / w.fall_check_period}
    expected |= {"digit/controller": 1 / w.controller_period, "digit/plant": 1 / w.time_step}
    for name, hz in expected.items():
        assert abs(rates[name] - hz) <= 4 / 1.2, (name, rates[name])
    assert abs(sum(shares.values()) - 1.0) < 1e-3 and shares["digit/controller"] > 0.05
    assert "wall share" in capsys.readouterr().out


def test_a_command_turns_the_step_it_was_planned_for_on_both_plants():
    """The timing pinned: a turn u_Δθ = 0.2 rad planned at t_5 shows in the heading
    change of step 5 (t_5 → t_6), on the LIP plant exactly and on Digit within a few
    centiradians, and not in steps 4 or 6 (before in-step commands Digit walked it in
    step 6)."""
    from emonav_drake.diagrams.navigation import run_episode
    from emonav_drake.diagrams.navigation_digit import run_digit_episode
    from emonav_drake.planners.replay import ReplayPlanner

    cfg = _short_config(8)
    commands = np.array([[0.3, 0.0]] * 8)
    commands[5, 1] = 0.2
    scenario = Scenario(robot_start=[-4.0, 0.0], robot_goal=[4.0, 0.0])
    _, log = run_episode(scenario, cfg, ReplayPlanner(commands), trace=True)
    lip = np.diff([r[2] for r in log.robot])  # heading change of steps 0, 1, ...
    np.testing.assert_allclose(lip[[4, 5, 6]], [0.0, 0.2, 0.0], atol=1e-12)
    _, trace = run_digit_episode(scenario, cfg, ReplayPlanner(commands), trace=True)
    digit = np.diff([r[2] for r in trace.robot])
    assert abs(digit[5] - 0.2) < 0.03, digit
    assert abs(digit[4]) < 0.03 and abs(digit[6]) < 0.03, digit


def test_both_plants_give_the_same_trace_of_one_row_per_planner_instant():
    """`Plant.simulate` with `trace=True` on the same scenario: an `EpisodeTrace` of rows
    k = 0 … steps at t_k = kT, robot (4,), held (2,), pedestrians (P, 2), emotions (P,),
    rewards of the steps (NaN at k = 0); its path, rewards and end agree with the record
    (which keeps no final position: its path length and total reward)."""
    from emonav_drake.diagrams.episode import EpisodeRequest
    from emonav_drake.diagrams.plants import PLANTS
    from emonav_drake.navigation.episode_trace import EpisodeTrace

    cfg = _short_config(4)
    scenario = sample_scenario(2, cfg)
    p = len(scenario.pedestrians)
    T = cfg.robot.step_time
    for name in ("lip", "digit"):
        request = EpisodeRequest(scenario, cfg, DwaPlanner(cfg), trace=True)
        record, trace = PLANTS[name].simulate(request)
        assert isinstance(trace, EpisodeTrace), name
        n = record.steps + 1
        assert len(trace) == n and trace.steps == record.steps == 4, name
        assert trace.k == list(range(n)) and trace.t == [k * T for k in range(n)], name
        for i in range(n):
            assert trace.robot[i].shape == (4,) and trace.held[i].shape == (2,), name
            assert trace.pedestrians[i].shape == (p, 2) and trace.emotions[i].shape == (p,)
        assert np.array_equal(trace.held[0], [0.0, 0.0]) and trace.commands.shape == (4, 2)
        # the monitor measures the path from the scenario's start (Digit's CoM stands a
        # few centimetres off it at t_0) through the robot at t_1 … t_K
        xy = np.vstack([scenario.robot_start, np.asarray(trace.robot)[1:, :2]])
        path = np.hypot(*np.diff(xy, axis=0).T).sum()
        assert math.isclose(path, record.path_length, rel_tol=1e-9), name
        assert math.isnan(trace.rewards[0])
        assert math.isclose(sum(trace.rewards[1:]), record.total_reward, rel_tol=1e-9), name
        assert math.isclose(trace.t[-1], record.nav_time, rel_tol=1e-9), name
        rows = trace.rows()  # the calibration files' form, and back
        assert list(rows[0]) == ["k", "t", "robot", "held", "pedestrians", "emotions"]
        again = EpisodeTrace.from_rows(json.loads(json.dumps(rows)))
        assert again.rows() == rows
        record_only, none = PLANTS[name].simulate(EpisodeRequest(scenario, cfg, DwaPlanner(cfg)))
        assert none is None and record_only.to_json() == record.to_json(), name
