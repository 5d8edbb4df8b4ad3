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
  line written with one `write` + flush + fsync. A kill can leave at most a torn last line;
  it is detected and dropped (and its trial redone) when the directory is opened again.
  Every other line is checked when read (`check_trial`: a known outcome, counts and
  lengths >= 0, …); a bad one is an error naming the file and line, never a table entry.
* `tables.md` and `table2.csv`, `table3.csv`, `social.csv`, `pairwise.csv` — the tables of
  `evaluation.tables`, written at the end and on an interruption, from the sorted trials.

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
import datetime
import json
import logging
import math
import os
import time
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import Any

from emonav_drake.atomic_io import (
    check_output_dir,
    json_safe,
    naming_full_disk,
    write_json,
    write_text_atomic,
)
from emonav_drake.core.metrics import COLLISION, FALL, SUCCESS, TIMEOUT, EpisodeRecord
from emonav_drake.core.scenario import MAX_SEED
from emonav_drake.diagrams.plants import PLANTS, plant_named
from emonav_drake.diagrams.trials import (
    MAX_TRIALS,
    BenchmarkSpec,
    MethodSpec,
    TrialRunner,
    run_serial,
    run_trials,
)
from emonav_drake.errors import RunInterrupted
from emonav_drake.evaluation import tables
from emonav_drake.params import ConfigError, EmoNavConfig, dump_config, load_config
from emonav_drake.provenance import package_identity, sha256_bytes

log = logging.getLogger(__name__)

SETTINGS_FILE = "settings.json"
TRIALS_FILE = "trials.jsonl"
TABLES_FILE = "tables.md"
TABLE_CSV_FILES = ("table2.csv", "table3.csv", "social.csv", "pairwise.csv")
RUN_FILES = (SETTINGS_FILE, TRIALS_FILE, TABLES_FILE, *TABLE_CSV_FILES)
FORMAT = 1
OUTCOMES = (SUCCESS, COLLISION, TIMEOUT, FALL)


class BenchmarkSettingsError(ConfigError):
    """A run directory holds a benchmark with other settings (or is damaged)."""


def setting_label(config: EmoNavConfig, name: str | None) -> str:
    """E.g. "var_dd [0.2, 0.35, 0.5] m" (+ ", time-varying"): the DD column of Table III."""
    r = config.reward
    label = f"{name or 'config'} [{r.happy_discomfort:g}, {r.neutral_discomfort:g}, "
    label += f"{r.negative_discomfort:g}] m"
    if config.crowd.time_varying_emotions:
        label += ", time-varying"
    return label


def make_settings(
    methods: Sequence[MethodSpec],
    plant: str,
    trials: int,
    first_seed: int,
    config: EmoNavConfig,
    setting: str | None = None,
    config_source: str = "defaults",
    emotion_estimate_yaml: str | None = None,
) -> dict:
    """The `settings.json` of a run."""
    cfg_yaml = dump_config(config)
    return {
        "format": FORMAT,
        "planners": [m.name for m in methods],
        "methods": {m.name: dc.asdict(m) for m in methods},
        "plant": plant,
        "trials": trials,
        "first_seed": first_seed,
        "setting": setting,
        "setting_label": setting_label(config, setting or _source_name(config_source)),
        "config_source": config_source,
        "config_sha256": sha256_bytes(cfg_yaml.encode()),
        "config_yaml": cfg_yaml,
        "time_varying": bool(config.crowd.time_varying_emotions),
        "goal_radius": config.episode.eval_goal_radius,
        "emotion_estimate_yaml": emotion_estimate_yaml,
        "emotion_estimate_sha256": (
            None if emotion_estimate_yaml is None else sha256_bytes(emotion_estimate_yaml.encode())
        ),
        "package": package_identity(),
        "created": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
    }


def _source_name(config_source: str) -> str:
    if config_source.startswith("--config"):
        return Path(config_source.split()[1]).stem
    return "default"


def spec_from_settings(settings: dict) -> BenchmarkSpec:
    return BenchmarkSpec(
        methods=[MethodSpec(**settings["methods"][n]) for n in settings["planners"]],
        plant=settings["plant"],
        config_yaml=settings["config_yaml"],
        emotion_estimate_yaml=settings["emotion_estimate_yaml"],
    )


def _short(v: Any) -> str:
    if isinstance(v, str):
        return repr(v if len(v) <= 14 else v[:12] + "…")
    return str(v)


