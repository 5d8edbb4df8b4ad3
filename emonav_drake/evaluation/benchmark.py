"""Benchmarks: many methods × many seeded trials, resumable, serial or on Ray.

A *run directory* holds one benchmark:

* `settings.json` — what the run is (methods and their planners, plant, number of trials,
  first seed, the full resolved configuration as YAML and its hash, time-varying emotions,
  emotion estimate, checkpoint hashes, package version, git commit and a hash of the
  package's code). A later run into the same directory must have the same settings — it
  then only adds the trials that are missing — or is refused with one line naming the
  difference (`BenchmarkSettingsError`, exit 2). Raising the number of trials is allowed.
  The code is compared by its hash (an uncommitted edit of a planner counts, a commit of
  docs does not); the commit is kept for the record.
* `trials.jsonl` — one JSON line per finished trial, appended as it finishes
  (`method`, `seed`, `plant`, `record` = `EpisodeRecord.to_json()`, `wall_seconds`), each
  line written with one `write` + fsync. A kill can leave at most a torn last line;
  it is detected and dropped (and its trial redone) when the directory is opened again.
  Every other line is checked when read (`check_trial`: a known outcome, counts and
  lengths >= 0, …); a bad one is an error naming the file and line, never a table entry.
* `tables.md` and `table2.csv`, `table3.csv`, `social.csv`, `pairwise.csv` — the tables of
  `evaluation.tables`, written at the end and on an interruption, from the sorted trials.
* `errors.jsonl` — the trials that raised instead of finishing (a bug, or a planner of the
  user's own that raises, returns no command or hangs past `episode.decision_timeout`):
  one JSON line each with the method, seed, plant and the error's type, message and
  traceback (`diagrams.trials.trial_error`). Such a trial is in no table and not in
  `trials.jsonl`; the other trials go on, and the run ends with `TrialsFailed` naming
  the failed trials and the `emonav sim` command that replays one (`emonav benchmark`:
  one line `emonav: error: …`, exit code 1). Running the same command again runs them
  again (they are missing); a line goes once its trial finishes. Ctrl-C and SIGTERM
  still stop the run at once (`RunInterrupted`), and a Ray worker that dies still
  counts as lost (`parallel.run_tasks`), not as a trial's error.

A failed append (a full disk) cuts `trials.jsonl` back to its finished trials and is the
error reported (the tables written after it may fail on the same disk: that is logged,
not raised). A run that fails before its first trial leaves nothing it made: a
`--ray-address` is checked (`parallel.check_ray_address`: does a Ray cluster answer
there?) before any file is written, and a new run directory that holds no trial is
removed again (its `settings.json`, and the folders this call created).

The files of a run directory must be regular files: a symbolic link (or a `trials.jsonl`
with another hard link) is refused when the directory is opened, since a write would go
into the file it points to.

Trial i of every method runs the scenario of seed `first_seed + i` with the evaluation goal
radius (`episode.eval_goal_radius`, as `emonav eval`).

Engines. `workers=1` (and no Ray address) runs the trials serially in this process. Else
Ray runs them: one actor per worker (`num_cpus=1`), each holding a `TrialRunner` that
builds every method's planner once and reuses it for all its trials, one trial per task
(two in flight per actor to hide the round trip). Reuse is safe because a planner's memory
lives in the diagram's Context (`initial_memory()` / `plan_with_memory()`): every episode
builds a new diagram whose planner memory starts from `initial_memory()`; what a planner
keeps on itself (the MPC's OSQP workspaces, the policy's network) is a cache that does
not change a command, bit for bit (`docs/mpc.md`; tested here by running seeds in
different orders and on fresh planners). Torch runs one thread per process in both engines
(`torch.set_num_threads(1)`), so a Ray run gives record for record the same
`trials.jsonl` lines as a serial one (order and wall times aside).
"""

from __future__ import annotations

import contextlib
import dataclasses as dc
import logging
import os
import shlex
import time
from collections.abc import Callable, Sequence
from pathlib import Path

