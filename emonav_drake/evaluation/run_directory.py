"""A benchmark's run directory: `settings.json`, `trials.jsonl`, the tables.

`trials.jsonl` holds one JSON line per finished trial, appended as it finishes with one
`write` + fsync; a torn last line (a kill mid-write: the file does not end in a newline) is
dropped and its trial redone when the directory is opened again; any other damaged line —
a complete last line included — is an error naming the file and the line, and every line
is checked when read
(`trial_check.check_trial`: each record consistent in itself and with the run's
configuration — `nav_time` is `steps` × `robot.step_time`, a timeout ends at
`episode.max_steps`, …). An append that fails (a full disk) cuts the file back to its
previous length: the finished trials stay, no half line. `settings.json` is checked on
every read (`run_settings.check_settings`). The files must be regular files (a symbolic
link, or a `trials.jsonl` with another hard link, is refused). `RunDirectory` opens,
checks, appends and writes the tables; `load_run` reads a finished run. See
`evaluation/benchmark.py` for the run.

`errors.jsonl`, beside them, holds one JSON line per trial that raised instead of
finishing (`diagrams.trials.trial_error`: method, seed, plant, the error's type, message
and traceback): such a trial is not in `trials.jsonl` nor in the tables, and runs again
when the run is continued. Lines are appended as trials fail (a trial's later line
supersedes its earlier ones, `RunDirectory.read_errors`); when a run ends, the file is
rewritten (atomically) with the last line of each trial still missing, or removed when
none is (`RunDirectory.record_errors`).
"""

from __future__ import annotations

import contextlib
import json
import logging
import os
import re
from collections.abc import Iterable, Iterator, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from emonav_drake.atomic_io import (
    json_safe,
    naming_full_disk,
    write_json,
    write_text_atomic,
)
from emonav_drake.evaluation import tables
from emonav_drake.evaluation.run_settings import (
    BenchmarkSettingsError,
    check_settings,
    settings_difference,
)
from emonav_drake.evaluation.trial_check import check_trial
from emonav_drake.json_input import JsonInputError, parse_json, read_json
from emonav_drake.params import ConfigError, load_config
from emonav_drake.provenance import kernels_difference, kernels_words
from emonav_drake.run_lock import RunDirectoryBusy, locked_directory

log = logging.getLogger(__name__)

if TYPE_CHECKING:
    from emonav_drake.diagrams.trials import TrialRunner
    from emonav_drake.params import EmoNavConfig

SETTINGS_FILE = "settings.json"
TRIALS_FILE = "trials.jsonl"
ERRORS_FILE = "errors.jsonl"
TABLES_FILE = "tables.md"
TABLE_CSV_FILES = ("table2.csv", "table3.csv", "social.csv", "pairwise.csv")
RUN_FILES = (SETTINGS_FILE, TRIALS_FILE, ERRORS_FILE, TABLES_FILE, *TABLE_CSV_FILES)


def trial_key(t: dict) -> tuple[str, int]:
    return t["method"], int(t["seed"])


def comparable(t: dict) -> dict:
    """A trial line without its wall time (what must be equal between engines)."""
    return {k: v for k, v in t.items() if k != "wall_seconds"}


def _sorted_trials(trials: Iterable[dict], methods: Sequence[str]) -> list[dict]:
    """`trials` sorted by method (in the order of `methods`, any other last) and seed."""
    rank = {m: i for i, m in enumerate(methods)}
    return sorted(trials, key=lambda t: (rank.get(t["method"], len(rank)), t["seed"]))


