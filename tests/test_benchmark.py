"""`emonav benchmark`: Ray = serial record for record, resumable, settings guarded, tables.

Real planners and a real local Ray, tiny sizes (LIP plant unless stated).
"""

from __future__ import annotations

import csv
import io
import json
import shutil
from pathlib import Path

import pytest

from emonav_drake.cli import main
from emonav_drake.configs import SETTINGS, load_setting, setting_path
from emonav_drake.diagrams.trials import BenchmarkSpec, MethodSpec, TrialRunner, method_specs
from emonav_drake.errors import RunInterrupted
from emonav_drake.evaluation import tables
from emonav_drake.evaluation.benchmark import run_benchmark
from emonav_drake.evaluation.run_directory import comparable, load_run, read_trials
from emonav_drake.evaluation.run_settings import BenchmarkSettingsError
from emonav_drake.params import dump_config, load_config

METHODS = "dwa,policy"
TRIALS = 3
FIRST = 4


def _bench(out: Path, *extra: str) -> int:
    return main(
        ["benchmark", "--planners", METHODS, "--trials", str(TRIALS), "--first-seed", str(FIRST)]
        + ["--workers", "1", "--quiet", "--out", str(out), *extra]
    )


def _lines(run: Path) -> set[str]:
    """trials.jsonl as a set of records (wall times aside)."""
    return {json.dumps(comparable(t), sort_keys=True) for t in read_trials(run / "trials.jsonl")}


def _csv(path: Path, drop: str | None = None) -> list[dict]:
    rows = list(csv.DictReader(io.StringIO(path.read_text())))
    return [{k: v for k, v in r.items() if k != drop} for r in rows]


def _same_tables(a: Path, b: Path) -> None:
    for name in ("table2.csv", "table3.csv", "pairwise.csv"):
        assert (a / name).read_text() == (b / name).read_text(), name
    assert _csv(a / "social.csv", "wall_seconds_mean") == _csv(
        b / "social.csv", "wall_seconds_mean"
    )


@pytest.fixture(scope="module")
def reference(tmp_path_factory) -> Path:
    """The uninterrupted serial run: dwa and the shipped policy on seeds 4–6."""
    out = tmp_path_factory.mktemp("bench") / "reference"
    assert _bench(out) == 0
    return out


@pytest.mark.slow
def test_serial_run_writes_lines_settings_and_tables(reference):
    settings, trials = load_run(reference)
    assert settings["planners"] == ["dwa", "policy"] and settings["plant"] == "lip"
    assert settings["trials"] == TRIALS and settings["first_seed"] == FIRST
    assert settings["goal_radius"] == load_config().episode.eval_goal_radius
    assert load_config(data=settings["config_yaml"]) == load_config()
    assert len(settings["methods"]["policy"]["checkpoint_sha256"]) == 64
    assert settings["package"]["code_sha256"] and settings["package"]["version"]
    assert [(t["method"], t["seed"]) for t in trials] == [
        (m, s) for m in ("dwa", "policy") for s in range(FIRST, FIRST + TRIALS)
    ]
    for t in trials:
        assert t["plant"] == "lip" and t["record"]["seed"] == t["seed"] and t["wall_seconds"] > 0
        # the outcome agrees with the rest of the record
        r, cfg = t["record"], load_config()
        assert (r["outcome"] == "collision") == bool(r.get("collided_with")), r
        assert r["steps"] <= cfg.episode.max_steps, r
        assert r["outcome"] != "timeout" or r["steps"] == cfg.episode.max_steps, r
        assert r["nav_time"] == pytest.approx(r["steps"] * cfg.robot.step_time), r
    md = (reference / "tables.md").read_text()
    # every success rate with its Wilson interval and trial count
    k = sum(t["record"]["outcome"] == "success" for t in trials if t["method"] == "dwa")
    lo, hi = tables.wilson_interval(k, TRIALS)
    assert f"{k / TRIALS:.3f} [{lo:.3f}, {hi:.3f}] (n={TRIALS})" in md
    for heading in ("Table II", "Table III", "Social metrics", "McNemar"):
        assert heading in md
    row = _csv(reference / "table2.csv")[0]
    assert row["method"] == "dwa" and float(row["SR_ci_low"]) == pytest.approx(lo)


