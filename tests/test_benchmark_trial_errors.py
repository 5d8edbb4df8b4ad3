"""A trial that raises does not end `emonav benchmark` (issue 46, item 4).

Real components: a planner module of the user's own written to a temporary directory,
which misbehaves on the scene of one seed only (it recognises the scene by its
pedestrians' start positions at step 0), and the real benchmark through
`emonav_drake.cli.main` on the LIP plant, a few short trials, serially and on two Ray
workers. The failed trial goes to `errors.jsonl` beside the run with its traceback, in no
table; the other trials go on; the run ends with exit code 1 and one line naming the
failed trials and the command that replays one; the same command again retries it. And
the probe's sub-items: a planner that answers no (speed, turn) pair, one whose `build`
raises, one that hangs (the decision watchdog), and a `trials.jsonl` whose complete last
line is damaged.
"""

from __future__ import annotations

import json
import shlex
import threading
import time
from pathlib import Path

import pytest

from emonav_drake.cli import main
from emonav_drake.errors import RunInterrupted
from emonav_drake.evaluation.benchmark import run_benchmark
from emonav_drake.evaluation.run_directory import comparable, read_trials
from emonav_drake.evaluation.run_settings import BenchmarkSettingsError
from emonav_drake.params import EmoNavConfig, load_config
from emonav_drake.planners import unregister
from emonav_drake.scenarios.scenario import sample_scenario

FIRST, TRIALS = 4, 3  # seeds 4, 5, 6
BAD = 5  # the seed whose scene the plug-in misbehaves on

PLUGIN = '''\
"""A planner of the user's own: heads for the goal; misbehaves on the scenes in WHEN."""

import os
from dataclasses import dataclass

import numpy as np

from emonav_drake.planners import PlannerKind, register

WHEN = {when!r}  # [pedestrians' start positions (rounded), what to do there]
FLAG = {flag!r}  # misbehave only while this file exists (None: always)
BUILD = {build!r}  # "raise": its build raises


def _misdeed(obs):
    if obs.step != 0 or (FLAG is not None and not os.path.exists(FLAG)):
        return None
    here = [round(float(v), 6) for v in np.asarray(obs.crowd.positions).ravel()]
    return next((what for starts, what in WHEN if starts == here), None)


class Flaky:
    name = "flaky"

    def __init__(self, config):
        self.max_speed = config.robot.max_speed
        self.max_turn = config.robot.max_heading_change

    def initial_memory(self):
        return None

    def plan_with_memory(self, obs, memory):
        what = _misdeed(obs)
        if what == "raise":
            raise RuntimeError("boom on purpose")
        if what == "interrupt":
            raise KeyboardInterrupt
        if what == "hang":
            while True:
                pass
        if what == "bare":  # a string, not a (command, memory) pair
            return "abc"
        if what is not None:  # a command, as Python source
            return eval(what), memory
        _, bearing = obs.goal_state()
        turn = float(np.clip(bearing, -self.max_turn, self.max_turn))
        return np.array([self.max_speed, turn]), memory

    def reset(self):
        pass

    def plan(self, obs):
        return self.plan_with_memory(obs, None)[0]


@dataclass
class FlakySpec:
    def build(self, config, device="cpu"):
        if BUILD == "raise":
            raise ValueError("no such setting")
        return Flaky(config)


register(PlannerKind("flaky", FlakySpec(), "misbehaves on one scene"), replace=True)
'''


@pytest.fixture(autouse=True)
def _forget_flaky():
    """Each test registers its own `flaky` (its own file); none outlives the test."""
    yield
    unregister("flaky")


@pytest.fixture()
def short(tmp_path: Path) -> Path:
    path = tmp_path / "short.yaml"
    path.write_text("episode: {max_steps: 6}\n")
    return path


def _starts(seed: int, config: Path) -> list[float]:
    scene = sample_scenario(seed, load_config(config))
    return [round(float(v), 6) for p in scene.pedestrians for v in p.start]


def _plugin(tmp_path: Path, config: Path, when: dict[int, str], **kw: object) -> Path:
    """The plug-in file: `when` = {seed: "raise" | "interrupt" | "hang" | an answer to
    return, as Python source}; `flag`: a file that must exist for it to misbehave;
    `build="raise"`: its build raises."""
    path = tmp_path / "flaky.py"
    rules = [[_starts(seed, config), what] for seed, what in when.items()]
    path.write_text(PLUGIN.format(when=rules, flag=kw.get("flag"), build=kw.get("build")))
    return path