def read_trials(path: Path, repair: bool = False, config: EmoNavConfig | None = None) -> list[dict]:
    """The trial lines of `trials.jsonl`, each checked (`check_trial`, against the run's
    `config` if given). A torn last line (a kill while writing: the file does not end in
    a newline) is dropped — and cut from the file with `repair`, so the next append
    starts on a fresh line. Any other damaged line (a complete last line included: an
    append writes the newline last, so a line that has it was written whole, and damaged
    since), or any line that is a trial's JSON with invalid values, is an error naming
    the file and the line."""
    if not path.exists():
        return []
    data = path.read_bytes()
    trials = []
    pos = 0
    number = 0
    while pos < len(data):
        number += 1
        nl = data.find(b"\n", pos)
        end = len(data) if nl < 0 else nl
        line = data[pos:end]
        t = None
        why = "not a trial's JSON"
        if nl >= 0 and line.strip():
            try:
                t = parse_json(line, f"line {number}")
            except JsonInputError as e:
                t, why = None, str(e).removeprefix(f"line {number}: ")
            if not (isinstance(t, dict) and {"method", "seed", "record"} <= set(t)):
                t = None
        elif nl >= 0:  # an empty line
            pos = nl + 1
            continue
        if t is None:
            if nl < 0:  # the last line, without its newline: an interrupted append
                log.warning("%s: dropping a torn last line (%d bytes)", path, len(line))
                break
            raise BenchmarkSettingsError(
                f"{path}: line {number} is damaged ({why}); fix or remove that line"
            )
        problem = check_trial(t, config)
        if problem is not None:
            raise BenchmarkSettingsError(
                f"{path}: line {number} is not a valid trial: {problem}; fix or remove that line"
            )
        trials.append(t)
        pos = nl + 1
    if repair and pos < len(data):
        fd = os.open(path, os.O_RDWR | os.O_NOFOLLOW)  # never cut the file a link points to
        with os.fdopen(fd, "r+b") as f:
            f.truncate(pos)
            f.flush()
            os.fsync(f.fileno())
    return trials


