import json

import pytest

from emonav_drake.cli import main
from emonav_drake.configs import SETTINGS


def test_sim_writes_the_json_outcome(tmp_path, capsys):
    out = tmp_path / "r.json"
    assert (
        main(["sim", "--planner", "dwa", "--plant", "lip", "--seed", "1", "--json", str(out)]) == 0
    )
    r = json.loads(out.read_text())
    assert set(r) >= {
        "outcome",
        "steps",
        "nav_time",
        "path_length",
        "min_ped_distance",
        "discomfort_steps",
        "idt",
        "seed",
    }
    assert r["outcome"] == "success" and r["seed"] == 1
    assert r["nav_time"] == r["steps"] * 0.4 and len(r["idt"]) == 4
    assert r["path_length"] >= 7.8  # (−4, 0) → within 0.2 m of (4, 0)
    assert "success" in capsys.readouterr().out


def test_sim_with_a_yaml_scenario_and_bad_scenarios(tmp_path, capsys):
    sc = tmp_path / "s.yaml"
    sc.write_text(
        "pedestrians:\n"
        "  - {start: [0.0, 4.0], goal: [0.0, -4.0], emotion: negative}\n"
        "obstacles:\n"
        "  - {center: [1.5, 0.0], radius: 0.35}\n"
    )
    out = tmp_path / "r.json"
    assert main(["sim", "--seed", "9", "--scenario", str(sc), "--json", str(out)]) == 0
    assert json.loads(out.read_text())["outcome"] == "success"
    sc.write_text("pedestrians:\n  - {start: [0.0, 4.0], goal: [0.0, -4.0], emotion: sad}\n")
    assert main(["sim", "--scenario", str(sc)]) == 2
    assert "pedestrians[0].emotion" in capsys.readouterr().err
    cfg = tmp_path / "c.yaml"
    cfg.write_text("robot: {max_speed: 7.0}\n")
    assert main(["sim", "--config", str(cfg)]) == 2
    assert "robot.max_speed" in capsys.readouterr().err


@pytest.mark.slow
def test_lgm_png(tmp_path):
    png = tmp_path / "lgm.png"
    assert main(["lgm", "--seed", "2", "--png", str(png)]) == 0
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 20_000


@pytest.mark.slow
def test_eval_summary(tmp_path):
    out = tmp_path / "e.json"
    assert (
        main(
            ["eval", "--planner", "dwa", "--episodes", "3", "--first-seed", "5", "--json", str(out)]
        )
        == 0
    )
    r = json.loads(out.read_text())
    assert r["summary"]["episodes"] == 3 and len(r["episodes"]) == 3
    assert [e["seed"] for e in r["episodes"]] == [5, 6, 7]
    # the summary is that of the episodes listed
    successes = sum(e["outcome"] == "success" for e in r["episodes"])
    assert r["summary"]["SR"] == pytest.approx(successes / 3)
    # and each episode is what `emonav sim` gives for its seed
    one = tmp_path / "s.json"
    assert main(["sim", "--planner", "dwa", "--seed", "6", "--json", str(one)]) == 0
    sim = json.loads(one.read_text())
    assert {k: sim[k] for k in r["episodes"][1]} == r["episodes"][1]


@pytest.mark.slow
def test_sim_with_misclassified_emotions(tmp_path):
    est = tmp_path / "est.yaml"
    est.write_text(
        "mode: confusion\nseed: 4\nconfusion: [[0.6, 0.3, 0.1], [0.2, 0.6, 0.2], [0.1, 0.3, 0.6]]\n"
    )
    runs = []
    for name in ("r1", "r2"):  # the misclassifications are seeded: the same run twice
        out = tmp_path / f"{name}.json"
        assert main(["sim", "--seed", "4", "--emotion-estimate", str(est), "--json", str(out)]) == 0
        runs.append(json.loads(out.read_text()))
    assert runs[0] == runs[1]
    # a confusion matrix that never errs perceives the truth: the ground-truth run
    est_id = tmp_path / "identity.yaml"
    est_id.write_text("mode: confusion\nseed: 4\nconfusion: [[1, 0, 0], [0, 1, 0], [0, 0, 1]]\n")
    truth, ident = tmp_path / "truth.json", tmp_path / "ident.json"
    assert main(["sim", "--seed", "4", "--json", str(truth)]) == 0
    assert (
        main(["sim", "--seed", "4", "--emotion-estimate", str(est_id), "--json", str(ident)]) == 0
    )
    truth_run, ident_run = json.loads(truth.read_text()), json.loads(ident.read_text())
    assert (
        truth_run.pop("emotion_source") == "truth"
        and ident_run.pop("emotion_source") == "confusion"
    )
    assert "emotion_estimate" not in truth_run.pop("spec")  # the simulator's own emotions
    assert ident_run.pop("spec")["emotion_estimate"]["mode"] == "confusion"
    assert truth_run == ident_run
    est.write_text("mode: confusion\nconfusion: [[2.0, 0.0, 0.0], [0, 1, 0], [0, 0, 1]]\n")
    assert main(["sim", "--seed", "4", "--emotion-estimate", str(est)]) == 2


