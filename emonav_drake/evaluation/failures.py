"""The failing trials of a benchmark run, listed from its `trials.jsonl` (`emonav
diagnose --failures`), with the `emonav sim` command that plays each one again.

`failing_trials` picks them per method (seed, outcome and cause, steps, smallest
pedestrian distance); `rerun_command` builds the command from the run's settings (its
planner and checkpoint, plant and configuration: the recorded `--setting`/`--config` when
it still gives the run's configuration hash, else the `run_config.yaml` that
`write_run_files` writes); `format_failures` prints the listing. `diagnosis.py` simulates
the failures again to explain them.
"""

from __future__ import annotations

import os
import shlex
from collections import Counter
from collections.abc import Iterable
from pathlib import Path

RUN_CONFIG_FILE = "run_config.yaml"  # the run's configuration, written with --out
RUN_ESTIMATE_FILE = "run_emotion_estimate.yaml"  # its emotion estimate, if it has one
HIT_KINDS = frozenset({"pedestrian", "wall", "static"})  # what a recorded collision hit


def failure_cause(record: dict) -> str:
    """The cause of a trial's end in words (see the module)."""
    outcome = record["outcome"]
    if outcome == "collision":
        return f"collision: {record.get('collided_with') or 'unknown'}"
    if outcome == "fall":
        return f"fall: {record.get('fall_reason') or 'unknown'}"
    return outcome


def failure_kind(record: dict) -> str | None:
    """What ended a failed trial, coarsely: a collision by what it hit ("pedestrian",
    "wall", "static"; "collision" when the record does not say), else the outcome
    ("timeout", "fall", "no_route"); None for a success."""
    from emonav_drake.params import EMOTION_NAMES

    outcome = record["outcome"]
    if outcome == "success":
        return None
    if outcome != "collision":
        return outcome
    hit = record.get("collided_with") or ""
    return "pedestrian" if hit in EMOTION_NAMES else (hit or "collision")


def failure_counts(records: Iterable[dict]) -> Counter[str]:
    """The failed trials among `records` counted by `failure_kind`."""
    return Counter(k for r in records if (k := failure_kind(r)) is not None)


def format_counts(counts: Counter[str]) -> str:
    """'pedestrian 12, wall 3' — most frequent first, ties in name order."""
    return ", ".join(f"{k} {n}" for k, n in sorted(counts.items(), key=lambda x: (-x[1], x[0])))


def failing_trials(trials: list[dict], methods: list[str]) -> list[dict]:
    """The failed trials (outcome other than success) of `methods`, in the order of
    `methods` and then by seed: method, seed, outcome, cause (`failure_cause`), steps and
    the smallest pedestrian distance [m] (None without pedestrians), from the records."""
    out = []
    for m in methods:
        for t in sorted((t for t in trials if t["method"] == m), key=lambda t: t["seed"]):
            r = t["record"]
            if r["outcome"] == "success":
                continue
            out.append(
                {
                    "method": m,
                    "seed": int(t["seed"]),
                    "outcome": r["outcome"],
                    "cause": failure_cause(r),
                    "steps": r["steps"],
                    "min_ped_distance": r.get("min_ped_distance"),
                }
            )
    return out