class RunDirectory:
    """A benchmark's run directory (see the module docstring): settings, trials, tables."""

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        self.settings_path = self.path / SETTINGS_FILE
        self.trials_path = self.path / TRIALS_FILE
        self.errors_path = self.path / ERRORS_FILE

    @contextlib.contextmanager
    def locked(self) -> Iterator[RunDirectory]:
        """Exclusive use of the directory (`run_lock.locked_directory`: a second benchmark,
        or a training run, into it is refused)."""
        with contextlib.ExitStack() as stack:
            try:
                stack.enter_context(locked_directory(self.path, "--out", "benchmark"))
            except RunDirectoryBusy as e:
                raise BenchmarkSettingsError(str(e)) from None
            yield self

    def check_regular_files(self) -> None:
        """`BenchmarkSettingsError` if a file of the run directory (`RUN_FILES`) is a
        symbolic link, or `trials.jsonl` has another hard link: writing it would change
        the other file."""
        for name in RUN_FILES:
            p = self.path / name
            if p.is_symlink():
                raise BenchmarkSettingsError(
                    f"--out {self.path}: {name} is a symbolic link (to {os.readlink(p)}); a run "
                    "directory's files must be regular files (a write would go into the file "
                    "it points to): replace it by a copy of that file, or use another --out"
                )
            if p.exists() and not p.is_file():
                raise BenchmarkSettingsError(
                    f"--out {self.path}: {name} exists and is not a regular file"
                )
        if self.trials_path.exists() and self.trials_path.stat().st_nlink > 1:
            raise BenchmarkSettingsError(
                f"--out {self.path}: {TRIALS_FILE} has {self.trials_path.stat().st_nlink} hard "
                "links: appending would change the file under its other names too; replace it "
                "by a copy, or use another --out"
            )

    def read_settings(self) -> tuple[dict, EmoNavConfig] | None:
        """(`settings.json`, the run's configuration) checked (`check_settings`); None if
        there is no `settings.json`."""
        if not self.settings_path.exists():
            return None
        settings = read_json(self.settings_path)
        return settings, check_settings(settings, str(self.settings_path))

    def open(self, settings: dict) -> tuple[dict, list[dict]]:
        """Check or create `settings.json`; the valid trials already done (torn line cut).

        Returns the directory's settings (its planners' order and first creation kept; the
        number of trials raised to `settings["trials"]`) and the finished trials. A file
        that is a link is refused first (`check_regular_files`).
        """
        self.check_regular_files()
        found = self.read_settings()
        if found is None:
            if self.trials_path.exists() and self.trials_path.stat().st_size:
                raise BenchmarkSettingsError(
                    f"--out {self.path}: has {TRIALS_FILE} but no {SETTINGS_FILE}; use an empty "
                    "or new directory"
                )
            write_json(self.settings_path, settings)
            return settings, []
        old, config = found
        diff = settings_difference(old, settings)
        if diff is not None:
            raise BenchmarkSettingsError(
                f"--out {self.path}: holds a benchmark with other settings: {diff}; use another "
                "--out, or the same settings to continue it"
            )
        kernels = kernels_difference(old.get("numerics"), settings.get("numerics", {}))
        if kernels is not None:  # the same trials, not the same last bits
            log.warning(
                "continuing %s on other numerics: %s; the trials run here may differ in "
                "their last bits (and, among walls, in outcome) from the same seeds there",
                self.path,
                kernels,
            )
        if settings["trials"] < old["trials"]:
            raise BenchmarkSettingsError(
                f"--trials {settings['trials']}: {self.path} already plans {old['trials']} trials "
                f"per method; give --trials >= {old['trials']} (a run can only be extended)"
            )
        # every line checked before anything is written (an extension included)
        trials = read_trials(self.trials_path, repair=True, config=config)
        trials = check_run_trials(self.trials_path, trials, old)
        merged = dict(old)
        if settings["trials"] > old["trials"]:
            merged["trials"] = settings["trials"]
            merged.setdefault("extended", []).append(
                {"from": old["trials"], "to": settings["trials"], "at": settings["created"]}
            )
            write_json(self.settings_path, merged)
        return merged, trials

    def append(self, trial: dict) -> None:
        """Append one trial line: one write, fsynced (never through a link). A failed
        append (a full disk) cuts the file back to its previous length — no half line —
        and raises the `OSError` naming `trials.jsonl`."""
        what = (
            "could not be appended to (cut back to its finished trials, which are kept; "
            "free some space and run the same command again to continue)"
        )
        _append_line(self.trials_path, trial, what)

    def append_error(self, error: dict) -> None:
        """Append one error line (`diagrams.trials.trial_error`) to `errors.jsonl` as
        `append` does to `trials.jsonl`; a later line of a trial supersedes its earlier."""
        what = (
            "could not be appended to (cut back to its earlier lines; free some space and "
            "run the same command again: the failed trials run again)"
        )
        _append_line(self.errors_path, error, what)

    def read_errors(self) -> dict[tuple[str, int], dict]:
        """The lines of `errors.jsonl` by trial (method, seed), in file order, a trial's
        last line superseding its earlier ones. The file is a report beside the run, which
        nothing reads into a table: a line that is not a trial's error line is skipped
        with a warning."""
        if not self.errors_path.is_file():
            return {}
        errors: dict[tuple[str, int], dict] = {}
        for number, line in enumerate(self.errors_path.read_bytes().splitlines(), 1):
            try:
                e = parse_json(line, f"line {number}")
                key = trial_key(e)
            except (JsonInputError, TypeError, KeyError, ValueError) as why:
                log.warning("%s: line %d is not a trial's error, skipped (%s)", self.errors_path,
                            number, why)  # fmt: skip
                continue
            errors.pop(key, None)
            errors[key] = e
        return errors

    def record_errors(self, errors: dict[tuple[str, int], dict]) -> None:
        """Make `errors.jsonl` hold exactly the error lines `errors` (one JSON line each,
        in order), written atomically; removed when there are none."""
        if not errors:
            self.errors_path.unlink(missing_ok=True)
            return
        text = "".join(json.dumps(json_safe(e), allow_nan=False) + "\n" for e in errors.values())
        write_text_atomic(self.errors_path, text, durable=True)

    def write_tables(
        self,
        settings: dict,
        trials: Sequence[dict],
        interrupted: bool = False,
        failed: int = 0,
    ) -> Path:
        """tables.md and the CSVs, from the trials sorted by method and seed; `failed`:
        trials that raised (`errors.jsonl`), named in a note — they are in no table."""
        methods = settings["planners"]
        trials = _sorted_trials(trials, methods)
        md = self.path / TABLES_FILE
        if not trials:
            return md
        obs = {m: settings["methods"][m]["observation"] for m in methods}
        reads = method_reads_of(settings)
        label = settings["setting_label"]
        plant = settings["plant"]
        summary = tables.summarize_methods(trials, methods)
        pairs = tables.pairwise_comparisons(trials, methods)
        counts = ", ".join(f"{m} {s['episodes']}" for m, s in summary.items())
        pkg = settings.get("package", {})
        notes = [
            f"plant: {plant}; setting: {label}; seeds {settings['first_seed']}–"
            f"{settings['first_seed'] + settings['trials'] - 1} "
            f"({settings['trials']} planned per method; done: {counts})"
            + (" — INTERRUPTED, partial" if interrupted else "")
            + (
                f" — {failed} trial{'s' if failed != 1 else ''} raised an error, in no table "
                f"({ERRORS_FILE})"
                if failed
                else ""
            ),
            f"goal radius {settings['goal_radius']} m (evaluation); configuration hash "
            f"{settings['config_sha256'][:12]}; emotion estimate: "
            f"{_estimate_label(settings['emotion_estimate_yaml'])}",
            f"package {pkg.get('version')} commit {str(pkg.get('commit'))[:12]}"
            + (" (with uncommitted changes)" if pkg.get("dirty") else "")
            + _kernels_label(settings.get("numerics")),
        ]
        if "runs" in settings:  # `emonav compare`: the runs the trials come from
            notes[-1] = "combined from " + "; ".join(
                f"{Path(r['path']).name} ({', '.join(r['planners'])}; commit "
                f"{str(r['commit'])[:12]})"
                for r in settings["runs"]
            )
            for name, m in settings.get("merged", {}).items():
                notes.append(
                    f"{name} is in {len(m['runs'])} runs ("
                    + ", ".join(Path(r).name for r in m["runs"])
                    + f"): merged, its {m['shared_trials']} trials found in more than one "
                    "agree record for record"
                )
        write_text_atomic(
            md,
            tables.render_markdown(
                trials,
                methods,
                label,
                plant,
                obs,
                title=f"Benchmark {self.path.name}",
                notes=notes,
                reads=reads,
            ),
        )
        csvs = (
            tables.table2_csv(summary),
            tables.table3_csv(summary, label, plant, obs),
            tables.social_csv(summary),
            tables.pairwise_csv(pairs),
        )
        for name, text in zip(TABLE_CSV_FILES, csvs, strict=True):
            write_text_atomic(self.path / name, text)
        return md


