"""`--state-source lidar`: the state-based planners read the crowd the robot tracks from
its LiDAR scan instead of the simulator's (issue 37; docs/perception.md, "Perceived state").
"""

import json

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator

from emonav_drake.cli import main
from emonav_drake.diagrams.navigation import build_navigation_diagram
from emonav_drake.params import EmoNavConfig
from emonav_drake.planners import make_planner
from emonav_drake.scenarios.scenario import PedestrianSpec, Scenario, StaticDiscSpec

SHORT = "episode: {max_steps: 12}\n"


@pytest.fixture(scope="module")
def short(tmp_path_factory):
    path = tmp_path_factory.mktemp("cfg") / "short.yaml"
    path.write_text(SHORT)
    return path


def _sim(tmp_path, config, planner, source, plant="lip", seed=3):
    """One `emonav sim` episode's JSON (`config`: a configuration file, or None)."""
    out = tmp_path / f"{planner}_{plant}_{source}_{seed}.json"
    argv = ["sim", "--planner", planner, "--plant", plant, "--seed", str(seed)]
    argv += ["--state-source", source, "--json", str(out), "--quiet"]
    argv += ["--config", str(config)] if config is not None else []
    assert main(argv) == 0
    data = json.loads(out.read_text())
    data.pop("wall_seconds", None)
    return data


@pytest.mark.slow
@pytest.mark.parametrize("planner", ["dwa", "mpc", "sarl", "rgl"])
def test_every_state_based_planner_runs_on_the_tracked_crowd_deterministically(tmp_path, planner):
    first = _sim(tmp_path, None, planner, "lidar")  # a whole LIP episode
    again = _sim(tmp_path / ".." / tmp_path.name, None, planner, "lidar")
    assert first == again  # same seed, same tracks, same episode
    truth = _sim(tmp_path, None, planner, "truth")
    assert first["trajectory"]["robot"] != truth["trajectory"]["robot"]  # it reads other state


@pytest.mark.slow
@pytest.mark.parametrize("planner", ["dwa", "mpc", "sarl", "rgl"])
def test_digit_runs_on_the_tracked_crowd_deterministically(tmp_path, short, planner):
    first = _sim(tmp_path, short, planner, "lidar", plant="digit", seed=5)
    again = _sim(tmp_path / ".." / tmp_path.name, short, planner, "lidar", plant="digit", seed=5)
    assert first == again


def test_the_planner_reads_the_tracks_and_they_follow_the_pedestrians():
    """In the diagram, the planner's crowd is the tracker's: one pedestrian crossing in
    front and two discs, all found (within 0.15 m, the pedestrian's speed within 0.15 m/s)
    after a few seconds of scans (a disc hidden at first behind the pedestrian too)."""
    config = EmoNavConfig()
    config.perception.state_source = "lidar"
    scenario = Scenario(
        seed=0,
        pedestrians=[PedestrianSpec(start=(1.0, -3.0), goal=(1.0, 3.5), emotion="negative")],
        obstacles=[
            StaticDiscSpec(center=(-1.5, 1.5), radius=0.3),
            StaticDiscSpec(center=(2.5, -1.5), radius=0.4),
        ],
    ).validate()
    nav = build_navigation_diagram(scenario, config, make_planner("dwa", config))
    sim = Simulator(nav.diagram)
    sim.Initialize()
    sim.AdvanceTo(4.0)  # still discs are static obstacles after TrackerParams.still_duration
    ctx = sim.get_context()
    plan_ctx = nav.planner.GetMyContextFromRoot(ctx)
    seen = nav.planner.GetInputPort("crowd").Eval(plan_ctx)
    truth = nav.crowd.GetOutputPort("crowd").Eval(nav.crowd.GetMyContextFromRoot(ctx))
    assert seen.positions.shape == (1, 2)
    assert np.linalg.norm(seen.positions[0] - truth.positions[0]) < 0.15
    assert np.linalg.norm(seen.velocities[0] - truth.velocities[0]) < 0.15
    assert seen.emotions.tolist() == [2]  # negative, by association with the report
    assert np.isclose(seen.discomfort[0], config.reward.negative_discomfort)
    order = np.argsort(seen.static_centers[:, 0])
    assert np.allclose(seen.static_centers[order], [[-1.5, 1.5], [2.5, -1.5]], atol=0.05)
    assert np.allclose(seen.static_radii[order], [0.3, 0.4], atol=0.05)


