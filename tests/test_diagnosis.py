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


def test_diagnose_names_the_settings_file_of_a_bad_configuration(tmp_path, capsys):
    """The run's configuration is YAML text inside settings.json: an error in it names the
    file and the field, not `<yaml>`."""
    import hashlib
    from pathlib import Path

    shipped = Path(__file__).parent.parent / "benchmarks/results/digit_table2/settings.json"
    run = tmp_path / "run"
    run.mkdir()
    (run / "trials.jsonl").write_text("")
    for text, culprit in (
        ("robot: {max_speed: -1}\n", "robot.max_speed"),
        ("robot: [1\n", "invalid YAML"),
        ("bogus: 1\n", "bogus"),
    ):
        settings = json.loads(shipped.read_text())
        settings["config_yaml"] = text
        settings["config_sha256"] = hashlib.sha256(text.encode()).hexdigest()
        (run / "settings.json").write_text(json.dumps(settings))
        assert main(["diagnose", str(run), "--out", str(tmp_path / "diag")]) == 2
        err = capsys.readouterr().err.strip()
        assert err.startswith(f"emonav: error: {run / 'settings.json'} (config_yaml): "), err
        assert culprit in err and "<yaml>" not in err and len(err.splitlines()) == 1
    assert not (tmp_path / "diag").exists()


def test_diagnose_a_run_without_trials(tmp_path, capsys):
    from pathlib import Path

    shipped = Path(__file__).parent.parent / "benchmarks/results/digit_table2/settings.json"
    run = tmp_path / "run"
    run.mkdir()
    (run / "trials.jsonl").write_text("")
    (run / "settings.json").write_text(shipped.read_text())
    assert main(["diagnose", str(run), "--out", str(tmp_path / "diag")]) == 2
    assert "no finished trials" in capsys.readouterr().err