def settings_difference(old: dict, new: dict) -> str | None:
    """The first setting in which `new` differs from a run directory's `old`, as words."""
    if old.get("format") != FORMAT:
        return f"format is {old.get('format')!r} there, {FORMAT} here"
    if set(old["planners"]) != set(new["planners"]):
        return f"planners are {','.join(old['planners'])} there, {','.join(new['planners'])} here"
    simple = [
        ("plant", "plant"),
        ("first_seed", "first seed"),
        ("time_varying", "time-varying emotions"),
        ("config_sha256", "configuration (hash)"),
        ("emotion_estimate_sha256", "emotion estimate (hash)"),
    ]
    for key, what in simple:
        if old.get(key) != new.get(key):
            extra = ""
            if key == "config_sha256":
                extra = f" — {_config_diff(old['config_yaml'], new['config_yaml'])}"
            return f"{what} is {_short(old.get(key))} there, {_short(new.get(key))} here{extra}"
    for name in new["planners"]:
        a, b = old["methods"][name], new["methods"][name]
        for key, what in (("planner", "planner"), ("checkpoint_sha256", "checkpoint (hash)")):
            if a.get(key) != b.get(key):
                return f"{what} of {name} is {_short(a.get(key))} there, {_short(b.get(key))} here"
    pa, pb = old.get("package", {}), new.get("package", {})
    # the code itself, not the commit: a commit of docs or tests does not change a trial,
    # an uncommitted edit of a planner does (the commit is kept for the record only)
    for key, what in (
        ("version", "package version"),
        ("code_sha256", "package code (hash of emonav_drake/**/*.py)"),
    ):
        if pa.get(key) != pb.get(key):
            return f"{what} is {_short(pa.get(key))} there, {_short(pb.get(key))} here"
    return None


def _config_diff(a: str, b: str) -> str:
    """The first differing line of two configuration dumps, with its section."""
    section = ""
    for la, lb in zip(a.splitlines(), b.splitlines(), strict=False):
        if not la.startswith(" "):
            section = la.rstrip(":")
        if la != lb:
            key = la.strip().split(":")[0]
            there, here = (x.split(":", 1)[-1].strip() for x in (la, lb))
            return f"{section}.{key}: {there} there, {here} here"
    return "the dumps differ in length"


# --------------------------------------------------------------------------- run dir
def _trial_key(t: dict) -> tuple[str, int]:
    return t["method"], int(t["seed"])


def comparable(t: dict) -> dict:
    """A trial line without its wall time (what must be equal between engines)."""
    return {k: v for k, v in t.items() if k != "wall_seconds"}


_RECORD_FIELDS = {f.name for f in dc.fields(EpisodeRecord)}
_RECORD_REQUIRED = (
    "outcome",
    "steps",
    "nav_time",
    "path_length",
    "min_ped_distance",
    "discomfort_steps",
    "idt",
    "total_reward",
)


def _is_int(v: Any) -> bool:
    return isinstance(v, int) and not isinstance(v, bool)


