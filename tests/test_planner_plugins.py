"""A planner from a module outside the package (`examples/cautious_planner.py`), registered
with `--planner-module` or as an installed plug-in (an entry point), runs through `emonav
sim`, `emonav benchmark` (serially and on Ray workers, to the same trials) and as a DAgger
route's expert — no edit of emonav_drake (issue 39 item 5)."""

import json
import sys
import textwrap
from pathlib import Path

import pytest

from emonav_drake.cli import main
from emonav_drake.planners import is_registered, make_planner, unregister
from emonav_drake.planners.plugins import import_planner_module, load_entry_points

ROOT = Path(__file__).resolve().parent.parent
EXAMPLE = ROOT / "examples" / "cautious_planner.py"


@pytest.fixture()
def short(tmp_path):
    path = tmp_path / "short.yaml"
    path.write_text("episode: {max_steps: 6}\n")
    return path


@pytest.mark.slow
def test_sim_runs_a_planner_named_by_its_module_on_both_plants(tmp_path, short):
    for plant in ("lip", "digit"):
        records = []
        for run in range(2):
            out = tmp_path / f"{plant}{run}.json"
            argv = ["sim", "--planner-module", str(EXAMPLE), "--planner", "cautious"]
            argv += ["--plant", plant, "--seed", "3", "--config", str(short), "--json", str(out)]
            assert main([*argv, "-q"]) == 0
            records.append(json.loads(out.read_text()))
        assert records[0] == records[1], plant  # deterministic
        assert records[0]["steps"] >= 1
    assert is_registered("cautious")


@pytest.mark.slow
def test_benchmark_workers_import_the_module_and_equal_the_serial_run(tmp_path, short):
    runs = {}
    for workers in (1, 2):
        out = tmp_path / f"w{workers}"
        argv = ["benchmark", "--planner-module", str(EXAMPLE), "--planners", "cautious,dwa"]
        argv += ["--trials", "2", "--first-seed", "4", "--config", str(short)]
        assert main([*argv, "--workers", str(workers), "--out", str(out), "-q"]) == 0
        settings = json.loads((out / "settings.json").read_text())
        assert settings["planner_modules"] == [str(EXAMPLE.resolve())]
        lines = [json.loads(line) for line in (out / "trials.jsonl").read_text().splitlines()]
        runs[workers] = sorted(
            ((t["method"], t["seed"]), t["record"]) for t in lines
        )  # fmt: skip
    assert runs[1] == runs[2]
    assert {k[0] for k, _ in runs[1]} == {"cautious", "dwa"}


@pytest.mark.slow
def test_a_registered_planner_of_ones_own_is_a_dagger_expert(tmp_path):
    from emonav_drake.learning.config import DaggerConfig
    from emonav_drake.learning.dagger import train_dagger
    from emonav_drake.planners.policy import load_policy
    from emonav_drake.planners.specs import PlannerSpec

    cfg = DaggerConfig(expert=PlannerSpec("cautious"), planner_modules=[str(EXAMPLE)])
    cfg.expert_episodes, cfg.episodes_per_round, cfg.rounds = 2, 1, 1
    cfg.grad_steps_first, cfg.grad_steps_per_round, cfg.batch_size = 4, 2, 8
    cfg.eval_episodes, cfg.hidden = 1, 16
    train_dagger(tmp_path / "run", cfg.validate())
    _, meta = load_policy(tmp_path / "run" / "policy.pt")
    assert meta["provenance"]["config"]["expert"] == {
        "_tag": "!PlannerSpec",
        "name": "cautious",
        "checkpoint": "",
    }
    assert meta["provenance"]["config"]["planner_modules"] == [str(EXAMPLE)]
    # through the command line, the module given there and recorded in the run
    route = tmp_path / "route.yaml"
    route.write_text(
        "expert: !PlannerSpec {name: cautious}\nexpert_episodes: 2\nepisodes_per_round: 1\n"
        "rounds: 1\n"
        "grad_steps_first: 4\ngrad_steps_per_round: 2\nbatch_size: 8\neval_episodes: 1\n"
        "hidden: 16\n"
    )
    out = tmp_path / "cli"
    argv = ["train", "--algo", "dagger", "--planner-module", str(EXAMPLE)]
    assert main([*argv, "--config", str(route), "--out", str(out), "-q"]) == 0
    _, meta = load_policy(out / "policy.pt")
    assert meta["provenance"]["config"]["planner_modules"] == [str(EXAMPLE.resolve())]