from emonav_drake.atomic_io import (
    check_output_dir,
)
from emonav_drake.diagrams.plants import plant_named
from emonav_drake.diagrams.trials import (
    MAX_TRIALS,
    BenchmarkSpec,
    BenchmarkTrialWorker,
    MethodSpec,
    TrialRunner,
    run_serial,
    run_trials,
)
from emonav_drake.errors import RunInterrupted
from emonav_drake.evaluation.run_directory import ERRORS_FILE, RunDirectory, trial_key
from emonav_drake.evaluation.run_settings import make_settings
from emonav_drake.params import ConfigError, EmoNavConfig, dump_config, load_config
from emonav_drake.scenarios.scenario import MAX_SEED

log = logging.getLogger(__name__)


# --------------------------------------------------------------------------- engine
@dc.dataclass
class BenchmarkResult:
    path: Path
    settings: dict
    trials: list[dict]  # all finished trials of the directory, sorted
    ran: int  # trials run by this call
    wall_seconds: float
    failed: list[dict] = dc.field(default_factory=list)  # this call's trials that raised


class TrialsFailed(Exception):
    """Trials of a benchmark raised an error instead of finishing; the others ran.

    The message is one line: the failed trials (method and seeds), the first error, where
    the errors and tracebacks are (`errors.jsonl`) and the `emonav sim` command that
    replays one. `result` is the run's `BenchmarkResult` (its finished trials, tables
    written), `failed` the error lines (`diagrams.trials.trial_error`).
    """

    def __init__(self, message: str, result: BenchmarkResult) -> None:
        super().__init__(message)
        self.result = result
        self.failed = result.failed


class _Progress:
    """tqdm bar with the running SR per method, labelled "starting workers" until the first
    trial of this run is in (Ray takes ~10 s to start), then "benchmark"."""

    def __init__(self, total: int, done: list[dict], methods: Sequence[str], enabled: bool):
        from emonav_drake.progress import progress_bar

        self.methods = list(methods)
        self.k = {m: 0 for m in methods}
        self.n = {m: 0 for m in methods}
        self.errors = 0
        for t in done:
            self._count(t)
        self.bar = progress_bar(
            total=total, initial=len(done), unit="trial", enabled=enabled, desc="starting workers"
        )
        self._started = False
        self._postfix()

    def _count(self, t: dict) -> None:
        self.n[t["method"]] += 1
        self.k[t["method"]] += t["record"]["outcome"] == "success"

    def _postfix(self) -> None:
        parts = [
            f"{m} SR {self.k[m] / self.n[m]:.3f} ({self.n[m]})" if self.n[m] else f"{m} -"
            for m in self.methods
        ]
        if self.errors:
            parts.append(f"{self.errors} raised")
        self.bar.set_postfix_str(" | ".join(parts), refresh=False)

    def update(self, t: dict) -> None:
        if not self._started:
            self.bar.set_description_str("benchmark", refresh=False)
            self._started = True
        self._count(t)
        self._postfix()
        self.bar.update(1)

    def failed(self) -> None:
        """A trial that raised: counted apart, in no success rate."""
        self.errors += 1
        self._postfix()
        self.bar.update(1)

    def close(self) -> None:
        self.bar.close()


