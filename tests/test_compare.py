"""`emonav compare`: benchmark runs made at different times, combined into one comparison
(`evaluation/combine.py`) — real LIP trials, real tables."""

import json

import pytest

from emonav_drake.cli import main
from emonav_drake.configs import load_setting
from emonav_drake.diagrams.trials import method_specs
from emonav_drake.evaluation.benchmark import run_benchmark
from emonav_drake.evaluation.combine import combine_runs
from emonav_drake.evaluation.run_directory import BenchmarkSettingsError, load_run
from emonav_drake.params import load_config


def _run(path, planners, first_seed=5, trials=2, config=None, checkpoints=()):
    methods = method_specs(planners, list(checkpoints))
    run_benchmark(
        path, methods, "lip", trials, first_seed, config or load_config(), workers=1,
        progress=False,
    )  # fmt: skip
    return path


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    root = tmp_path_factory.mktemp("compare")
    a = _run(root / "a", "dwa")
    b = _run(root / "b", "mpc,dwa", first_seed=6)  # dwa again, one seed shared with a
    return root, a, b


@pytest.mark.slow
def test_two_runs_compare_as_one_on_the_seeds_they_share(runs, tmp_path, capsys):
    root, a, b = runs
    settings, trials = combine_runs([a, b])
    assert settings["planners"] == ["dwa", "mpc"]
    assert (settings["first_seed"], settings["trials"]) == (5, 3)
    assert sorted((t["method"], t["seed"]) for t in trials) == [
        ("dwa", 5), ("dwa", 6), ("dwa", 7), ("mpc", 6), ("mpc", 7),
    ]  # fmt: skip
    # the shared dwa trial is the same trial in both runs (kept once)
    assert main(["compare", str(a), str(b), "--out", str(tmp_path / "c")]) == 0
    md = (tmp_path / "c" / "tables.md").read_text()
    assert "| dwa | mpc | 2 |" in md  # McNemar on the 2 seeds both ran
    assert "combined from a (dwa; commit" in md and "b (mpc, dwa; commit" in md
    combined = json.loads((tmp_path / "c" / "combined.json").read_text())
    assert [r["planners"] for r in combined["runs"]] == [["dwa"], ["mpc", "dwa"]]
    # dwa is in both runs: said on stderr and in the tables, never merged silently
    assert "dwa is in 2 runs; merged (1 shared trials agree)" in capsys.readouterr().err
    assert "dwa is in 2 runs (a, b): merged, its 1 trials found in more than one" in md
    assert settings["merged"] == {"dwa": {"runs": [str(a), str(b)], "shared_trials": 1}}


@pytest.mark.slow
def test_runs_of_other_trials_or_clashing_names_are_refused(runs, tmp_path, capsys):
    root, a, _ = runs
    other = _run(tmp_path / "n", "dwa", config=load_setting("no_emotion"))
    # the configuration's first differing field is named, with the run each value is from
    with pytest.raises(
        BenchmarkSettingsError,
        match=r"first difference reward\.neutral_discomfort: 0\.35 in a, 0\.2 in n",
    ):
        combine_runs([a, other])
    with pytest.raises(BenchmarkSettingsError, match="at least two"):
        combine_runs([a])
    # the name dwa for another planner: refused, asking for a rename
    settings, _ = load_run(a)
    clash = tmp_path / "clash"
    clash.mkdir()
    settings["methods"]["dwa"] = dict(settings["methods"]["dwa"], planner="mpc")
    (clash / "settings.json").write_text(json.dumps(settings))
    (clash / "trials.jsonl").write_text((a / "trials.jsonl").read_text())
    with pytest.raises(BenchmarkSettingsError, match="rename"):
        combine_runs([a, clash])
    # --out must not hold a benchmark run
    assert main(["compare", str(a), str(root / "b"), "--out", str(a)]) == 2
    assert "already holds a run" in capsys.readouterr().err
