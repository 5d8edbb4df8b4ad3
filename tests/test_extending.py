"""Adding a planner is one module plus one registry line; adding an observation kind, a
plant or a sub-command is one registry entry (docs/architecture.md, "Extending").

The throw-away planner and observation below are registered the way a new module would
register them, then run through `emonav sim` and `emonav benchmark` on both plants, with
nothing else in the package changed.
"""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pytest

from emonav_drake.cli import main
from emonav_drake.diagrams.plants import PLANTS, Plant, register_plant, unregister_plant
from emonav_drake.diagrams.trials import method_specs
from emonav_drake.navigation.lip_world import PlannerInput
from emonav_drake.navigation.observations import (
    ObservationKind,
    ScanStack,
    observation_frame,
    register_observation,
    unregister_observation,
)
from emonav_drake.planners import PlannerKind, register, unregister

SECTORS = 8


# ------------------------------------------------------------- a new observation kind
def sector_frame(robot, crowd, config) -> np.ndarray:
    """The nearest range [m] in each of 8 sectors of the LiDAR scan (sector 0 behind)."""
    scan = observation_frame(robot, crowd, config, "scan")
    return scan.reshape(SECTORS, -1).min(axis=1).astype(np.float32)


SECTOR_KIND = ObservationKind(
    name="toy_sectors",
    description="nearest range per 45° sector",
    key="sectors",
    frame=sector_frame,
    shape=lambda li: (li.num_frames, SECTORS),
    dtype=np.dtype(np.float32),
    high=lambda li: li.max_range,
    new_stack=lambda li: ScanStack(li.num_frames, SECTORS),
    mirror=lambda x: np.ascontiguousarray(np.asarray(x)[..., ::-1]),
    lidar_for=lambda shape, li: {"num_frames": shape[0]},
    scans=True,
)


# --------------------------------------------------------------------- new planners
class StraightPlanner:
    """Walks at 0.3 m/s turning toward the goal: a model planner with no observation."""

    name = "toy_straight"

    def __init__(self, config) -> None:
        self.turn = config.robot.max_heading_change

    def initial_memory(self):
        return None

    def plan_with_memory(self, obs: PlannerInput, memory):
        bearing = float(obs.goal_state()[1])
        return np.array([0.3, float(np.clip(bearing, -self.turn, self.turn))]), memory

    def reset(self) -> None:
        pass

    def plan(self, obs: PlannerInput) -> np.ndarray:
        return self.plan_with_memory(obs, None)[0]