def method_reads_of(settings: dict) -> dict | None:
    """`tables.method_reads` of every method of a run, from its recorded configuration
    (None when a run directory of an older format lacks what it needs)."""
    observations = {m: settings["methods"][m]["observation"] for m in settings["planners"]}
    from emonav_drake.planners import MPC_STEERED

    try:
        config = load_config(data=settings["config_yaml"])
    except (KeyError, ConfigError):
        return None
    source, sensor = config.perception.state_source, config.sensor.preset
    # the maps ring the tracks when asked to, or when the camera's emotions are kept per track
    rings = config.perception.map_rings == "tracks" or (
        _estimate_mode(settings.get("emotion_estimate_yaml")) == "camera_tracks"
    )
    return {
        m: tables.method_reads(obs, source, sensor, m in MPC_STEERED, rings)
        for m, obs in observations.items()
    }


def _append_line(path: Path, obj: dict, what: str) -> None:
    """Append `obj` as one JSON line to `path`: one write, fsynced, never through a link.
    A failed append (a full disk) cuts the file back to its previous length — no half
    line — and raises the `OSError` naming `path` and saying `what` happened."""
    data = (json.dumps(json_safe(obj), allow_nan=False) + "\n").encode()
    flags = os.O_WRONLY | os.O_APPEND | os.O_CREAT | os.O_NOFOLLOW
    with naming_full_disk(path, what):
        fd = os.open(path, flags, 0o666)
        try:
            size = os.fstat(fd).st_size
            try:
                view = memoryview(data)
                while view:  # a short write (the disk filling up) goes on, or raises
                    view = view[os.write(fd, view) :]
                os.fsync(fd)
            except BaseException:
                with contextlib.suppress(OSError):
                    os.ftruncate(fd, size)
                    os.fsync(fd)
                raise
        finally:
            os.close(fd)