def config_flags(settings: dict) -> list[str] | None:
    """The `--setting` / `--config` / `--time-varying` / `--deployable` / `--state-source` /
    `--family` / `--sensor` flags of the run's `config_source` if they still give its
    configuration (the same `config_sha256`), else None (the defaults, a setting, a preset
    or the file have changed since: use its `config_yaml`). Applied in the order of
    `cli.resolve.resolve_config`."""
    from emonav_drake.configs import load_setting
    from emonav_drake.params import apply_deployable, apply_sensor_preset, dump_config, load_config
    from emonav_drake.provenance import sha256_bytes

    words = str(settings.get("config_source") or "").split(" ")
    try:
        if words[0] == "--setting":
            cfg, flags, rest = load_setting(words[1]), words[:2], words[2:]
        elif words[0] == "--config":
            cfg, flags, rest = load_config(words[1]), words[:2], words[2:]
        else:  # "defaults", "the default configuration", then the flags
            first = next((i for i, w in enumerate(words) if w.startswith("--")), len(words))
            cfg, flags, rest = load_config(), [], words[first:]
        given: dict[str, str | None] = {}
        while rest:
            flag = rest.pop(0)
            if flag in ("--time-varying", "--deployable"):
                given[flag] = None
                flags.append(flag)
            elif flag in ("--state-source", "--family", "--sensor") and rest:
                given[flag] = rest.pop(0)
                flags += [flag, given[flag]]
            else:
                return None
        if "--time-varying" in given:
            cfg.crowd.time_varying_emotions = True
        if "--state-source" in given:
            cfg.perception.state_source = str(given["--state-source"])
        if "--family" in given:
            cfg.crowd.family = str(given["--family"])
        if "--deployable" in given:
            apply_deployable(cfg, given.get("--sensor"))
        elif "--sensor" in given:
            apply_sensor_preset(cfg, str(given["--sensor"]))
    except (OSError, ValueError, KeyError, IndexError):  # ConfigError is a ValueError
        return None
    return flags if sha256_bytes(dump_config(cfg).encode()) == settings["config_sha256"] else None


def write_run_files(settings: dict, out: str | Path) -> dict[str, str]:
    """Write the run's configuration (and emotion estimate) as YAML into `out`:
    {"config": path, "estimate": path (if the run has one)}, for `rerun_command`."""
    from emonav_drake.atomic_io import write_text_atomic

    files = {"config": str(Path(out) / RUN_CONFIG_FILE)}
    write_text_atomic(files["config"], settings["config_yaml"])
    if settings.get("emotion_estimate_yaml") is not None:
        files["estimate"] = str(Path(out) / RUN_ESTIMATE_FILE)
        write_text_atomic(files["estimate"], settings["emotion_estimate_yaml"])
    return files


def _shown_path(path: str) -> str:
    """`path` relative to the working directory when it lies under it."""
    rel = os.path.relpath(path) if os.path.isabs(path) else path
    return path if rel.startswith("..") else rel


def _planner_flags(method: dict) -> list[str]:
    """`--planner` (and `--checkpoint`) of `emonav sim` for a run's method (`MethodSpec`
    fields): the planner kind; a learned one by the registered name whose shipped
    checkpoint it is, else `policy` with its checkpoint (what the benchmark ran)."""
    from emonav_drake.planners import is_registered, planner_kind
    from emonav_drake.provenance import sha256_file

    if method.get("checkpoint") is None:
        return ["--planner", method["planner"]]
    for name in (method["name"], "policy"):
        kind = planner_kind(name) if is_registered(name) else None
        if kind is None or not kind.learned or kind.default_checkpoint is None:
            continue
        try:
            shipped = kind.default_checkpoint()
            same = shipped is not None and sha256_file(shipped) == method["checkpoint_sha256"]
        except (OSError, ValueError):
            same = False
        if same:
            return ["--planner", name]
    from emonav_drake.planners.legacy import planner_of

    kind = planner_of(method["planner"])
    return ["--planner", kind, "--checkpoint", _shown_path(method["checkpoint"])]


def rerun_command(
    settings: dict, method: str, seed: int, run_files: dict[str, str] | None = None
) -> str:
    """The `emonav sim` command line that plays trial (`method`, `seed`) of the run again:
    planner (and checkpoint), seed, plant, and the configuration — the flags of its
    `config_source` if they still give it (`config_flags`), else `--config` of the file
    `run_files["config"]` (default `run_config.yaml`, see `write_run_files`); the emotion
    estimate from `run_files["estimate"]` (default `run_emotion_estimate.yaml`)."""
    from emonav_drake.diagrams.plants import DEFAULT_PLANT

    files = run_files or {}
    argv = ["emonav", "sim", *_planner_flags(settings["methods"][method]), "--seed", str(seed)]
    if settings["plant"] != DEFAULT_PLANT:  # --plant's default needs no flag
        argv += ["--plant", settings["plant"]]
    flags = config_flags(settings)
    if flags is None:
        flags = ["--config", files.get("config", RUN_CONFIG_FILE)]
    argv += flags
    if settings.get("emotion_estimate_yaml") is not None:
        argv += ["--emotion-estimate", files.get("estimate", RUN_ESTIMATE_FILE)]
    elif "--deployable" in flags:  # its emotions were the simulator's, not the default
        argv += ["--emotion-source", "truth"]
    return shlex.join(argv)