class SectorPlanner(StraightPlanner):
    """Reads the toy observation (2 frames of 8 sectors): slows when the front is close."""

    name = "toy_sectors"
    grid_kind = "toy_sectors"
    expected_shape = (2, SECTORS)
    expected_dtype = np.dtype(np.float32)

    def plan_with_memory(self, obs: PlannerInput, memory):
        stack = obs.lgm_stack
        if stack is None or stack.shape != self.expected_shape or stack.dtype != np.float32:
            raise AssertionError(f"the diagram gave {None if stack is None else stack.shape}")
        command, memory = super().plan_with_memory(obs, memory)
        front = stack[-1][SECTORS // 2 - 1 : SECTORS // 2 + 1].min()  # the two ahead
        if front < 1.0:
            command[0] = 0.1
        return command, memory


class ToySpec:
    """A planner spec of the user's own: the registry builds `planner(config)`."""

    def __init__(self, planner: type) -> None:
        self.planner = planner

    def build(self, config, device="cpu"):
        return self.planner(config)


@pytest.fixture
def toys():
    register_observation(SECTOR_KIND)
    register(PlannerKind("toy_straight", ToySpec(StraightPlanner)))
    register(PlannerKind("toy_sectors", ToySpec(SectorPlanner)))
    yield
    unregister("toy_straight")
    unregister("toy_sectors")
    unregister_observation("toy_sectors")


def _short_config(tmp_path, steps: int):
    path = tmp_path / f"short{steps}.yaml"
    path.write_text(f"episode:\n  max_steps: {steps}\n")
    return str(path)


@pytest.mark.slow
@pytest.mark.parametrize("planner", ["toy_straight", "toy_sectors"])
def test_a_registered_planner_runs_in_sim_on_both_plants(toys, tmp_path, planner):
    lip = [tmp_path / f"lip{i}.json" for i in range(2)]
    for out in lip:  # twice: deterministic
        assert main(["sim", "--planner", planner, "--seed", "3", "--json", str(out)]) == 0
    assert lip[0].read_text() == lip[1].read_text()
    run = json.loads(lip[0].read_text())
    assert run["steps"] > 5
    digit = tmp_path / "digit.json"
    config = _short_config(tmp_path, 4)
    argv = ["sim", "--planner", planner, "--plant", "digit", "--seed", "3", "--config", config]
    assert main([*argv, "--json", str(digit)]) == 0
    assert json.loads(digit.read_text())["steps"] == 4


@pytest.mark.slow
def test_a_registered_planner_and_observation_run_in_benchmark_on_both_plants(toys, tmp_path):
    methods = method_specs("toy_straight,toy_sectors")
    assert [(m.name, m.planner, m.checkpoint) for m in methods] == [
        ("toy_straight", "toy_straight", None),
        ("toy_sectors", "toy_sectors", None),
    ]
    lip = tmp_path / "lip"
    argv = ["benchmark", "--planners", "toy_straight,toy_sectors", "--trials", "2"]
    assert main([*argv, "--first-seed", "10", "--workers", "1", "--out", str(lip)]) == 0
    settings = json.loads((lip / "settings.json").read_text())
    assert settings["methods"]["toy_sectors"]["observation"] == "TOY_SECTORS"
    assert settings["methods"]["toy_straight"]["observation"] == "state"
    trials = [json.loads(line) for line in (lip / "trials.jsonl").read_text().splitlines()]
    assert sorted((t["method"], t["seed"]) for t in trials) == [
        (m, s) for m in ("toy_sectors", "toy_straight") for s in (10, 11)
    ]
    # the sector planner saw the toy observation: it differs from the blind one somewhere
    by = {(t["method"], t["seed"]): t["record"] for t in trials}
    assert any(by["toy_sectors", s] != by["toy_straight", s] for s in (10, 11))
    digit = tmp_path / "digit"
    config = _short_config(tmp_path, 3)
    argv = ["benchmark", "--planners", "toy_sectors", "--plant", "digit", "--trials", "1"]
    assert main([*argv, "--config", config, "--workers", "1", "--out", str(digit)]) == 0
    (line,) = (digit / "trials.jsonl").read_text().splitlines()
    record = json.loads(line)["record"]
    assert record["steps"] == 3 and math.isfinite(record["path_length"])


def test_an_unregistered_planner_is_refused_with_the_choices(tmp_path, capsys):
    with pytest.raises(SystemExit) as e:
        main(["sim", "--planner", "toy_straight"])
    assert e.value.code == 2
    assert "invalid choice: 'toy_straight'" in capsys.readouterr().err


# --------------------------------------------------------------------- a new plant
class HalfSpeed:
    """The planner as a robot that walks every command at half its speed would see it."""

    def __init__(self, planner) -> None:
        self.planner = planner
        self.name = planner.name
        for attr in ("grid_kind", "expected_shape", "expected_dtype"):
            if hasattr(planner, attr):
                setattr(self, attr, getattr(planner, attr))

    def initial_memory(self):
        return self.planner.initial_memory()

    def plan_with_memory(self, obs, memory):
        command, memory = self.planner.plan_with_memory(obs, memory)
        return np.array([0.5 * command[0], command[1]]), memory


def _simulate_half_speed(request):
    """A plant of its own: the LIP's `simulate` on the request with the slow planner."""
    lip = PLANTS["lip"]
    return lip.simulate(dataclasses.replace(request, planner=HalfSpeed(request.planner)))


def _record_only_half_speed(request):
    """The same robot, as a plant that keeps no trace and draws nothing (no `viewers`)."""
    plain = dataclasses.replace(request, meshcat=None, record_html=None, rates=None, trace=False)
    record, _ = _simulate_half_speed(plain)
    return record, None


@pytest.fixture
def half_speed_plant():
    plant = Plant(
        "lip_half", "LIP at half speed", _record_only_half_speed, can_fall=False, footsteps=True
    )
    register_plant(plant)
    yield plant
    unregister_plant("lip_half")


@pytest.mark.slow
def test_a_registered_plant_runs_in_sim_eval_and_benchmark(half_speed_plant, tmp_path, capsys):
    runs = {}
    for plant in ("lip", "lip_half"):
        out = tmp_path / f"{plant}.json"
        assert (
            main(["sim", "--planner", "dwa", "--plant", plant, "--seed", "5", "--json", str(out)])
            == 0
        )
        runs[plant] = json.loads(out.read_text())
    # the slow robot takes more steps to the goal (or times out), deterministically
    assert runs["lip_half"]["steps"] > runs["lip"]["steps"]
    again = tmp_path / "again.json"
    assert (
        main(
            ["sim", "--planner", "dwa", "--plant", "lip_half", "--seed", "5", "--json", str(again)]
        )
        == 0
    )
    assert json.loads(again.read_text()) == runs["lip_half"]
    assert "trajectory" not in runs["lip_half"]  # it gave no trace
    assert main(["sim", "--plant", "lip_half", "--record", str(tmp_path / "r.html")]) == 2
    assert "--record need --plant lip or digit" in capsys.readouterr().err
    ev = tmp_path / "eval.json"
    argv = [
        "eval",
        "--planner",
        "dwa",
        "--plant",
        "lip_half",
        "--episodes",
        "1",
        "--first-seed",
        "5",
    ]
    assert main([*argv, "--json", str(ev)]) == 0
    assert json.loads(ev.read_text())["episodes"][0]["steps"] == runs["lip_half"]["steps"]
    out = tmp_path / "bench"
    argv = ["benchmark", "--planners", "dwa", "--plant", "lip_half", "--trials", "1"]
    assert main([*argv, "--first-seed", "5", "--workers", "1", "--out", str(out)]) == 0
    (line,) = (out / "trials.jsonl").read_text().splitlines()
    trial = json.loads(line)
    assert trial["plant"] == "lip_half"
    assert trial["record"]["steps"] == runs["lip_half"]["steps"]


@pytest.fixture
def half_speed_plant_with_outputs():
    plant = Plant(
        "lip_half_sim",
        "LIP at half speed",
        _simulate_half_speed,
        can_fall=False,
        footsteps=True,
        rays=True,
        viewers=True,
    )
    register_plant(plant)
    yield plant
    unregister_plant("lip_half_sim")


@pytest.mark.slow
def test_a_registered_plant_with_viewers_gets_the_sim_outputs_and_replays(
    half_speed_plant, half_speed_plant_with_outputs, tmp_path
):
    from emonav_drake.diagrams.trials import BenchmarkSpec, MethodSpec, TrialRunner
    from emonav_drake.params import EmoNavConfig, dump_config

    runs = {}
    for plant in ("lip_half", "lip_half_sim"):
        out = tmp_path / f"{plant}.json"
        assert (
            main(["sim", "--planner", "dwa", "--plant", plant, "--seed", "5", "--json", str(out)])
            == 0
        )
        runs[plant] = json.loads(out.read_text())
    steps = runs["lip_half"]["steps"]
    assert runs["lip_half_sim"]["steps"] == steps
    assert "trajectory" in runs["lip_half_sim"] and "trajectory" not in runs["lip_half"]
    assert runs["lip_half_sim"]["trajectory"]["plant"] == "lip_half_sim"
    csv = tmp_path / "steps.csv"
    argv = [
        "sim",
        "--planner",
        "dwa",
        "--plant",
        "lip_half_sim",
        "--seed",
        "5",
        "--steps-out",
        str(csv),
    ]
    assert main(argv) == 0
    assert len(csv.read_text().splitlines()) == steps + 1  # header + one row a step
    # a trial of either replays on its plant; the one without a trace gives None
    for plant, traced in (("lip_half_sim", True), ("lip_half", False)):
        spec = BenchmarkSpec([MethodSpec("dwa", "dwa")], plant, dump_config(EmoNavConfig()))
        _, record, trace = TrialRunner(spec).replay("dwa", 5)
        assert record.steps == steps and (trace is not None) == traced
        assert trace is None or trace.steps == steps


def test_a_plant_without_a_training_environment_is_refused(half_speed_plant):
    from emonav_drake.learning.env_pool import make_env
    from emonav_drake.learning.sac_config import SacConfig
    from emonav_drake.params import ConfigError

    with pytest.raises(ConfigError, match="'lip_half' has no training environment"):
        make_env(SacConfig(plant="lip_half"))


# ---------------------------------------------------------------- a new sub-command
def test_a_new_subcommand_is_one_module_and_one_line(monkeypatch, capsys):
    import types

    import emonav_drake.cli as cli

    hello = types.ModuleType("hello")

    def add_parser(subparsers):
        p = subparsers.add_parser("hello", help="say hello")
        p.add_argument("--name", default="Digit")
        p.set_defaults(func=lambda args: print(f"hello {args.name}") or 0)
        return p

    hello.add_parser = add_parser
    monkeypatch.setattr(cli, "SUBCOMMANDS", (*cli.SUBCOMMANDS, hello))
    assert main(["hello", "--name", "Cassie"]) == 0
    assert capsys.readouterr().out == "hello Cassie\n"
    with pytest.raises(SystemExit) as e:  # argparse's errors, like every command
        main(["hello", "--nmae", "x"])
    assert e.value.code == 2