def check_run_trials(path: Path, trials: list[dict], settings: dict) -> list[dict]:
    """The trials of the run file `path` that belong to its `settings` (one per method and
    seed: a repeated identical line is kept once); `BenchmarkSettingsError` for a trial
    of another method or plant, a seed outside the run's, or two different results for
    one trial."""
    seen: dict[tuple[str, int], dict] = {}
    lo = settings["first_seed"]
    hi = lo + settings["trials"]
    for t in trials:
        key = trial_key(t)
        if t["method"] not in settings["planners"] or t.get("plant") != settings["plant"]:
            raise BenchmarkSettingsError(
                f"{path}: a trial of {t['method']!r} on {t.get('plant')!r} "
                "does not belong to this run's settings"
            )
        if not lo <= key[1] < hi:
            raise BenchmarkSettingsError(
                f"{path}: seed {key[1]} is outside this run's seeds [{lo}, {hi})"
            )
        if key in seen:
            if comparable(seen[key]) != comparable(t):
                raise BenchmarkSettingsError(
                    f"{path}: two different results for {key[0]} seed {key[1]}"
                )
            continue
        seen[key] = t
    return list(seen.values())


def load_run(path: str | Path) -> tuple[dict, list[dict]]:
    """(settings, trials sorted by method and seed) of a run directory (read only), every
    file checked as when a benchmark continues it: the settings (`check_settings`), each
    trial line against them (`check_trial`, `check_run_trials`)."""
    rd = RunDirectory(path)
    found = rd.read_settings()
    if found is None:
        raise BenchmarkSettingsError(f"{path}: no {SETTINGS_FILE}: not a benchmark run directory")
    settings, config = found
    trials = check_run_trials(rd.trials_path, read_trials(rd.trials_path, config=config), settings)
    return settings, _sorted_trials(trials, settings["planners"])


def _estimate_mode(estimate_yaml: str | None) -> str | None:
    """The `mode` of a run's recorded emotion estimate (None: ground truth; a recorded
    estimate without one: "confusion", its default)."""
    if estimate_yaml is None:
        return None
    mode = re.search(r"^mode:\s*(\w+)", estimate_yaml, re.M)
    return mode.group(1) if mode else "confusion"


def _kernels_label(numerics: dict | None) -> str:
    """'; BLAS kernels …' of a run that recorded them (docs/reliability.md: the same
    records on another machine need the same kernels), else ''."""
    words = kernels_words(numerics)
    return "; BLAS kernels " + words if words else ""


def _estimate_label(estimate_yaml: str | None) -> str:
    """How a run perceived emotions, for its summary line (the camera's rate from the
    estimate's `period`; an unknown mode is named as it is)."""
    name = _estimate_mode(estimate_yaml)
    if name is None:
        return "ground truth"
    period = re.search(r"^period:\s*([0-9.eE+-]+)", estimate_yaml, re.M)
    rate = f"{1.0 / float(period.group(1)):g} Hz" if period else "its period"
    return {
        "camera": f"head camera + face classifier ({rate}; unseen = neutral)",
        "camera_tracks": f"head camera, emotion kept per LiDAR track ({rate})",
        "confusion": "confusion model",
        "classifier": "face classifier",
        "ground_truth": "ground truth",
    }.get(name, name)


def replay_outcomes(run: str | Path, method: str, outcome: str) -> tuple[TrialRunner, list[int]]:
    """A runner that re-simulates the trials of the run directory `run` as they ran, and the
    seeds on which `method` ended with `outcome` ("collision", "timeout", …), in order."""
    from emonav_drake.diagrams.trials import TrialRunner
    from emonav_drake.evaluation.run_settings import spec_from_settings

    settings, trials = load_run(run)
    seeds = [
        t["seed"] for t in trials if t["method"] == method and t["record"]["outcome"] == outcome
    ]
    return TrialRunner(spec_from_settings(settings)), seeds
