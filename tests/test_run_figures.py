"""Figures for a user's own runs (issue 51, item 1): a benchmark writes its figures beside
its tables, `emonav report` draws and compares run directories, `emonav plot` draws one
trial of a benchmark's trials file — real LIP trials."""

from __future__ import annotations

import json

import pytest

from emonav_drake.cli import main

PNG = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def two_runs(tmp_path_factory):
    root = tmp_path_factory.mktemp("figures")
    base = ["benchmark", "--planners", "dwa,mpc", "--plant", "lip", "--trials", "5"]
    base += ["--workers", "1", "-q"]
    assert main([*base, "--out", str(root / "paper")]) == 0
    assert main([*base, "--family", "blocker", "--out", str(root / "blocker")]) == 0
    return root / "paper", root / "blocker"


@pytest.mark.slow
def test_a_benchmark_writes_its_figures_beside_its_tables(two_runs):
    for run in two_runs:
        for name in ("summary.png", "social.png"):
            data = (run / name).read_bytes()
            assert data.startswith(PNG) and len(data) > 10_000, (run, name)


@pytest.mark.slow
def test_report_compares_runs_with_a_heat_map_when_families_differ(two_runs, tmp_path):
    from emonav_drake.evaluation.run_directory import load_run
    from emonav_drake.evaluation.run_figures import plot_report

    out = tmp_path / "report"
    assert main(["report", *map(str, two_runs), "--out", str(out)]) == 0
    md = (out / "report.md").read_text()
    assert "## paper" in md and "## blocker" in md and "family blocker" in md
    assert "the simulator's crowd — privileged" in md  # what each row reads
    assert (out / "report.png").read_bytes().startswith(PNG)
    loaded = [(p, *load_run(p)) for p in two_runs]
    titles = [ax.get_title() for ax in plot_report(loaded).axes]
    assert "SR per family" in titles  # two families: the heat map
    same = [(p, *load_run(p)) for p in two_runs[:1] * 2]
    assert "SR per family" not in [ax.get_title() for ax in plot_report(same).axes]


@pytest.mark.slow
def test_plot_draws_one_trial_of_a_trials_file_as_it_ran(two_runs, tmp_path, capsys):
    from emonav_drake.diagrams.trials import TrialRunner
    from emonav_drake.evaluation.run_directory import load_run
    from emonav_drake.evaluation.run_settings import spec_from_settings

    run = two_runs[1]
    settings, trials = load_run(run)
    line = next(t for t in trials if t["method"] == "mpc" and t["seed"] == 3)
    _, record, _ = TrialRunner(spec_from_settings(settings)).replay("mpc", 3)
    # the replay is the trial: same outcome, steps, discomfort
    for key in ("outcome", "steps", "discomfort_steps", "idt"):
        assert getattr(record, key) == line["record"][key], key
    png = tmp_path / "trial.png"
    argv = ["plot", str(run / "trials.jsonl"), "--method", "mpc", "--seed", "3"]
    assert main([*argv, "--png", str(png)]) == 0
    assert png.read_bytes().startswith(PNG)
    capsys.readouterr()
    # without a trial picked, or with one the run does not have: one line saying what to do
    assert main(["plot", str(run / "trials.jsonl"), "--png", str(png)]) == 2
    assert "pick one with --method (dwa, mpc) and --seed" in capsys.readouterr().err
    assert main([*argv[:2], "--method", "mpc", "--seed", "99", "--png", str(png)]) == 2
    assert "mpc has no such trial" in capsys.readouterr().err
    assert json.loads((run / "settings.json").read_text())["plant"] == "lip"