def _bench(plugin: Path, config: Path, out: Path, workers: int = 1, *extra: str) -> int:
    argv = ["benchmark", "--planner-module", str(plugin), "--planners", "flaky,dwa"]
    argv += ["--trials", str(TRIALS), "--first-seed", str(FIRST), "--config", str(config)]
    return main([*argv, "--workers", str(workers), "--out", str(out), "-q", *extra])


def _errors(out: Path) -> list[dict]:
    return [json.loads(line) for line in (out / "errors.jsonl").read_text().splitlines()]


def _records(out: Path) -> dict[tuple[str, int], dict]:
    return {(t["method"], t["seed"]): comparable(t) for t in read_trials(out / "trials.jsonl")}


# --------------------------------------------------------- a trial that raises, the others go on


@pytest.mark.slow
def test_a_trial_that_raises_is_recorded_beside_the_run_serially_and_on_ray(
    tmp_path: Path, short: Path, capsys: pytest.CaptureFixture
) -> None:
    """Serially and on 2 Ray workers: flaky seed 5 raises; its error (type, message,
    traceback) is the one line of errors.jsonl, not in trials.jsonl nor the tables; the
    five other trials ran, the same on both engines; exit code 1 with one line naming
    the trial and the `emonav sim` command, which replays the error."""
    plugin = _plugin(tmp_path, short, {BAD: "raise"})
    runs = {}
    for workers in (1, 2):
        out = tmp_path / f"w{workers}"
        assert _bench(plugin, short, out, workers) == 1
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1, err
        line = err[0]
        assert line.startswith("emonav: error: 1 trial raised an error and is in no table: ")
        first = f"flaky seed {BAD} (first: PluginError: planner 'flaky' raised RuntimeError: "
        assert first + f"boom on purpose (module {plugin}))" in line
        assert f"errors and tracebacks in {out / 'errors.jsonl'}" in line
        assert "run the same command again to retry it" in line
        (error,) = _errors(out)
        assert (error["method"], error["seed"], error["plant"]) == ("flaky", BAD, "lip")
        assert error["error"]["type"] == "PluginError"  # the plug-in's fault, named
        assert error["error"]["message"] == (
            f"planner 'flaky' raised RuntimeError: boom on purpose (module {plugin})"
        )
        assert "plan_with_memory" in error["error"]["traceback"]
        assert "RuntimeError: boom on purpose" in error["error"]["traceback"]
        runs[workers] = _records(out)
        assert set(runs[workers]) == {
            (m, s) for m in ("flaky", "dwa") for s in range(FIRST, FIRST + TRIALS)
        } - {("flaky", BAD)}
        tables = (out / "tables.md").read_text()
        assert "1 trial raised an error, in no table (errors.jsonl)" in tables
        assert "| flaky | 0." in tables or "| flaky | 1." in tables  # its two other trials
        replay = line.split("replay flaky seed 5 with: ")[1].split("; run the same")[0]
        assert replay.startswith(f"emonav sim --planner-module {plugin} --planner flaky ")
        assert f"--seed {BAD}" in replay and f"--config {short}" in replay
    assert runs[1] == runs[2]  # Ray = serial, record for record
    assert main(shlex.split(replay)[1:]) == 2  # the replay raises the very error: the user's
    assert "RuntimeError: boom on purpose" in capsys.readouterr().err


@pytest.mark.slow
def test_the_same_command_again_retries_the_failed_trial(
    tmp_path: Path, short: Path, capsys: pytest.CaptureFixture
) -> None:
    """The plug-in raises while a flag file exists: the first run records the error; run
    again, the trial is retried (and fails again: still one line); with the cause gone
    the same command runs that trial only, exits 0, and errors.jsonl is gone; the run
    equals one that never failed."""
    flag = tmp_path / "fail-now"
    flag.touch()
    plugin = _plugin(tmp_path, short, {BAD: "raise"}, flag=str(flag))
    out = tmp_path / "run"
    for _ in range(2):
        assert _bench(plugin, short, out) == 1
        assert [(e["method"], e["seed"]) for e in _errors(out)] == [("flaky", BAD)]
        assert len(read_trials(out / "trials.jsonl")) == 2 * TRIALS - 1
    capsys.readouterr()
    flag.unlink()
    assert _bench(plugin, short, out) == 0
    assert "1 trials run in" in capsys.readouterr().out  # only the missing one
    assert not (out / "errors.jsonl").exists()
    clean = tmp_path / "clean"
    assert _bench(plugin, short, clean) == 0
    assert _records(out) == _records(clean)
    assert "raised an error" not in (out / "tables.md").read_text()