def run_benchmark(
    out: str | Path,
    methods: Sequence[MethodSpec],
    plant: str,
    trials: int,
    first_seed: int,
    config: EmoNavConfig,
    workers: int | None = 1,
    ray_address: str | None = None,
    setting: str | None = None,
    config_source: str = "defaults",
    emotion_estimate_yaml: str | None = None,
    progress: bool = True,
    on_trial: Callable[[dict, int], None] | None = None,
    planner_modules: Sequence[str] = (),
) -> BenchmarkResult:
    """Run (or continue) the benchmark in the run directory `out`; see the module.

    Args:
        workers: 1 (and no `ray_address`): serial in this process; > 1: a local Ray with
            that many workers; None with `ray_address`: one worker per CPU of the cluster.
        on_trial: called with every new trial line and the number written by this call,
            after it is on disk (tests raise `KeyboardInterrupt` from it to simulate Ctrl-C).
        planner_modules: planner modules from outside the package, as recorded by
            `planners.plugins.import_planner_module` (a .py path or a module name): recorded
            in the settings and imported by every worker.
    Raises:
        BenchmarkSettingsError: `out` holds another benchmark.
        RunInterrupted: after Ctrl-C / SIGTERM: the finished trials are kept and the
            tables of them written; running the same call again continues.
        TrialsFailed: at the end, if trials raised an error (in `errors.jsonl`, not in
            the tables); every other trial ran, and its `result` is the run's.
    """
    workers = _check_run_args(
        plant, trials, first_seed, workers, ray_address, emotion_estimate_yaml
    )
    out = check_output_dir(out, "--out")
    if ray_address:  # a cluster that is not there fails now, before any work or file
        from emonav_drake.parallel import check_ray_address

        check_ray_address(ray_address)
    # the same YAML text drives every engine (the driver's and the workers' configs are equal)
    config = load_config(data=dump_config(config))
    _check_scenarios(config, first_seed, trials, config_source)
    spec = _probed_spec(methods, plant, config, emotion_estimate_yaml, list(planner_modules))
    settings = make_settings(
        spec.methods,
        plant,
        trials,
        first_seed,
        config,
        setting,
        config_source,
        emotion_estimate_yaml,
        spec.planner_modules,
    )
    made = _missing_folders(out)
    rd = RunDirectory(out)
    t0 = time.perf_counter()
    new_run = False
    try:
        with rd.locked():
            new_run = not rd.settings_path.exists()
            settings, done = rd.open(settings)
            # the directory's method order; this call's checkpoint paths (same hashes)
            given = {m.name: m for m in spec.methods}
            spec.methods = [given[n] for n in settings["planners"]]
            engine = (workers, ray_address)
            all_trials, new, failed = _run_missing(
                rd, spec, settings, done, engine, progress, on_trial
            )
    except (KeyboardInterrupt, RunInterrupted):
        raise  # the settings stay: "run the same command again to start"
    except BaseException:
        _remove_empty_start(rd, new_run, made)
        raise
    rank = {m: i for i, m in enumerate(settings["planners"])}
    all_trials.sort(key=lambda t: (rank[t["method"]], t["seed"]))
    failed.sort(key=lambda t: (rank[t["method"]], t["seed"]))
    wall = time.perf_counter() - t0
    result = BenchmarkResult(out, settings, all_trials, len(new), wall, failed)
    if failed:  # the settings and errors.jsonl stay: the same command runs them again
        raise TrialsFailed(_failure_message(rd, settings, failed), result)
    return result


SHOWN_SEEDS = 10  # failed seeds named per method in `TrialsFailed`'s line


def _failure_message(rd: RunDirectory, settings: dict, failed: list[dict]) -> str:
    """`TrialsFailed`'s line: the failed trials by method, the first error, where the
    errors are, the command that replays the first one, and how to retry them."""
    by_method: dict[str, list[int]] = {}
    for t in failed:
        by_method.setdefault(t["method"], []).append(int(t["seed"]))
    which = "; ".join(
        f"{m} seed{'s' if len(seeds) > 1 else ''} {', '.join(map(str, seeds[:SHOWN_SEEDS]))}"
        + (f", … ({len(seeds)} in all)" if len(seeds) > SHOWN_SEEDS else "")
        for m, seeds in by_method.items()
    )
    first = failed[0]
    error = f"{first['error']['type']}: {first['error']['message']}".splitlines()[0]
    if len(error) > 200:
        error = error[:199] + "…"
    n = len(failed)
    replay = replay_command(rd, settings, first["method"], int(first["seed"]))
    return (
        f"{n} trial{'s' if n > 1 else ''} raised an error and {'are' if n > 1 else 'is'} in "
        f"no table: {which} (first: {error}); errors and tracebacks in "
        f"{rd.path / ERRORS_FILE}; replay {first['method']} seed {first['seed']} with: "
        f"{replay}; run the same command again to retry {'them' if n > 1 else 'it'}"
    )


def replay_command(rd: RunDirectory, settings: dict, method: str, seed: int) -> str:
    """The `emonav sim` command that plays trial (`method`, `seed`) of the run in `rd`
    again (`evaluation.failures.rerun_command`, with the run's `--planner-module`s; the
    run's configuration and emotion estimate written into `rd` as YAML when its flags no
    longer give them)."""
    from emonav_drake.evaluation.failures import config_flags, rerun_command, write_run_files

    files = None
    if config_flags(settings) is None or settings.get("emotion_estimate_yaml") is not None:
        files = write_run_files(settings, rd.path)
    argv = shlex.split(rerun_command(settings, method, seed, files))
    modules = settings.get("planner_modules") or []
    argv[2:2] = [word for m in modules for word in ("--planner-module", m)]
    return shlex.join(argv)


