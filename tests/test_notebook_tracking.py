"""The tracking-error notebook runs headless in its short mode: several open-loop seeds,
one short Digit navigation episode, statistics tables, figures; outputs are not stored."""

import re

import pytest

from tests.notebook_runner import run_short

NAME = "tracking_errors.ipynb"


@pytest.mark.slow
def test_tracking_notebook_runs_in_short_mode(monkeypatch, tmp_path):
    monkeypatch.setenv("EMONAV_FIGURES", str(tmp_path))
    text, cells = run_short(NAME, monkeypatch)
    # open loop: two seeds, no fall, per-seed RMS lines
    assert text.count("fell: False") == 2 and "fell: True" not in text
    assert "tracking RMS per step" in text
    # the statistics tables: per seed and pooled, every statistic, units labelled
    assert "Open-loop walking: per-step errors" in text
    assert "Digit navigation: per-step errors" in text
    for stat in ("mean", "std", "rms", "p50", "p95", "max"):
        assert re.search(rf"\b{stat}\b", text), stat
    pooled = [line.split() for line in text.splitlines() if re.match(r"\s*pooled\s+err_", line)]
    assert {row[1] for row in pooled} >= {"err_x", "err_y", "err_heading"}
    assert all(row[2] in ("cm", "rad") for row in pooled)
    assert all(all(float(v) >= 0 for v in row[5:]) for row in pooled)  # std, RMS, |e| stats
    # a short Digit navigation episode, its RMS and the one-step-lag comparison
    assert re.search(r"seed 0: (timeout|success|collision|fall) after \d+ steps", text)
    m = re.search(r"navigation tracking RMS per step \(k >= 2, (\d+) steps\): x ([\d.]+) cm", text)
    assert m and int(m.group(1)) >= 3 and 0.0 < float(m.group(2)) < 20.0
    assert "LIP driven by u_k | by u_k-1" in text
    # every figure rendered (inline) and exported as a PNG
    images = sum("image/png" in o.get("data", {}) for c in cells for o in c.get("outputs", []))
    assert images == 5
    pngs = {p.name for p in tmp_path.glob("*.png")}
    assert pngs == {
        "walk_errors_vs_time.png",
        "walk_error_histograms.png",
        "nav_errors_vs_time.png",
        "nav_histograms_and_turn_lag.png",
        "alip_prediction.png",
    }
    assert not any("Traceback" in o.get("text", "") for c in cells for o in c.get("outputs", []))