def test_ctrl_c_still_stops_the_run_after_a_failed_trial(tmp_path: Path, short: Path) -> None:
    """Seed 5 raises (recorded, the run goes on), seed 6 is a Ctrl-C in the planner: the
    run stops there (RunInterrupted), seed 5's error is kept beside the run."""
    plugin = _plugin(tmp_path, short, {BAD: "raise", BAD + 1: "interrupt"})
    out = tmp_path / "run"
    assert _bench(plugin, short, out) == 130
    assert [(e["method"], e["seed"]) for e in _errors(out)] == [("flaky", BAD)]
    done = {(t["method"], t["seed"]) for t in read_trials(out / "trials.jsonl")}
    assert ("flaky", BAD + 1) not in done and ("dwa", BAD + 1) not in done


@pytest.mark.slow
def test_run_benchmark_raises_trials_failed_with_the_result(tmp_path: Path, short: Path) -> None:
    """The library call: `TrialsFailed` at the end, its `result` the finished trials."""
    from emonav_drake.diagrams.trials import method_specs
    from emonav_drake.evaluation.benchmark import TrialsFailed
    from emonav_drake.planners.plugins import import_planner_module

    plugin = import_planner_module(str(_plugin(tmp_path, short, {BAD: "raise"})))
    with pytest.raises(TrialsFailed, match=f"flaky seed {BAD}") as caught:
        run_benchmark(
            tmp_path / "run",
            method_specs("flaky"),
            "lip",
            TRIALS,
            FIRST,
            load_config(short),
            progress=False,
            planner_modules=[plugin],
        )
    result = caught.value.result
    assert [t["seed"] for t in result.trials] == [FIRST, FIRST + 2]
    assert [(t["method"], t["seed"]) for t in caught.value.failed] == [("flaky", BAD)]
    assert not issubclass(TrialsFailed, RunInterrupted)


# ------------------------------------------------------------- a planner's answer, build, hang


@pytest.mark.parametrize(
    ("answer", "message"),
    [
        ("bare", "planner 'flaky' returned 'abc' from plan_with_memory, not a (command, memory)"),
        ("'abc'", "planner 'flaky' returned 'abc', not a (speed, turn) pair of numbers"),
        ("[0.1, 0.0, 0.2]", "planner 'flaky' returned [0.1, 0.0, 0.2], not a (speed, turn)"),
        ("[float('nan'), 0.0]", "planner 'flaky' returned [nan, 0.0]: a command that is not"),
    ],
)
def test_an_answer_that_is_no_speed_turn_pair_names_the_planner(
    tmp_path: Path, short: Path, capsys: pytest.CaptureFixture, answer: str, message: str
) -> None:
    """`emonav sim` with a planner answering a bare string, a string command, three
    numbers, NaN: the error names the planner and what it returned (before: "too many
    values to unpack", "could not convert string to float", a CommandError naming no
    planner)."""
    plugin = _plugin(tmp_path, short, {BAD: answer})
    argv = ["sim", "--planner-module", str(plugin), "--planner", "flaky", "--seed", str(BAD)]
    assert main([*argv, "--config", str(short), "-q"]) == 2  # the plug-in's fault
    err = capsys.readouterr().err
    assert err.startswith("emonav: error: ") and message in err and str(plugin) in err


@pytest.mark.slow
def test_a_benchmark_trial_answering_a_string_is_an_error_naming_the_planner(
    tmp_path: Path, short: Path
) -> None:
    plugin = _plugin(tmp_path, short, {BAD: "'abc'"})
    out = tmp_path / "run"
    assert _bench(plugin, short, out) == 1
    (error,) = _errors(out)
    assert error["error"]["type"] == "PluginError"
    assert error["error"]["message"] == (
        f"planner 'flaky' returned 'abc', not a (speed, turn) pair of numbers (module {plugin})"
    )


def test_a_plug_in_whose_build_raises_is_named_with_its_module(
    tmp_path: Path, short: Path, capsys: pytest.CaptureFixture
) -> None:
    """Its build raises: a user error (exit 2) naming the planner, its file and the error —
    not "internal error … a bug" — from `sim` and from `benchmark` (nothing run)."""
    plugin = _plugin(tmp_path, short, {}, build="raise")
    want = f"emonav: error: planner 'flaky' (module {plugin}) failed to build: ValueError: "
    want += "no such setting"
    argv = ["sim", "--planner-module", str(plugin), "--planner", "flaky", "--seed", "1"]
    assert main([*argv, "-q"]) == 2
    assert capsys.readouterr().err.strip() == want
    out = tmp_path / "run"
    assert _bench(plugin, short, out) == 2
    assert capsys.readouterr().err.strip() == want
    assert not (out / "trials.jsonl").exists()


def test_the_build_error_is_a_config_error() -> None:
    from emonav_drake.planners.registry import PlannerBuildError
    from emonav_drake.typed_yaml import ConfigError

    assert issubclass(PlannerBuildError, ConfigError)