@pytest.mark.slow
def test_a_planner_of_ones_own_labels_the_digit_rounds_on_ray_workers_too():
    """The Digit rounds label with the calibrated run's expert: a planner of the user's own
    (its module recorded in the run) is imported by every Ray worker, and two workers give
    the serial round's labels bit for bit."""
    import numpy as np

    from emonav_drake.learning.digit_dagger import collect_round
    from emonav_drake.learning.digit_rounds_config import DigitRoundsConfig
    from emonav_drake.params import EmoNavConfig
    from emonav_drake.planners.policy import DEFAULT_POLICY
    from emonav_drake.planners.specs import PlannerSpec

    short = EmoNavConfig()
    short.episode.max_steps = 3
    cfg = DigitRoundsConfig(
        episodes=2, beta=1.0, expert=PlannerSpec("cautious"), planner_modules=[str(EXAMPLE)]
    )
    import_planner_module(str(EXAMPLE))
    serial = collect_round(DEFAULT_POLICY, cfg, 0, 1, None, short)
    ray = collect_round(DEFAULT_POLICY, cfg, 0, 2, None, short)
    assert [e["seed"] for e in ray] == [e["seed"] for e in serial]
    for a, b in zip(serial, ray, strict=True):
        assert len(a["labels"]) >= 3
        for key in ("frames", "states", "labels"):
            assert np.array_equal(a[key], b[key]), key


@pytest.mark.slow
def test_a_planner_of_ones_own_is_sarls_imitation_expert(tmp_path):
    """SARL imitates a planner named by its module (`--planner-module`, recorded in the
    run's configuration, so `--resume` finds the expert again)."""
    from emonav_drake.learning.run_state import read_state_config
    from emonav_drake.learning.sarl_run import STATE_FILE

    route = tmp_path / "sarl.yaml"
    route.write_text(
        "expert: !PlannerSpec {name: cautious}\nil_episodes: 2\nil_epochs: 1\n"
        "rl_episodes: 1\ntrain_batches: 1\neval_episodes: 1\neval_every: 1\n"
    )
    out = tmp_path / "run"
    argv = ["train", "--algo", "sarl", "--config", str(route), "--out", str(out), "-q"]
    assert main([*argv, "--planner-module", str(EXAMPLE)]) == 0
    saved = read_state_config(out / STATE_FILE)
    assert saved["planner_modules"] == [str(EXAMPLE.resolve())]
    assert saved["expert"] == {"_tag": "!PlannerSpec", "name": "cautious", "checkpoint": ""}


def test_an_installed_plug_in_registers_through_its_entry_point(tmp_path, monkeypatch):
    """A distribution on the path that declares an `emonav_drake.planners` entry point."""
    (tmp_path / "fake_plug.py").write_text(
        textwrap.dedent(
            """
            from emonav_drake.planners import PlannerKind, register
            from emonav_drake.planners.specs import DwaSpec

            register(PlannerKind("fake_plug_dwa", DwaSpec()))
            """
        )
    )
    info = tmp_path / "fake_plug-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: fake-plug\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text("[emonav_drake.planners]\nfake = fake_plug\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    try:
        assert "fake" in load_entry_points()
        assert is_registered("fake_plug_dwa")
        from emonav_drake.params import EmoNavConfig

        assert make_planner("fake_plug_dwa", EmoNavConfig()).name == "fake_plug_dwa"
    finally:
        unregister("fake_plug_dwa")
        sys.modules.pop("fake_plug", None)


def test_a_bad_module_is_one_clear_error(tmp_path, capsys):
    assert main(["sim", "--planner-module", str(tmp_path / "nope.py")]) == 2
    assert "--planner-module" in capsys.readouterr().err
    broken = tmp_path / "broken.py"
    broken.write_text("raise RuntimeError('half written')\n")
    assert main(["sim", "--planner-module", str(broken)]) == 2
    err = capsys.readouterr().err
    assert "importing it failed" in err and "half written" in err
    with pytest.raises(Exception, match="no such module"):
        import_planner_module("surely_not_a_module_here")