def test_wilson_and_mcnemar_values():
    lo, hi = tables.wilson_interval(0, 10)
    assert lo == 0.0 and hi == pytest.approx(0.2775, abs=1e-4)
    lo, hi = tables.wilson_interval(95, 100)
    assert (lo, hi) == pytest.approx((0.8883, 0.9785), abs=1e-4)
    assert tables.mcnemar_exact(0, 6) == pytest.approx(0.03125)
    assert tables.mcnemar_exact(3, 3) == 1.0 and tables.mcnemar_exact(0, 0) == 1.0
    assert tables.mcnemar_exact(1, 9) == pytest.approx(0.021484375)
    # signed ranks: six pairs all worse, no ties → exact two-sided p = 2 / 2**6
    assert tables.signed_rank_p([0] * 6, [1, 2, 3, 4, 5, 6]) == pytest.approx(0.03125)
    assert tables.signed_rank_p([2, 0, 5], [2, 0, 5]) == 1.0


@pytest.mark.slow
def test_ray_equals_serial_and_a_ray_run_survives_ctrl_c(reference, tmp_path):
    """2 Ray workers: Ctrl-C after 2 trials keeps them and writes the tables; the same call
    continues; the result is the serial run, record for record."""
    methods = method_specs(METHODS)
    out = tmp_path / "ray"

    def stop_after_two(trial: dict, n: int) -> None:
        if n == 2:
            raise KeyboardInterrupt

    kwargs = dict(out=out, methods=methods, plant="lip", trials=TRIALS, first_seed=FIRST)
    with pytest.raises(RunInterrupted, match="run the same command again"):
        run_benchmark(
            **kwargs, config=load_config(), workers=2, progress=False, on_trial=stop_after_two
        )
    assert len(read_trials(out / "trials.jsonl")) == 2
    assert "INTERRUPTED" in (out / "tables.md").read_text()
    result = run_benchmark(**kwargs, config=load_config(), workers=2, progress=False)
    assert result.ran == 2 * TRIALS - 2
    assert _lines(out) == _lines(reference)
    assert len(read_trials(out / "trials.jsonl")) == 2 * TRIALS  # nothing run twice
    _same_tables(out, reference)


@pytest.mark.slow
def test_interrupted_serial_run_resumes_to_the_same_result(reference, tmp_path):
    out = tmp_path / "resumed"
    # a short run first (as if killed after 2 trials per method), then a Ctrl-C …
    assert (
        main(
            ["benchmark", "--planners", METHODS, "--trials", "1", "--first-seed", str(FIRST)]
            + ["--workers", "1", "--quiet", "--out", str(out)]
        )
        == 0
    )
    assert len(read_trials(out / "trials.jsonl")) == 2

    def interrupt(trial: dict, n: int) -> None:
        raise KeyboardInterrupt

    with pytest.raises(RunInterrupted, match="3 of 6"):
        run_benchmark(
            out,
            method_specs(METHODS),
            "lip",
            TRIALS,
            FIRST,
            load_config(),
            progress=False,
            on_trial=interrupt,
        )
    # … then the full run: only the missing trials are run
    assert _bench(out) == 0
    assert _lines(out) == _lines(reference)
    assert len(read_trials(out / "trials.jsonl")) == 2 * TRIALS
    _same_tables(out, reference)


@pytest.mark.slow
def test_torn_last_line_is_dropped_and_redone(reference, tmp_path):
    out = tmp_path / "torn"
    shutil.copytree(reference, out)
    path = out / "trials.jsonl"
    data = path.read_bytes()
    path.write_bytes(data[:-25])  # a kill in the middle of writing the last line
    assert len(read_trials(path)) == 2 * TRIALS - 1
    assert _bench(out) == 0
    assert _lines(out) == _lines(reference)
    assert path.read_bytes().count(b"\n") == 2 * TRIALS  # the torn piece was cut, not kept
    # a damaged line before the last one is not guessed at: one-line error, exit 2
    lines = path.read_bytes().split(b"\n")
    lines[1] = lines[1][:40]
    path.write_bytes(b"\n".join(lines))
    with pytest.raises(BenchmarkSettingsError, match="line 2 is damaged"):
        read_trials(path)


@pytest.mark.slow
def test_other_settings_in_the_same_directory_are_refused(reference, tmp_path, capsys):
    out = tmp_path / "mixed"
    shutil.copytree(reference, out)
    before = (out / "trials.jsonl").read_bytes()
    cases = [
        (["--setting", "no_emotion"], "configuration (hash)"),
        (["--time-varying"], "time-varying emotions"),
        (["--planners", "dwa,mpc"], "planners are dwa,policy there, dwa,mpc here"),
        (["--first-seed", "0"], "first seed is 4 there, 0 here"),
        (["--trials", "2"], "--trials 2"),
    ]
    for extra, culprit in cases:
        assert _bench(out, *extra) == 2, extra
        err = capsys.readouterr().err
        assert err.startswith("emonav: error: ") and err.count("\n") == 1, err
        assert culprit in err, err
    assert "reward.neutral_discomfort: 0.35 there, 0.2 here" in _err_of(out, capsys)
    assert (out / "trials.jsonl").read_bytes() == before  # nothing touched
    # more trials on the same settings: allowed, only adds
    assert _bench(out, "--trials", str(TRIALS + 1), "--planners", "dwa,policy") == 0
    settings, trials = load_run(out)
    assert settings["trials"] == TRIALS + 1 and len(trials) == 2 * (TRIALS + 1)
    assert settings["extended"][0]["from"] == TRIALS