def _missing_folders(out: Path) -> list[Path]:
    """The folders of `out` (itself included) that do not exist yet, innermost first."""
    missing = []
    p = out.absolute()
    while not p.exists():
        missing.append(p)
        p = p.parent
    return missing


def _remove_empty_start(rd: RunDirectory, new_run: bool, made: list[Path]) -> None:
    """After a failure: if this call started the run (`new_run`) and no trial was written,
    remove its `settings.json` (and an empty `trials.jsonl`); then the folders of `made`
    (this call created them) that are empty. Nothing else is touched."""
    trials = rd.trials_path
    if new_run and not (trials.exists() and trials.stat().st_size):
        with contextlib.suppress(OSError):
            trials.unlink(missing_ok=True)
            rd.settings_path.unlink(missing_ok=True)
    for folder in made:  # innermost first: a folder emptied by the one before
        with contextlib.suppress(OSError):
            folder.rmdir()  # only an empty one


def _check_run_args(
    plant: str,
    trials: int,
    first_seed: int,
    workers: int | None,
    ray_address: str | None,
    emotion_estimate_yaml: str | None,
) -> int | None:
    """The plant and the run's numbers checked (`ConfigError`); the number of workers to use."""
    plant_named(plant)  # an unknown plant is refused here
    if not 1 <= trials <= MAX_TRIALS:
        raise ConfigError(
            f"--trials {trials}: must be in [1, {MAX_TRIALS}] (trials per method; every "
            "scenario is sampled before the first trial)"
        )
    if first_seed < 0:
        raise ConfigError(f"--first-seed {first_seed}: must be >= 0")
    if first_seed + trials - 1 > MAX_SEED:
        raise ConfigError(
            f"--first-seed {first_seed}: with --trials {trials} the last seed, "
            f"{first_seed + trials - 1}, is beyond 64 bits (2**64 - 1)"
        )
    if workers is not None and workers < 1:
        raise ConfigError(f"--workers {workers}: must be >= 1")
    if workers is None and not ray_address:
        workers = os.cpu_count() or 1
    return workers


def _probed_spec(
    methods: Sequence[MethodSpec],
    plant: str,
    config: EmoNavConfig,
    emotion_estimate_yaml: str | None,
    planner_modules: list[str],
) -> BenchmarkSpec:
    """The benchmark's spec, every method's observation filled in by building its planner."""
    spec = BenchmarkSpec(
        list(methods), plant, dump_config(config), emotion_estimate_yaml, planner_modules
    )
    probe = TrialRunner(spec)  # builds every planner now: a bad checkpoint fails before work
    for m in spec.methods:
        m.observation = probe.observation(m.name)
    del probe
    return spec