@pytest.mark.slow
@pytest.mark.parametrize("workers", [1, 2])
def test_a_planner_that_hangs_is_stopped_by_the_decision_watchdog(
    tmp_path: Path, workers: int, capsys: pytest.CaptureFixture
) -> None:
    """Seed 5's decision never returns (a busy loop): after `episode.decision_timeout`
    (1 s here) the trial is an error naming the planner (PlannerTimeout), serially and in
    a Ray worker; the other trials finish; exit code 1."""
    config = tmp_path / "short.yaml"
    config.write_text("episode: {max_steps: 6, decision_timeout: 1.0}\n")
    plugin = _plugin(tmp_path, config, {BAD: "hang"})
    out = tmp_path / "run"
    t0 = time.perf_counter()
    assert _bench(plugin, config, out, workers) == 1
    assert time.perf_counter() - t0 < 120
    (error,) = _errors(out)
    assert (error["method"], error["seed"]) == ("flaky", BAD)
    assert error["error"]["type"] == "PluginError"
    assert error["error"]["message"].startswith(
        "planner 'flaky' made no decision at t = 0.00 s within 1 s of wall time "
        "(episode.decision_timeout)"
    )
    assert len(read_trials(out / "trials.jsonl")) == 2 * TRIALS - 1
    assert "made no decision" in capsys.readouterr().err


def test_the_watchdog_changes_no_finished_result(tmp_path: Path) -> None:
    """A generous default (60 s), configurable; the same trial with the watchdog off
    (0) and on gives the same record."""
    from emonav_drake.diagrams.trials import BenchmarkSpec, TrialRunner, method_specs
    from emonav_drake.params import dump_config

    assert EmoNavConfig().episode.decision_timeout == 60.0
    records = []
    for limit in (0.0, 60.0):
        cfg = EmoNavConfig()
        cfg.episode.max_steps = 8
        cfg.episode.decision_timeout = limit
        runner = TrialRunner(BenchmarkSpec(method_specs("dwa"), "lip", dump_config(cfg)))
        records.append(runner.run("dwa", 3)["record"])
    assert records[0] == records[1]


@pytest.mark.slow
def test_the_watchdog_raises_again_in_a_body_that_swallows_it() -> None:
    """A body that catches the first error is interrupted again a second later; a body
    that returns in time is untouched; off the main thread there is no watchdog."""
    from emonav_drake.watchdog import wall_clock_limit

    caught = []
    with pytest.raises(TimeoutError), wall_clock_limit(0.2, lambda: TimeoutError("late")):
        while True:
            try:
                while True:
                    pass
            except TimeoutError:
                caught.append(1)
                if len(caught) == 2:
                    raise
    assert len(caught) == 2
    with wall_clock_limit(5.0, lambda: TimeoutError("late")) as on:
        assert on
    time.sleep(0.01)  # no stray alarm after the body
    seen = []

    def in_thread() -> None:
        with wall_clock_limit(1.0, lambda: TimeoutError("late")) as on:
            seen.append(on)

    thread = threading.Thread(target=in_thread)
    thread.start()
    thread.join()
    assert seen == [False]


# ------------------------------------------------------------------- trials.jsonl's last line


@pytest.mark.slow
def test_a_complete_damaged_last_line_is_refused_not_dropped(
    tmp_path: Path, short: Path, capsys: pytest.CaptureFixture
) -> None:
    """trials.jsonl's last line ends in its newline but is not JSON: not an interrupted
    append (that has no newline), so it is refused naming the file and the line — it was
    dropped with a warning before; a last line without its newline is still dropped."""
    out = tmp_path / "run"
    argv = ["benchmark", "--planners", "dwa", "--trials", "2", "--first-seed", "4"]
    argv += ["--config", str(short), "--workers", "1", "--out", str(out), "-q"]
    assert main(argv) == 0
    path = out / "trials.jsonl"
    good = path.read_bytes()
    path.write_bytes(good + b'{"method": "dwa", "seed": 6, "rec\n')
    with pytest.raises(BenchmarkSettingsError, match=r"trials.jsonl: line 3 is damaged"):
        read_trials(path)
    capsys.readouterr()
    assert main([*argv[:4], "3", *argv[5:]]) == 2
    err = capsys.readouterr().err
    assert f"{path}: line 3 is damaged" in err
    assert path.read_bytes() == good + b'{"method": "dwa", "seed": 6, "rec\n'  # untouched
    path.write_bytes(good + b'{"method": "dwa", "seed": 6, "rec')  # torn: dropped
    assert len(read_trials(path)) == 2