def _err_of(out: Path, capsys) -> str:
    assert _bench(out, "--setting", "no_emotion") == 2
    return capsys.readouterr().err


@pytest.mark.slow
def test_planner_reuse_gives_the_records_of_fresh_planners():
    """One runner (planners built once) over seeds in any order = a fresh planner per trial
    (the MPC keeps OSQP workspaces on itself; its memory lives in the Context)."""
    spec = BenchmarkSpec(
        [MethodSpec("mpc", "mpc"), MethodSpec("dwa", "dwa")], "lip", dump_config(load_config())
    )
    reused = TrialRunner(spec)
    a = [comparable(reused.run(m, s)) for s in (7, 2, 7) for m in ("mpc", "dwa")]
    b = [comparable(TrialRunner(spec).run(m, s)) for s in (7, 2, 7) for m in ("mpc", "dwa")]
    assert a == b and a[0] == a[4]


@pytest.mark.slow
def test_one_digit_trial(tmp_path):
    cfg = tmp_path / "short.yaml"
    cfg.write_text("episode: {max_steps: 3}\n")
    out = tmp_path / "digit"
    assert (
        main(
            [
                "benchmark",
                "--planners",
                "dwa",
                "--plant",
                "digit",
                "--trials",
                "1",
                "--workers",
                "1",
            ]
            + ["--quiet", "--config", str(cfg), "--out", str(out)]
        )
        == 0
    )
    settings, trials = load_run(out)
    assert settings["plant"] == "digit" and len(trials) == 1
    assert trials[0]["record"]["outcome"] in ("timeout", "fall") and trials[0]["plant"] == "digit"
    assert "fall rate" in (out / "tables.md").read_text()


def test_named_settings_and_config_show(capsys):
    for name in SETTINGS:
        cfg = load_config(setting_path(name))
        assert cfg == load_setting(name)
    assert load_setting("no_emotion").reward.emotion_distances() == (0.2, 0.2, 0.2)
    assert load_setting("constant_0.5").reward.emotion_distances() == (0.5, 0.5, 0.5)
    assert load_setting("var_dd") == load_config()
    tv = load_setting("time_varying")
    assert tv.crowd.time_varying_emotions and tv.reward.emotion_distances() == (0.2, 0.35, 0.5)
    assert main(["config", "--show", "--setting", "no_emotion"]) == 0
    text = capsys.readouterr().out
    assert "neutral_discomfort: 0.2  #" in text
    assert load_config(data=text) == load_setting("no_emotion")
    assert main(["config"]) == 0  # the defaults: --dump is the default action
    assert load_config(data=capsys.readouterr().out) == load_config()
    assert main(["config", "--dump", "--setting", "constant_0.5"]) == 0
    assert load_config(data=capsys.readouterr().out) == load_setting("constant_0.5")
    assert main(["config", "--list"]) == 0
    listing = capsys.readouterr().out
    for name in (*SETTINGS, "head_on", "crossing", "mood_swing"):
        assert f"  {name} " in listing, name


def test_bad_flags_fail_before_any_trial(tmp_path, capsys):
    out = tmp_path / "bad"
    for extra, culprit in [
        (["--planners", "dwa,foo"], "unknown method 'foo'"),
        (["--planners", "dwa,dwa"], "dwa is listed twice"),
        (["--checkpoint", "dwa=x.pt"], "only learned policies"),
        (["--checkpoint", "policy=missing.pt"], "no such file"),
        (["--trials", "0"], "--trials 0"),
        (["--workers", "0"], "--workers 0"),
    ]:
        args = ["benchmark", "--planners", "dwa,policy", "--quiet", "--out", str(out), *extra]
        assert main(args) == 2, extra
        err = capsys.readouterr().err
        assert culprit in err and err.count("\n") == 1, err
    assert not (out / "trials.jsonl").exists()


def test_a_second_benchmark_into_a_running_directory_is_refused(tmp_path):
    from emonav_drake.evaluation.run_directory import RunDirectory

    with RunDirectory(tmp_path / "busy").locked():
        with pytest.raises(BenchmarkSettingsError, match="another emonav benchmark is running"):
            with RunDirectory(tmp_path / "busy").locked():
                pass
    with RunDirectory(tmp_path / "busy").locked():  # free again
        pass
    assert list((tmp_path / "busy").iterdir()) == []  # no lock file left behind
