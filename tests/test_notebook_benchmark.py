"""The benchmark notebook runs headless in its short mode: a tiny benchmark, its tables,
the bar charts and the re-simulated trajectories of a success and a failure."""

import pytest

from tests.notebook_runner import run_short


@pytest.mark.slow
def test_benchmark_notebook_runs_in_short_mode(monkeypatch):
    outputs, cells = run_short("benchmark.ipynb", monkeypatch)
    assert "6 trials of dwa, policy on lip" in outputs
    assert "## Table II" in outputs and "(n=3)" in outputs and "McNemar" in outputs
    # a success and a failure, re-simulated to the recorded outcome
    assert "re-simulated policy seed 12: success, as recorded" in outputs
    assert "re-simulated policy seed 13: timeout, as recorded" in outputs
    images = [o for c in cells for o in c.get("outputs", []) if "image/png" in o.get("data", {})]
    assert len(images) == 2  # the bar charts and the trajectories


@pytest.mark.slow
def test_benchmark_notebook_reads_the_user_s_run_from_any_directory(monkeypatch, tmp_path):
    from emonav_drake.diagrams.trials import method_specs
    from emonav_drake.evaluation.benchmark import run_benchmark
    from emonav_drake.params import load_config

    run = tmp_path / "my_run"
    run_benchmark(run, method_specs("dwa"), "lip", 3, 12, load_config(), workers=1, progress=False)
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.setenv("EMONAV_RUNS", str(run))
    outputs, cells = run_short("benchmark.ipynb", monkeypatch, short=False, cwd=elsewhere)
    assert "my_run: 3 trials of dwa on lip" in outputs
    assert "Digit runs: skipped" in outputs  # the committed Digit runs are not the user's