def _is_number(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def check_trial(t: dict) -> str | None:
    """What is wrong with one `trials.jsonl` line (a dict with `method`, `seed`, `record`),
    in words; None if it is a valid trial: a method name, a seed in [0, 2**64 - 1], a
    record with every field of `EpisodeRecord.to_json()` and no other, a known outcome,
    step counts that are integers in [0, steps], lengths and times that are finite and
    >= 0 (`min_ped_distance` may be null: no pedestrian), a finite reward."""
    if not isinstance(t["method"], str) or not t["method"]:
        return f"method = {t['method']!r} is not a method name"
    if not (_is_int(t["seed"]) and 0 <= t["seed"] <= MAX_SEED):
        return f"seed = {t['seed']!r} is not a seed (an integer in [0, 2**64 - 1])"
    if "plant" in t and t["plant"] not in PLANTS:
        return f"plant = {t['plant']!r} is not {' or '.join(PLANTS)}"
    if "wall_seconds" in t and not (_is_number(t["wall_seconds"]) and t["wall_seconds"] >= 0):
        return f"wall_seconds = {t['wall_seconds']!r} must be a number >= 0"
    r = t["record"]
    if not isinstance(r, dict):
        return f"record = {r!r} is not an object"
    missing = [k for k in _RECORD_REQUIRED if k not in r]
    if missing:
        return f"record lacks {', '.join(missing)}"
    unknown = sorted(set(r) - _RECORD_FIELDS)
    if unknown:
        return f"record has the unknown field {unknown[0]!r}"
    if r["outcome"] not in OUTCOMES:
        return f"record.outcome = {r['outcome']!r} is not one of {', '.join(OUTCOMES)}"
    if not (_is_int(r["steps"]) and r["steps"] >= 0):
        return f"record.steps = {r['steps']!r} must be an integer >= 0"
    idt = r["idt"]
    if not (isinstance(idt, list) and len(idt) == 4):
        return f"record.idt = {idt!r} must be a list of 4 step counts"
    counts = [("discomfort_steps", r["discomfort_steps"])]
    counts += [(f"idt[{i}]", v) for i, v in enumerate(idt)]
    for name, v in counts:
        if not (_is_int(v) and 0 <= v <= r["steps"]):
            return f"record.{name} = {v!r} must be an integer in [0, steps = {r['steps']}]"
    for name in ("nav_time", "path_length", "min_ped_distance"):
        v = r[name]
        if v is None and name == "min_ped_distance":
            continue
        if not (_is_number(v) and v >= 0):
            return f"record.{name} = {v!r} must be a finite number >= 0"
    if not _is_number(r["total_reward"]):
        return f"record.total_reward = {r['total_reward']!r} must be a finite number"
    if "seed" in r and r["seed"] != t["seed"]:
        return f"record.seed = {r['seed']!r} differs from the line's seed {t['seed']!r}"
    for name in ("fall_reason", "collided_with"):
        if name in r and not isinstance(r[name], str):
            return f"record.{name} = {r[name]!r} must be a string"
    return None


def read_trials(path: Path, repair: bool = False) -> list[dict]:
    """The trial lines of `trials.jsonl`, each checked (`check_trial`). A torn last line (a
    kill while writing: no final newline, or not a trial's JSON) is dropped — and cut from
    the file with `repair`, so the next append starts on a fresh line; a damaged earlier
    line, or any line that is a trial's JSON with invalid values, is an error naming the
    file and the line."""
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
        if nl >= 0 and line.strip():
            try:
                t = json.loads(line)
            except ValueError:
                t = None
            if not (isinstance(t, dict) and {"method", "seed", "record"} <= set(t)):
                t = None
        elif nl >= 0:  # an empty line
            pos = nl + 1
            continue
        if t is None:
            if end >= len(data) - 1:  # the last line
                log.warning("%s: dropping a torn last line (%d bytes)", path, len(line))
                break
            raise BenchmarkSettingsError(
                f"{path}: line {number} is damaged (not a trial's JSON); fix or remove that line"
            )
        problem = check_trial(t)
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
        self._lock_fd: int | None = None

    @contextlib.contextmanager
    def locked(self) -> Iterator[RunDirectory]:
        """Exclusive use of the directory (a second benchmark into it is refused)."""
        import fcntl

        self.path.mkdir(parents=True, exist_ok=True)
        fd = os.open(self.path, os.O_RDONLY)  # the directory itself: no lock file to leave
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            os.close(fd)
            raise BenchmarkSettingsError(
                f"--out {self.path}: another emonav benchmark is running in this directory"
            ) from None
        self._lock_fd = fd
        try:
            yield self
        finally:
            fcntl.flock(fd, fcntl.LOCK_UN)
            os.close(fd)
            self._lock_fd = None

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

    def read_settings(self) -> dict | None:
        if not self.settings_path.exists():
            return None
        try:
            return json.loads(self.settings_path.read_text())
        except ValueError as e:
            raise BenchmarkSettingsError(f"{self.settings_path}: not valid JSON ({e})") from None

    def open(self, settings: dict) -> tuple[dict, list[dict]]:
        """Check or create `settings.json`; the valid trials already done (torn line cut).

        Returns the directory's settings (its planners' order and first creation kept; the
        number of trials raised to `settings["trials"]`) and the finished trials. A file
        that is a link is refused first (`check_regular_files`).
        """
        self.check_regular_files()
        old = self.read_settings()
        if old is None:
            if self.trials_path.exists() and self.trials_path.stat().st_size:
                raise BenchmarkSettingsError(
                    f"--out {self.path}: has {TRIALS_FILE} but no {SETTINGS_FILE}; use an empty "
                    "or new directory"
                )
            write_json(self.settings_path, settings)
            return settings, []
        diff = settings_difference(old, settings)
        if diff is not None:
            raise BenchmarkSettingsError(
                f"--out {self.path}: holds a benchmark with other settings: {diff}; use another "
                "--out, or the same settings to continue it"
            )
        if settings["trials"] < old["trials"]:
            raise BenchmarkSettingsError(
                f"--trials {settings['trials']}: {self.path} already plans {old['trials']} trials "
                f"per method; give --trials >= {old['trials']} (a run can only be extended)"
            )
        merged = dict(old)
        if settings["trials"] > old["trials"]:
            merged["trials"] = settings["trials"]
            merged.setdefault("extended", []).append(
                {"from": old["trials"], "to": settings["trials"], "at": settings["created"]}
            )
            write_json(self.settings_path, merged)
        trials = read_trials(self.trials_path, repair=True)
        return merged, self._check_trials(trials, merged)

    def _check_trials(self, trials: list[dict], settings: dict) -> list[dict]:
        seen: dict[tuple[str, int], dict] = {}
        lo = settings["first_seed"]
        hi = lo + settings["trials"]
        for t in trials:
            key = _trial_key(t)
            if t["method"] not in settings["planners"] or t.get("plant") != settings["plant"]:
                raise BenchmarkSettingsError(
                    f"{self.trials_path}: a trial of {t['method']!r} on {t.get('plant')!r} "
                    "does not belong to this run's settings"
                )
            if not lo <= key[1] < hi:
                raise BenchmarkSettingsError(
                    f"{self.trials_path}: seed {key[1]} is outside this run's seeds [{lo}, {hi})"
                )
            if key in seen:
                if comparable(seen[key]) != comparable(t):
                    raise BenchmarkSettingsError(
                        f"{self.trials_path}: two different results for {key[0]} seed {key[1]}"
                    )
                continue
            seen[key] = t
        return list(seen.values())

    def append(self, trial: dict) -> None:
        """Append one trial line: one write, flushed and fsynced (never through a link)."""
        line = json.dumps(json_safe(trial), allow_nan=False) + "\n"
        flags = os.O_WRONLY | os.O_APPEND | os.O_CREAT | os.O_NOFOLLOW
        with naming_full_disk(self.trials_path, "could not be appended to"):
            with os.fdopen(os.open(self.trials_path, flags, 0o666), "ab") as f:
                f.write(line.encode())
                f.flush()
                os.fsync(f.fileno())

    def write_tables(
        self, settings: dict, trials: Sequence[dict], interrupted: bool = False
    ) -> Path:
        """tables.md and the CSVs, from the trials sorted by method and seed."""
        methods = settings["planners"]
        rank = {m: i for i, m in enumerate(methods)}
        trials = sorted(trials, key=lambda t: (rank.get(t["method"], len(rank)), t["seed"]))
        md = self.path / TABLES_FILE
        if not trials:
            return md
        obs = {m: settings["methods"][m]["observation"] for m in methods}
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
            + (" — INTERRUPTED, partial" if interrupted else ""),
            f"goal radius {settings['goal_radius']} m (evaluation); configuration hash "
            f"{settings['config_sha256'][:12]}; emotion estimate: "
            f"{'ground truth' if settings['emotion_estimate_yaml'] is None else 'confusion model'}",
            f"package {pkg.get('version')} commit {str(pkg.get('commit'))[:12]}"
            + (" (with uncommitted changes)" if pkg.get("dirty") else ""),
        ]
        write_text_atomic(
            md,
            tables.render_markdown(
                trials, methods, label, plant, obs, title=f"Benchmark {self.path.name}", notes=notes
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


def load_run(path: str | Path) -> tuple[dict, list[dict]]:
    """(settings, trials sorted by method and seed) of a run directory (read only)."""
    rd = RunDirectory(path)
    settings = rd.read_settings()
    if settings is None:
        raise BenchmarkSettingsError(f"{path}: no {SETTINGS_FILE}: not a benchmark run directory")
    rank = {m: i for i, m in enumerate(settings["planners"])}
    trials = read_trials(rd.trials_path)
    trials.sort(key=lambda t: (rank.get(t["method"], len(rank)), t["seed"]))
    return settings, trials


# --------------------------------------------------------------------------- engine
@dc.dataclass
class BenchmarkResult:
    path: Path
    settings: dict
    trials: list[dict]  # all finished trials of the directory, sorted
    ran: int  # trials run by this call
    wall_seconds: float


class _Progress:
    """tqdm bar with the running SR per method."""

    def __init__(self, total: int, done: list[dict], methods: Sequence[str], enabled: bool):
        from tqdm import tqdm

        self.methods = list(methods)
        self.k = {m: 0 for m in methods}
        self.n = {m: 0 for m in methods}
        for t in done:
            self._count(t)
        self.bar = tqdm(total=total, initial=len(done), unit="trial", disable=not enabled)
        self._postfix()

    def _count(self, t: dict) -> None:
        self.n[t["method"]] += 1
        self.k[t["method"]] += t["record"]["outcome"] == "success"

    def _postfix(self) -> None:
        parts = [
            f"{m} SR {self.k[m] / self.n[m]:.3f} ({self.n[m]})" if self.n[m] else f"{m} -"
            for m in self.methods
        ]
        self.bar.set_postfix_str(" | ".join(parts), refresh=False)

    def update(self, t: dict) -> None:
        self._count(t)
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
) -> BenchmarkResult:
    """Run (or continue) the benchmark in the run directory `out`; see the module.

    Args:
        workers: 1 (and no `ray_address`): serial in this process; > 1: a local Ray with
            that many workers; None with `ray_address`: one worker per CPU of the cluster.
        on_trial: called with every new trial line and the number written by this call,
            after it is on disk (tests raise `KeyboardInterrupt` from it to simulate Ctrl-C).
    Raises:
        BenchmarkSettingsError: `out` holds another benchmark.
        RunInterrupted: after Ctrl-C / SIGTERM: the finished trials are kept and the
            tables of them written; running the same call again continues.
    """
    robot = plant_named(plant)
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
    if emotion_estimate_yaml is not None and not robot.emotion_estimates:
        raise ConfigError("--emotion-estimate is available with --plant lip only")
    out = check_output_dir(out, "--out")
    # the same YAML text drives every engine (the driver's and the workers' configs are equal)
    config = load_config(data=dump_config(config))
    _check_scenarios(config, first_seed, trials, config_source)
    spec = BenchmarkSpec(list(methods), plant, dump_config(config), emotion_estimate_yaml)
    probe = TrialRunner(spec)  # builds every planner now: a bad checkpoint fails before work
    for m in spec.methods:
        m.observation = probe.observation(m.name)
    del probe
    settings = make_settings(
        spec.methods,
        plant,
        trials,
        first_seed,
        config,
        setting,
        config_source,
        emotion_estimate_yaml,
    )
    rd = RunDirectory(out)
    t0 = time.perf_counter()
    with rd.locked():
        settings, done = rd.open(settings)
        # the directory's method order; this call's checkpoint paths (same hashes)
        given = {m.name: m for m in spec.methods}
        spec.methods = [given[n] for n in settings["planners"]]
        have = {_trial_key(t) for t in done}
        seeds = range(settings["first_seed"], settings["first_seed"] + settings["trials"])
        tasks = [(m, s) for s in seeds for m in settings["planners"] if (m, s) not in have]
        all_trials = list(done)
        new: list[dict] = []
        bar = _Progress(len(done) + len(tasks), done, settings["planners"], progress)

        def on_result(t: dict) -> None:
            rd.append(t)
            all_trials.append(t)
            new.append(t)
            bar.update(t)
            if on_trial is not None:
                on_trial(t, len(new))

        try:
            if tasks:
                if workers == 1 and not ray_address:
                    run_serial(spec, tasks, on_result)
                else:
                    run_trials(spec, tasks, on_result, workers, ray_address)
        except KeyboardInterrupt:
            bar.close()
            md = rd.write_tables(settings, all_trials, interrupted=True)
            total = len(seeds) * len(settings["planners"])
            if not all_trials:
                raise RunInterrupted(
                    f"interrupted before the first trial finished; {out} holds the settings "
                    "only; run the same command again to start"
                ) from None
            raise RunInterrupted(
                f"interrupted after {len(new)} new trials ({len(all_trials)} of {total} in "
                f"{out}); tables of the finished ones in {md}; run the same command again "
                "to continue"
            ) from None
        except BaseException:
            bar.close()
            rd.write_tables(settings, all_trials, interrupted=True)
            raise
        bar.close()
        rd.write_tables(settings, all_trials)
    rank = {m: i for i, m in enumerate(settings["planners"])}
    all_trials.sort(key=lambda t: (rank[t["method"]], t["seed"]))
    return BenchmarkResult(out, settings, all_trials, len(new), time.perf_counter() - t0)


def _check_scenarios(config: EmoNavConfig, first_seed: int, trials: int, where: str) -> None:
    """Sample every scenario now (cheap): a crowd that does not fit fails before any trial."""
    from emonav_drake.core.scenario import ScenarioSamplingError, sample_scenario

    for seed in range(first_seed, first_seed + trials):
        try:
            sample_scenario(seed, config)
        except ScenarioSamplingError as e:
            raise ScenarioSamplingError(f"{where}: {e}") from None
