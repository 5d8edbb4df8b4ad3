"""`emonav diagnose`: every failed Digit trial re-simulated, its cause and tracking errors."""

import json

from emonav_drake.cli import main


def test_diagnose_explains_the_failures_of_a_digit_run(tmp_path):
    cfg = tmp_path / "short.yaml"
    cfg.write_text("episode: {max_steps: 4}\n")
    run = tmp_path / "run"
    argv = ["benchmark", "--planners", "dwa", "--plant", "digit", "--trials", "2"]
    argv += ["--first-seed", "5", "--workers", "1", "--config", str(cfg), "--out", str(run)]
    assert main([*argv, "--quiet"]) == 0
    out = tmp_path / "diag"
    assert main(["diagnose", str(run), "--last", "3", "--out", str(out)]) == 0
    rows = json.loads((out / "diagnosis.json").read_text())
    assert [(r["method"], r["seed"]) for r in rows] == [("dwa", 5), ("dwa", 6)]
    for r in rows:  # 4-step episodes time out; the re-simulation reproduces the trial
        assert r["cause"] == "timeout" and r["reproduced"]
        t = r["tracking"]  # steps 1 and 2 (step 0 starts standing, the last is left out)
        assert t["steps"] == 2 and len(t["lip_heading"]) == 2 and len(t["model_position"]) == 2
        assert all(e >= 0 for e in t["lip_position"])
    assert "| dwa | 2 | timeout 2 |" in (out / "diagnosis.md").read_text()
    assert (out / "diagnosis.png").stat().st_size > 10_000
    assert main(["diagnose", str(tmp_path), "--out", str(out)]) == 2  # not a run directory
