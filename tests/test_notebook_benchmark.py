"""The benchmark notebook runs headless in its short mode: a tiny benchmark, its tables,
the bar charts and the re-simulated trajectories of a success and a failure."""

from tests.notebook_runner import run_short


def test_benchmark_notebook_runs_in_short_mode(monkeypatch):
    outputs, cells = run_short("benchmark.ipynb", monkeypatch)
    assert "6 trials of dwa, policy on lip" in outputs
    assert "## Table II" in outputs and "(n=3)" in outputs and "McNemar" in outputs
    # a success and a failure, re-simulated to the recorded outcome
    assert "re-simulated policy seed 12: success, as recorded" in outputs
    assert "re-simulated policy seed 13: timeout, as recorded" in outputs
    images = [o for c in cells for o in c.get("outputs", []) if "image/png" in o.get("data", {})]
    assert len(images) == 2  # the bar charts and the trajectories