def test_shipped_example_scenarios_load_and_run_by_name(tmp_path, capsys):
    """Every example scenario is valid and runs by its name; a bad name lists them."""
    from emonav_drake.scenarios import EXAMPLES, scenario_path
    from emonav_drake.scenarios.scenario import load_scenario

    for name in EXAMPLES:
        sc = load_scenario(scenario_path(name))
        assert sc.pedestrians and (sc.obstacles or sc.walls), name
    assert any(p.emotion_schedule for p in load_scenario(scenario_path("mood_swing")).pedestrians)
    out = tmp_path / "r.json"
    assert main(["sim", "--scenario", "head_on", "--json", str(out)]) == 0
    run = json.loads(out.read_text())["trajectory"]
    head_on = load_scenario(scenario_path("head_on"))
    # the episode played the file's scenario: its robot, obstacles and pedestrians
    assert run["scenario"]["start"] == pytest.approx(head_on.robot_start)
    assert run["scenario"]["goal"] == pytest.approx(head_on.robot_goal)
    assert [o["center"] for o in run["scenario"]["obstacles"]] == [
        pytest.approx(o.center) for o in head_on.obstacles
    ]
    assert run["pedestrians"][0] == [pytest.approx(p.start) for p in head_on.pedestrians]
    assert main(["sim", "--scenario", "nowhere"]) == 2
    assert "head_on, crossing, mood_swing, hallway" in capsys.readouterr().err


@pytest.mark.slow
def test_sim_and_eval_take_a_named_setting_as_benchmark_does(tmp_path, capsys):
    """`--setting NAME` on sim and eval: the shipped setting's configuration; an unknown
    name is refused (exit 2) with the same error line as `benchmark`'s, naming the choices."""
    out = tmp_path / "r.json"
    argv = ["sim", "--plant", "lip", "--seed", "1", "--json", out]
    assert main([*argv, "--setting", "constant_0.5"]) == 0
    discomfort = json.loads(out.read_text())["trajectory"]["scenario"]["discomfort"]
    assert {k: discomfort[k] for k in ("happy", "neutral", "negative")} == dict.fromkeys(
        ("happy", "neutral", "negative"), 0.5
    )
    assert main(argv) == 0  # without it: the defaults (var_dd)
    discomfort = json.loads(out.read_text())["trajectory"]["scenario"]["discomfort"]
    assert (discomfort["happy"], discomfort["negative"]) == (0.2, 0.5)
    capsys.readouterr()

    errors = {}
    for command in ("benchmark", "sim", "eval"):
        extra = ["--out", tmp_path / "run"] if command == "benchmark" else []
        with pytest.raises(SystemExit) as e:
            main([command, "--setting", "var_dd_typo", *extra])
        assert e.value.code == 2
        err = capsys.readouterr().err
        assert "Traceback" not in err
        lines = [line for line in err.splitlines() if "error:" in line]
        assert len(lines) == 1, err  # argparse: the usage, then one error line
        errors[command] = lines[0].removeprefix(f"emonav {command}: ")
    assert errors["sim"] == errors["eval"] == errors["benchmark"]
    assert errors["sim"].startswith("error: argument --setting: invalid choice: 'var_dd_typo'")
    assert all(repr(name) in errors["sim"] for name in SETTINGS)
    # --setting and --config exclude each other, as in benchmark
    with pytest.raises(SystemExit) as e:
        main(["eval", "--setting", "no_emotion", "--config", tmp_path / "c.yaml"])
    assert e.value.code == 2
    assert "not allowed with argument" in capsys.readouterr().err
    assert not (tmp_path / "run").exists()


def test_the_progress_bar_changes_no_lip_episode(capsys):
    """`run_episode(progress=True)`: a bar over simulated time on stderr, ended with the
    outcome; the record and the trace are the same bit for bit."""
    import dataclasses as dc

    import numpy as np

    from emonav_drake.diagrams.navigation import run_episode
    from emonav_drake.params import load_config
    from emonav_drake.planners import make_planner
    from emonav_drake.scenarios.scenario import sample_scenario

    cfg = load_config()
    runs = []
    for progress in (False, True):
        record, log = run_episode(
            sample_scenario(3, cfg), cfg, make_planner("dwa", cfg), progress=progress, trace=True
        )
        runs.append((record, log, capsys.readouterr().err))
    (r0, log0, err0), (r1, log1, err1) = runs
    assert err0 == "" and dc.asdict(r0) == dc.asdict(r1)
    for field in dc.fields(log0):
        a, b = getattr(log0, field.name), getattr(log1, field.name)
        same = all(np.array_equal(x, y, equal_nan=True) for x, y in zip(a, b, strict=True))
        assert len(a) == len(b) and same
    t = r1.steps * cfg.robot.step_time
    assert f"{t:.1f}/{t:.1f} s simulated" in err1 and r1.outcome in err1


@pytest.mark.slow
def test_sim_on_digit_shows_its_bar_on_a_terminal_only(tmp_path, capsys, monkeypatch):
    """`emonav sim --plant digit`: the bar on stderr when it is a terminal and --quiet is
    not given; the --json output is the same file byte for byte either way."""
    import sys

    cfg = tmp_path / "short.yaml"
    cfg.write_text("episode: {max_steps: 10}\n")
    outs = {}
    for name, tty, extra in (("pipe", False, []), ("tty", True, []), ("quiet", True, ["--quiet"])):
        monkeypatch.setattr(sys.stderr, "isatty", lambda tty=tty: tty)
        outs[name] = tmp_path / f"{name}.json"
        argv = ["sim", "--plant", "digit", "--seed", "3", "--planner", "dwa"]
        assert main([*argv, "--config", str(cfg), "--json", str(outs[name]), *extra]) == 0
        captured = capsys.readouterr()
        assert ("Digit episode" in captured.err) == (name == "tty"), (name, captured.err)
        assert "s simulated [" not in captured.out
    texts = {name: p.read_bytes() for name, p in outs.items()}
    assert texts["pipe"] == texts["tty"] == texts["quiet"]
    assert json.loads(texts["tty"])["steps"] == 10
