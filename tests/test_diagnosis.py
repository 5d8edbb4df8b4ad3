"""`emonav diagnose`: every failed Digit trial re-simulated, its cause and tracking errors."""

import json

import pytest

from emonav_drake.cli import main


@pytest.mark.slow
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


def _lip_run(tmp_path):
    """A tiny LIP run: DWA on seeds 1–3 with 60-step episodes (some reach the goal, some
    time out)."""
    cfg = tmp_path / "short.yaml"
    cfg.write_text("episode: {max_steps: 60}\n")
    run = tmp_path / "run"
    argv = ["benchmark", "--planners", "dwa", "--trials", "3", "--first-seed", "1"]
    argv += ["--workers", "1", "--config", str(cfg), "--out", str(run), "--quiet"]
    assert main(argv) == 0
    trials = [json.loads(line) for line in (run / "trials.jsonl").read_text().splitlines()]
    outcomes = {t["record"]["outcome"] for t in trials}
    assert "success" in outcomes and outcomes - {"success"}, outcomes  # both kinds
    return run, trials


def _listed(text: str) -> list[tuple[int, str, int, str]]:
    """(seed, cause, steps, min distance) of the trial lines of a --failures listing."""
    rows = []
    for line in text.splitlines():
        parts = line.split()
        if len(parts) >= 4 and parts[0].isdigit() and parts[-2].isdigit():
            rows.append((int(parts[0]), " ".join(parts[1:-2]), int(parts[-2]), parts[-1]))
    return rows


@pytest.mark.slow
def test_diagnose_lists_the_failures_of_a_lip_run_and_how_to_rerun_them(tmp_path, capsys):
    import shlex

    run, trials = _lip_run(tmp_path)
    capsys.readouterr()
    assert main(["diagnose", str(run), "--failures"]) == 0
    out = capsys.readouterr().out
    failed = sorted(
        (t["seed"], t["record"]["outcome"], t["record"]["steps"], t["record"]["min_ped_distance"])
        for t in trials
        if t["record"]["outcome"] != "success"
    )
    # every failed trial, and only those, with its record's numbers
    assert _listed(out) == [(s, o, n, f"{d:.2f}") for s, o, n, d in failed]
    assert f"dwa: {len(failed)} of 3 trials failed" in out
    commands = [line.strip() for line in out.splitlines() if line.strip().startswith("emonav sim")]
    assert len(commands) == len(failed)  # the first 3 of each method
    # the printed command plays the trial again: the same record
    argv = shlex.split(commands[0])
    assert argv[:2] == ["emonav", "sim"] and "--plant" not in argv  # the LIP is sim's default
    assert argv[argv.index("--config") + 1] == str(tmp_path / "short.yaml")
    again = tmp_path / "again.json"
    assert main([*argv[1:], "--json", str(again)]) == 0
    replayed = json.loads(again.read_text())
    recorded = next(t["record"] for t in trials if t["seed"] == failed[0][0])
    assert {k: replayed[k] for k in recorded} == recorded
    # --rerun 0: the list without commands
    capsys.readouterr()
    assert main(["diagnose", str(run), "--failures", "--rerun", "0"]) == 0
    assert "emonav sim" not in capsys.readouterr().out
    # neither --failures nor --out: refused
    assert main(["diagnose", str(run)]) == 2
    assert "--failures" in capsys.readouterr().err
    # a LIP run without failures: nothing to re-simulate, and none listed
    won = [line for line in (run / "trials.jsonl").read_text().splitlines() if '"success"' in line]
    (run / "trials.jsonl").write_text("\n".join(won) + "\n")
    assert main(["diagnose", str(run), "--out", str(tmp_path / "none")]) == 2
    assert f"no failed trials of ['dwa'] to diagnose (all {len(won)} succeeded)" in (
        capsys.readouterr().err
    )
    assert main(["diagnose", str(run), "--failures"]) == 0
    out = capsys.readouterr().out
    assert _listed(out) == [] and f"dwa: 0 of {len(won)} trials failed" in out