def _run_missing(
    rd: RunDirectory,
    spec: BenchmarkSpec,
    settings: dict,
    done: list[dict],
    engine: tuple[int | None, str | None],
    progress: bool,
    on_trial: Callable[[dict, int], None] | None,
) -> tuple[list[dict], list[dict], list[dict]]:
    """Run the trials of `settings` that `done` lacks on `engine` = (workers, Ray address),
    each appended to `rd` as it finishes (one that raised: recorded in `errors.jsonl`
    instead), then write the tables; the directory's trials (unsorted), this call's, and
    this call's error lines. On an interruption the tables of the finished trials are
    written first (Ctrl-C / SIGTERM: `RunInterrupted`; anything else is re-raised)."""
    workers, ray_address = engine
    have = {trial_key(t) for t in done}
    seeds = range(settings["first_seed"], settings["first_seed"] + settings["trials"])
    tasks = [(m, s) for s in seeds for m in settings["planners"] if (m, s) not in have]
    all_trials = list(done)
    new: list[dict] = []
    failed: list[dict] = []
    # errors.jsonl: the errors of earlier calls whose trials are still missing (they run
    # again now), then this call's, appended as they come; settled when the call ends
    errors = {k: e for k, e in rd.read_errors().items() if k not in have}
    bar = _Progress(len(done) + len(tasks), done, settings["planners"], progress)

    def on_result(t: dict) -> None:
        key = trial_key(t)
        if "error" in t:  # the trial raised: beside the run, in no table
            rd.append_error(t)
            errors.pop(key, None)
            errors[key] = t
            failed.append(t)
            bar.failed()
            return
        rd.append(t)
        errors.pop(key, None)  # it raised before, if it did; finished now
        all_trials.append(t)
        new.append(t)
        bar.update(t)
        if on_trial is not None:
            on_trial(t, len(new))

    try:
        if tasks:
            if workers == 1 and not ray_address:
                run_serial(spec, tasks, on_result, TrialRunner.try_run)
            else:
                worker = BenchmarkTrialWorker
                run_trials(spec, tasks, on_result, workers, ray_address, worker)
    except KeyboardInterrupt:
        bar.close()
        _settle_errors(rd, errors)
        md = _tables_after_a_stop(rd, settings, all_trials)
        total = len(seeds) * len(settings["planners"])
        raise _interruption(rd.path, md, len(new), len(all_trials), total) from None
    except BaseException:
        bar.close()
        _settle_errors(rd, errors)
        _tables_after_a_stop(rd, settings, all_trials)
        raise
    bar.close()
    rd.record_errors(errors)
    rd.write_tables(settings, all_trials, failed=len(failed))
    _write_figures(rd.path, settings, all_trials)
    return all_trials, new, failed


def _write_figures(path: Path, settings: dict, trials: list[dict]) -> None:
    """The run's figures beside its tables (`run_figures.write_run_figures`); a figure that
    cannot be drawn is a warning, never a lost run."""
    from emonav_drake.evaluation.run_figures import write_run_figures

    try:
        write_run_figures(path, settings, trials)
    except Exception as e:  # noqa: BLE001 — the trials and tables are already safe
        log.warning("the run's figures were not drawn: %s", e)


def _settle_errors(rd: RunDirectory, errors: dict[tuple[str, int], dict]) -> None:
    """After an interruption or an error: `errors.jsonl` rewritten to `errors` (the last
    error of each trial still missing) — logged, not raised, if it cannot be (what stopped
    the run is the error to report; the file's extra lines are dropped at the next open)."""
    try:
        rd.record_errors(errors)
    except OSError as e:
        log.warning("%s was not rewritten: %s", rd.errors_path, e)


def _tables_after_a_stop(rd: RunDirectory, settings: dict, trials: list[dict]) -> Path | None:
    """The tables of the finished trials after an interruption or an error (their
    `tables.md`), or None if they could not be written — logged, not raised: what stopped
    the run (a full disk while appending a trial) is the error to report, not its echo."""
    try:
        return rd.write_tables(settings, trials, interrupted=True)
    except Exception as e:  # noqa: BLE001 — the run's own error is raised by the caller
        log.warning("the tables of the finished trials were not written: %s", e)
        return None


def _interruption(
    out: Path, md: Path | None, new: int, finished: int, total: int
) -> RunInterrupted:
    """The `RunInterrupted` of a run into `out` stopped after `new` trials of this call,
    `finished` of the directory's `total`, with the tables of the finished ones in `md`
    (None: they could not be written)."""
    if not finished:
        return RunInterrupted(
            f"interrupted before the first trial finished; {out} holds the settings "
            "only; run the same command again to start"
        )
    tables = f"tables of the finished ones in {md}" if md else "their tables not written"
    return RunInterrupted(
        f"interrupted after {new} new trials ({finished} of {total} in "
        f"{out}); {tables}; run the same command again to continue"
    )


def _check_scenarios(config: EmoNavConfig, first_seed: int, trials: int, where: str) -> None:
    """Sample every scenario now (cheap): a crowd that does not fit fails before any trial."""
    from emonav_drake.scenarios.scenario import ScenarioSamplingError, sample_scenario

    for seed in range(first_seed, first_seed + trials):
        try:
            sample_scenario(seed, config)
        except ScenarioSamplingError as e:
            raise ScenarioSamplingError(f"{where}: {e}") from None