def _distance(d: float | None) -> str:
    return "—" if d is None else f"{d:.2f}"


def format_failures(
    settings: dict,
    trials: list[dict],
    methods: list[str],
    run_dir: str | Path,
    run_files: dict[str, str] | None = None,
    rerun: int = 3,
    causes: dict[tuple[str, int], str] | None = None,
) -> str:
    """The failed trials of `methods` as text, per method: a count by outcome (and, with
    collisions, by `failure_kind`: what they hit), one line
    per trial (seed, cause, steps, smallest pedestrian distance) and the `emonav sim`
    command of the first `rerun` (`rerun_command`). `causes` replaces a record's cause
    by a re-simulated one ((method, seed) → cause, from `diagnose_run`)."""
    failures = failing_trials(trials, methods)
    plant = settings["plant"]
    first, count = settings.get("first_seed"), settings.get("trials")
    lines = [f"{run_dir}: {plant} run, {len(trials)} finished trials"]
    if first is not None and count:
        lines[0] += f" (seeds {first}–{first + count - 1} per method)"
    files = run_files or {}
    if config_flags(settings) is None and "config" not in files:
        where = Path(run_dir) / "settings.json"
        lines += [
            f"Its configuration ({settings.get('config_source')}) has changed since the run: "
            f"the commands read the run's from {RUN_CONFIG_FILE}; write it with",
            '  python3 -c "import json; print(json.load(open('
            f"{str(where)!r}))['config_yaml'], end='')\" > {RUN_CONFIG_FILE}",
        ]
    if settings.get("emotion_estimate_yaml") is not None and "estimate" not in files:
        lines.append(
            f"Its emotion estimate is settings.json's emotion_estimate_yaml: save it as "
            f"{RUN_ESTIMATE_FILE} (or use --out DIR, which writes both files)."
        )
    unknown = False
    for m in methods:
        mine = [f for f in failures if f["method"] == m]
        n = sum(t["method"] == m for t in trials)
        text = format_counts(Counter(f["outcome"] for f in mine))
        kinds = failure_counts(t["record"] for t in trials if t["method"] == m)
        if kinds.keys() & HIT_KINDS:  # the records say what the collisions hit
            text += f"; by kind: {format_counts(kinds)}"
        lines += ["", f"{m}: {len(mine)} of {n} trials failed" + (f" ({text})" if text else "")]
        if not mine:
            continue
        lines.append(f"  {'seed':>8s}  {'outcome: cause':32s} {'steps':>5s}  min ped. distance [m]")
        for f in mine:
            cause = (causes or {}).get((m, f["seed"]), f["cause"])
            unknown |= cause.endswith(": unknown")
            distance = _distance(f["min_ped_distance"])
            lines.append(f"  {f['seed']:>8d}  {cause:32s} {f['steps']:>5d}  {distance}")
        shown = mine[:rerun]
        if shown:
            lines.append(f"  re-run (the first {len(shown)}):")
            lines += [f"    {rerun_command(settings, m, f['seed'], files)}" for f in shown]
    if unknown:
        lines += [
            "",
            "unknown: the run's records do not say what a collision hit (recorded since "
            "`collided_with`); `emonav diagnose RUN --out DIR` simulates the failures "
            "again and names it.",
        ]
    return "\n".join(lines) + "\n"