@pytest.mark.slow
def test_diagnose_re_simulates_a_lip_run_and_skips_the_digit_comparison(tmp_path, capsys):
    run, trials = _lip_run(tmp_path)
    out = tmp_path / "diag"
    assert main(["diagnose", str(run), "--out", str(out)]) == 0
    rows = json.loads((out / "diagnosis.json").read_text())
    failed = [t for t in trials if t["record"]["outcome"] != "success"]
    # the failures only (successes are the reference of Digit's tracking comparison)
    assert [(r["method"], r["seed"]) for r in rows] == [("dwa", t["seed"]) for t in failed]
    for r, t in zip(rows, failed, strict=True):
        assert r["plant"] == "lip" and r["reproduced"] and r["tracking"] is None
        assert r["cause"] == t["record"]["outcome"] == "timeout"
        assert {k: r["record"][k] for k in t["record"]} == t["record"]
    md = (out / "diagnosis.md").read_text()
    assert f"| dwa | {len(failed)} | timeout {len(failed)} |" in md
    assert "skipped — on a LIP run" in md and f"All {len(failed)} re-simulated" in md
    assert "LIP position error" not in md
    assert (out / "diagnosis.png").stat().st_size > 5_000
    assert (out / "run_config.yaml").read_text() == json.loads((run / "settings.json").read_text())[
        "config_yaml"
    ]
    assert _listed((out / "failures.md").read_text()) == [
        (r["seed"], r["cause"], r["steps"], f"{r['min_ped_distance']:.2f}") for r in rows
    ]
    printed = capsys.readouterr().out
    assert "skipped — on a LIP run" in printed and "failures.md" in printed


def test_failures_are_counted_by_what_ended_them():
    from emonav_drake.evaluation.failures import failure_counts, failure_kind, format_counts

    records = [
        {"outcome": "collision", "collided_with": "happy"},
        {"outcome": "collision", "collided_with": "negative"},
        {"outcome": "collision", "collided_with": "wall"},
        {"outcome": "collision", "collided_with": "static"},
        {"outcome": "collision"},  # recorded before `collided_with`
        {"outcome": "timeout"},
        {"outcome": "success"},
    ]
    assert [failure_kind(r) for r in records] == [
        "pedestrian",
        "pedestrian",
        "wall",
        "static",
        "collision",
        "timeout",
        None,
    ]
    counts = failure_counts(records)
    assert sum(counts.values()) == 6
    assert format_counts(counts) == "pedestrian 2, collision 1, static 1, timeout 1, wall 1"


def test_failure_listing_names_causes_and_a_changed_configuration():
    """Collisions name what was hit, falls their reason; a run whose configuration source
    no longer gives its configuration (hash) is re-run from run_config.yaml; a learned
    method with another checkpoint is re-run as `policy` with it."""
    from emonav_drake.evaluation.failures import format_failures, rerun_command

    def trial(method, seed, outcome, **extra):
        record = {"outcome": outcome, "steps": 7 + seed, "min_ped_distance": 0.25 * seed}
        return {"method": method, "seed": seed, "record": record | extra}

    settings = {
        "plant": "digit",
        "planners": ["mine", "dwa"],
        "methods": {
            "mine": {"name": "mine", "planner": "policy", "checkpoint": "/x/mine.pt"}
            | {"checkpoint_sha256": "0" * 64},
            "dwa": {"name": "dwa", "planner": "dwa", "checkpoint": None},
        },
        "config_source": "--setting var_dd",
        "config_sha256": "not the hash of var_dd",
        "first_seed": 1,
        "trials": 4,
        "emotion_estimate_yaml": None,
    }
    trials = [
        trial("mine", 1, "collision", collided_with="negative"),
        trial("mine", 2, "success"),
        trial("mine", 3, "fall", fall_reason="torso at 0.512 m"),
        trial("dwa", 1, "success"),
        trial("dwa", 4, "timeout"),
    ]
    text = format_failures(settings, trials, ["mine", "dwa"], "RUN", rerun=1)
    assert _listed(text) == [
        (1, "collision: negative", 8, "0.25"),
        (3, "fall: torso at 0.512 m", 10, "0.75"),
        (4, "timeout", 11, "1.00"),
    ]
    assert "mine: 2 of 3 trials failed (collision 1, fall 1; by kind: fall 1, pedestrian 1)" in text
    assert "dwa: 1 of 2 trials failed (timeout 1)\n" in text  # no collision: no breakdown
    assert "RUN/settings.json" in text and "> run_config.yaml" in text
    assert rerun_command(settings, "mine", 1) == (
        "emonav sim --planner policy --checkpoint /x/mine.pt --seed 1 --plant digit "
        "--config run_config.yaml"
    )
    assert rerun_command(settings, "dwa", 4, {"config": "d/run_config.yaml"}) == (
        "emonav sim --planner dwa --seed 4 --plant digit --config d/run_config.yaml"
    )
    commands = [line.strip() for line in text.splitlines() if "emonav sim" in line]
    assert commands == [rerun_command(settings, m, s) for m, s in (("mine", 1), ("dwa", 4))]