@pytest.mark.parametrize("still, static_at_1_5_s", [(2.0, 0), (1.0, 1)])
def test_the_still_duration_decides_when_a_disc_is_a_static_obstacle(still, static_at_1_5_s):
    """`perception.still_duration` [s]: a disc in view from the start is a pedestrian at
    rest until its track has been still that long, then a static obstacle (at 1.5 s: still
    a pedestrian with the default 2 s, a static disc with 1 s)."""
    config = EmoNavConfig()
    config.perception.state_source = "lidar"
    config.perception.still_duration = still
    scenario = Scenario(
        seed=0,
        pedestrians=[PedestrianSpec(start=(3.0, 3.0), goal=(3.0, 3.5))],
        obstacles=[StaticDiscSpec(center=(-1.5, 1.5), radius=0.4)],
    ).validate()
    nav = build_navigation_diagram(scenario, config, make_planner("dwa", config))
    sim = Simulator(nav.diagram)
    sim.Initialize()
    sim.AdvanceTo(1.5)
    seen = nav.planner.GetInputPort("crowd").Eval(
        nav.planner.GetMyContextFromRoot(sim.get_context())
    )
    assert len(seen.static_centers) == static_at_1_5_s
    disc = np.vstack([seen.positions, seen.static_centers])
    assert np.min(np.linalg.norm(disc - [-1.5, 1.5], axis=1)) < 0.05  # tracked either way


@pytest.mark.slow
def test_a_benchmark_records_its_state_source(tmp_path, short):
    out = tmp_path / "run"
    argv = ["benchmark", "--planners", "dwa", "--trials", "2", "--workers", "1", "--quiet"]
    argv += ["--config", str(short), "--state-source", "lidar", "--out", str(out)]
    assert main(argv) == 0
    settings = json.loads((out / "settings.json").read_text())
    assert "state_source: lidar" in settings["config_yaml"]
    assert settings["setting_label"].endswith("lidar state")
    assert "--state-source lidar" in settings["config_source"]


@pytest.mark.slow
def test_eval_takes_the_state_source(tmp_path):
    runs = {}
    for source in ("truth", "lidar"):
        out = tmp_path / f"{source}.json"
        argv = ["eval", "--planner", "mpc", "--episodes", "3", "--first-seed", "7"]
        assert main([*argv, "--state-source", source, "--json", str(out)]) == 0
        runs[source] = json.loads(out.read_text())
    assert len(runs["truth"]["episodes"]) == len(runs["lidar"]["episodes"]) == 3
    assert runs["truth"]["episodes"] != runs["lidar"]["episodes"]  # the MPC read other state


@pytest.mark.slow
def test_a_parallel_lidar_benchmark_equals_the_serial_one(tmp_path, short):
    """The tracker lives in each trial's diagram: two Ray workers give the serial trials."""
    from emonav_drake.evaluation.run_directory import comparable, read_trials

    runs = {}
    for workers in ("1", "2"):
        out = tmp_path / f"w{workers}"
        argv = ["benchmark", "--planners", "dwa,mpc", "--trials", "3", "--first-seed", "20"]
        argv += ["--config", str(short), "--state-source", "lidar", "--quiet"]
        assert main([*argv, "--workers", workers, "--out", str(out)]) == 0
        trials = read_trials(out / "trials.jsonl")
        runs[workers] = sorted(map(comparable, trials), key=lambda t: (t["method"], t["seed"]))
    assert len(runs["1"]) == 6 and runs["1"] == runs["2"]
