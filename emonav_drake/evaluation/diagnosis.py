"""Why a benchmark run's trials fail: the failing trials, their causes, and on Digit
the tracking before them.

    emonav diagnose benchmarks/results/digit_table2 [--methods policy] [--last 5]
                    --out runs/diagnosis
    emonav diagnose benchmarks/results/lip_table2 --failures

`failing_trials` / `format_failures` (`--failures`) list, per method, the failed trials
of a run from its `trials.jsonl` alone (no simulation): seed, outcome and cause, steps,
smallest pedestrian distance, and the `emonav sim` command that plays a trial again
(`rerun_command`: the run's planner, checkpoint, plant and configuration).

`diagnose_run` (`--out`) simulates every failed trial (outcome collision, timeout or
fall) again from its seed (the benchmark is deterministic: the same record, checked), on
the run's plant. On a LIP run that gives each failure its cause (the records of runs
made before `collided_with` was recorded do not say what a collision hit). On a Digit run
it does so with a trace of the robot and the held command at every planner instant, and
each failure gets:

* its cause: "collision: static" or "collision: <emotion>" (the pedestrian's emotion at
  the collision), "fall: <reason>", "timeout";
* the tracking over the last `last` walking steps before the end: per step, the distance
  between where Digit's CoM went and where the planner's model (the LIP of Eq. 1, driven
  by u_k) put it, and the heading error — the LIP/Digit discrepancy the planner did not
  see — and the same for the calibrated model (`data/digit_response.json`);
* the smallest pedestrian distance of the episode.

Successful trials give the reference: the same errors over their last steps before the
goal, from up to `reference` successful trials per method. The tracking comparison is
Digit's against the planner's LIP model: on a LIP run the robot *is* that model, so it is
skipped there (and no successes are simulated). `diagnosis.json` keeps every row;
`diagnosis.md` the counts by cause and the error statistics; `diagnosis.png` the figure
(causes by method, on Digit the tracking errors before failures against successes);
`failures.md` the list of failed trials; `run_config.yaml` the run's configuration, which
the listed `emonav sim` commands read when `config_source` no longer gives it.
"""

from __future__ import annotations

import os
import shlex
from collections import Counter
from pathlib import Path

import numpy as np

from emonav_drake.core import step_response as sr
from emonav_drake.params import ConfigError, EmoNavConfig

RUN_CONFIG_FILE = "run_config.yaml"  # the run's configuration, written with --out
RUN_ESTIMATE_FILE = "run_emotion_estimate.yaml"  # its emotion estimate, if it has one


def failure_cause(record: dict) -> str:
    """The cause of a trial's end in words (see the module)."""
    outcome = record["outcome"]
    if outcome == "collision":
        return f"collision: {record.get('collided_with') or 'unknown'}"
    if outcome == "fall":
        return f"fall: {record.get('fall_reason') or 'unknown'}"
    return outcome


def tracking_errors(trace: list[dict], config: EmoNavConfig, last: int, model=None) -> dict:
    """Per-step errors over the last `last` transitions of a trace: position [m] and
    heading [rad] of the LIP driven by u_k (and of `model`, if given) against Digit."""
    r = config.robot
    data = sr.transitions_from_trace(trace, r.step_time, skip=1)
    if len(data) == 0:
        return {"steps": 0}
    tail = data.select(np.arange(len(data)) >= len(data) - last)
    lip = sr.lip_errors(tail, r.omega, r.step_time, 0)
    out = {
        "steps": len(tail),
        "lip_position": np.hypot(lip[:, 0], lip[:, 1]).tolist(),
        "lip_heading": np.abs(lip[:, 2]).tolist(),
    }
    if model is not None:
        fit = sr.evaluate(model, tail)
        out["model_position"] = np.hypot(fit[:, 0], fit[:, 1]).tolist()
        out["model_heading"] = np.abs(fit[:, 2]).tolist()
    return out


def diagnose_trial(runner, method: str, seed: int, last: int, model) -> dict:
    """Simulate one trial of `runner`'s run again: its cause, and on Digit (traced) the
    tracking errors over the last `last` steps (`tracking` is None on another plant)."""
    plant = runner.spec.plant
    if plant == "digit":
        from emonav_drake.core.scenario import sample_scenario
        from emonav_drake.diagrams.navigation_digit import run_digit_episode

        planner, cfg, grid_kind = runner.planner(method)
        trace: list[dict] = []
        record = run_digit_episode(
            sample_scenario(seed, runner.config),
            cfg,
            planner,
            grid_kind=grid_kind,
            goal_radius=cfg.episode.eval_goal_radius,
            trace=trace,
        ).to_json()
        tracking = tracking_errors(trace, cfg, last, model)
    else:  # the benchmark's own trial: the same record, nothing to compare the robot with
        record, tracking = runner.run(method, seed)["record"], None
    return {
        "method": method,
        "seed": seed,
        "plant": plant,
        "outcome": record["outcome"],
        "cause": failure_cause(record),
        "steps": record["steps"],
        "min_ped_distance": record.get("min_ped_distance"),
        "tracking": tracking,
        "record": record,
    }


def diagnose_run(
    run_dir: str | Path,
    out: str | Path,
    methods: list[str] | None = None,
    last: int = 5,
    reference: int = 10,
    progress: bool = True,
) -> list[dict]:
    """Diagnose every failure of a benchmark run, LIP or Digit (module docstring); write
    diagnosis.{json,md,png}, failures.md and run_config.yaml into `out`."""
    from tqdm import tqdm

    from emonav_drake.atomic_io import write_json, write_text_atomic
    from emonav_drake.diagrams.trials import TrialRunner
    from emonav_drake.evaluation.run_directory import SETTINGS_FILE, load_run
    from emonav_drake.evaluation.run_settings import spec_from_settings

    settings, trials = load_run(run_dir)
    where = Path(run_dir) / SETTINGS_FILE
    try:  # the run's configuration, stored as YAML text in its settings
        runner = TrialRunner(spec_from_settings(settings))
    except KeyError as e:
        raise ConfigError(f"{where}: no {e} in it (not a benchmark's settings?)") from None
    except ConfigError as e:
        # the YAML loader names no file for a YAML string: name the settings and the field
        field = "config_yaml"
        if settings.get("emotion_estimate_yaml") is not None:
            field += " or emotion_estimate_yaml"
        raise ConfigError(f"{where} ({field}): {str(e).removeprefix('<yaml>: ')}") from None
    methods = check_methods(settings, methods)
    digit = settings["plant"] == "digit"
    model = None
    if digit:
        from emonav_drake.planners.model_aware import load_response

        model = load_response("digit")
    else:  # successes are the reference of the tracking comparison, Digit's only
        reference = 0
    todo = []
    for m in methods:
        mine = sorted((t for t in trials if t["method"] == m), key=lambda t: t["seed"])
        todo += [t for t in mine if t["record"]["outcome"] != "success"]
        todo += [t for t in mine if t["record"]["outcome"] == "success"][:reference]
    if not todo:
        finished = sum(t["method"] in methods for t in trials)
        if finished:  # a LIP run simulates failures only
            raise ConfigError(
                f"{run_dir}: no failed trials of {methods} to diagnose (all {finished} succeeded)"
            )
        raise ConfigError(f"{run_dir}: no finished trials of {methods} to diagnose")
    rows = []
    for t in tqdm(todo, desc="re-simulating", unit="trial", disable=not progress):
        row = diagnose_trial(runner, t["method"], t["seed"], last, model)
        row["reproduced"] = row["record"]["outcome"] == t["record"]["outcome"] and (
            row["record"]["steps"] == t["record"]["steps"]
        )
        rows.append(row)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    write_json(out / "diagnosis.json", rows)
    write_text_atomic(out / "diagnosis.md", diagnosis_table(rows))
    run_files = write_run_files(settings, out)
    causes = {(r["method"], r["seed"]): r["cause"] for r in rows if r["reproduced"]}
    listing = format_failures(settings, trials, methods, run_dir, run_files, causes=causes)
    write_text_atomic(out / "failures.md", listing)
    fig = plot_diagnosis(rows)
    fig.savefig(out / "diagnosis.png", dpi=110)
    return rows


def check_methods(settings: dict, methods: list[str] | None) -> list[str]:
    """`methods` (default: every method of the run), each one of the run's."""
    methods = methods or list(settings["planners"])
    unknown = set(methods) - set(settings["planners"])
    if unknown:
        raise ConfigError(f"--methods: {sorted(unknown)} not in the run ({settings['planners']})")
    return methods


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
    """The `--setting` / `--config` / `--time-varying` flags of the run's `config_source`
    if they still give its configuration (the same `config_sha256`), else None (the
    defaults, a setting or the file have changed since: use its `config_yaml`)."""
    from emonav_drake.configs import load_setting
    from emonav_drake.params import dump_config, load_config
    from emonav_drake.provenance import sha256_bytes

    source = str(settings.get("config_source") or "")
    time_varying = source.endswith(" --time-varying")
    origin = source.removesuffix(" --time-varying")
    flag, _, value = origin.partition(" ")
    try:
        if flag == "--setting":
            cfg, flags = load_setting(value), ["--setting", value]
        elif flag == "--config":
            cfg, flags = load_config(value), ["--config", value]
        else:  # "defaults", "the default configuration"
            cfg, flags = load_config(), []
    except (OSError, ValueError, KeyError):  # ConfigError is a ValueError
        return None
    if time_varying:
        cfg.crowd.time_varying_emotions = True
        flags.append("--time-varying")
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
    return ["--planner", "policy", "--checkpoint", _shown_path(method["checkpoint"])]


def rerun_command(
    settings: dict, method: str, seed: int, run_files: dict[str, str] | None = None
) -> str:
    """The `emonav sim` command line that plays trial (`method`, `seed`) of the run again:
    planner (and checkpoint), seed, plant, and the configuration — the flags of its
    `config_source` if they still give it (`config_flags`), else `--config` of the file
    `run_files["config"]` (default `run_config.yaml`, see `write_run_files`); the emotion
    estimate from `run_files["estimate"]` (default `run_emotion_estimate.yaml`)."""
    files = run_files or {}
    argv = ["emonav", "sim", *_planner_flags(settings["methods"][method]), "--seed", str(seed)]
    if settings["plant"] != "lip":
        argv += ["--plant", settings["plant"]]
    flags = config_flags(settings)
    if flags is None:
        flags = ["--config", files.get("config", RUN_CONFIG_FILE)]
    argv += flags
    if settings.get("emotion_estimate_yaml") is not None:
        argv += ["--emotion-estimate", files.get("estimate", RUN_ESTIMATE_FILE)]
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
    """The failed trials of `methods` as text, per method: a count by outcome, one line
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
        by_outcome = Counter(f["outcome"] for f in mine)
        text = ", ".join(f"{o} {k}" for o, k in sorted(by_outcome.items(), key=lambda x: -x[1]))
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


def diagnosis_table(rows: list[dict]) -> str:
    """Markdown: failures by cause per method; on Digit, tracking errors before failures
    and before successes (median and 90th percentile over the last steps) — on a LIP run
    a line saying why they are skipped; whether the re-simulations reproduced the run."""
    methods = sorted({r["method"] for r in rows})
    lines = ["| method | failures | causes |", "|---|---|---|"]
    for m in methods:
        fails = [r for r in rows if r["method"] == m and r["outcome"] != "success"]
        causes = Counter(r["cause"] for r in fails)
        text = ", ".join(f"{c} {n}" for c, n in sorted(causes.items(), key=lambda x: -x[1]))
        lines.append(f"| {m} | {len(fails)} | {text or '—'} |")
    checked = [r for r in rows if "reproduced" in r]
    if checked:
        missed = [r for r in checked if not r["reproduced"]]
        lines.append("")
        if missed:
            lines.append(
                f"{len(missed)} of {len(checked)} re-simulated trials did not reproduce their "
                "recorded outcome and step count (the code or a checkpoint changed since the "
                "run): "
                + ", ".join(f"{r['method']} seed {r['seed']}" for r in missed[:10])
                + (", …" if len(missed) > 10 else "")
            )
        else:
            lines.append(
                f"All {len(checked)} re-simulated trials reproduced their recorded outcome "
                "and step count."
            )
    rows = [r for r in rows if r.get("tracking") is not None]
    if not rows:
        lines += [
            "",
            "Tracking errors (Digit against the planner's LIP model, before failures and "
            "successes): skipped — on a LIP run the robot is the planner's model.",
        ]
        return "\n".join(lines) + "\n"
    methods = sorted({r["method"] for r in rows})
    lines += [
        "",
        "| method | trials | LIP position error [cm] p50 / p90 | LIP heading error [mrad] "
        "p50 / p90 | model position [cm] p50 / p90 | model heading [mrad] p50 / p90 |",
        "|---|---|---|---|---|---|",
    ]
    for m in methods:
        for label, ok in (("failures", False), ("successes", True)):
            sel = [r for r in rows if r["method"] == m and (r["outcome"] == "success") == ok]
            if not sel:
                continue
            cells = []
            for key, scale in (
                ("lip_position", 100),
                ("lip_heading", 1000),
                ("model_position", 100),
                ("model_heading", 1000),
            ):
                v = np.concatenate([r["tracking"].get(key, []) for r in sel] or [[]]) * scale
                cells.append(
                    f"{np.percentile(v, 50):.1f} / {np.percentile(v, 90):.1f}" if v.size else "—"
                )
            lines.append(f"| {m} ({label}) | {len(sel)} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def _cause_order(cause: str) -> tuple[int, str]:
    order = ["collision: static", "collision: happy", "collision: neutral"]
    order += ["collision: negative", "timeout"]
    return (order.index(cause) if cause in order else len(order), cause)


def _cause_color(cause: str) -> tuple[float, float, float]:
    """The world's colours (`core.palette`): emotions as everywhere, static discs grey;
    timeouts purple, falls and anything else black."""
    from emonav_drake.core import palette
    from emonav_drake.params import EMOTION_NAMES

    kind = cause.removeprefix("collision: ")
    if kind in EMOTION_NAMES:
        return palette.EMOTION_RGB[EMOTION_NAMES.index(kind)]
    if kind == "static":
        return palette.STATIC_RGB
    if cause in palette.OUTCOME_RGB:
        return palette.OUTCOME_RGB[cause]
    return palette.INK_RGB


def plot_diagnosis(rows: list[dict]):
    """Causes of failure per method; on Digit, heading and position errors of the LIP
    prediction over the last steps, before failures and before successes."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from emonav_drake.core import palette

    methods = sorted({r["method"] for r in rows})
    causes = sorted({r["cause"] for r in rows if r["outcome"] != "success"}, key=_cause_order)
    tracked = any(r.get("tracking") is not None for r in rows)
    if not tracked:  # a LIP run: the causes only
        fig, axes = plt.subplots(1, 1, figsize=(5.5, 4.6), constrained_layout=True, squeeze=False)
        axes = axes[0]
    else:
        fig, axes = plt.subplots(1, 3, figsize=(15, 4.6), constrained_layout=True)
    ax = axes[0]
    bottom = np.zeros(len(methods))
    x = np.arange(len(methods))
    for c in causes:
        n = np.array(
            [sum(r["cause"] == c for r in rows if r["method"] == m) for m in methods], float
        )
        ax.bar(x, n, bottom=bottom, label=c, color=_cause_color(c), edgecolor=palette.PAPER_RGB)
        bottom += n
    ax.set_xticks(x, [m.replace("_", "_\n", 1) for m in methods])
    ax.set(ylabel="failed trials", title="causes of failure")
    if causes:
        ax.legend(fontsize=8)
    if not tracked:
        return fig
    rows = [r for r in rows if r.get("tracking") is not None]
    for ax, key, scale, unit in (
        (axes[1], "lip_heading", 1000, "mrad"),
        (axes[2], "lip_position", 100, "cm"),
    ):
        data, labels = [], []
        for m in methods:
            for label, ok in (("fail", False), ("success", True)):
                sel = [r for r in rows if r["method"] == m and (r["outcome"] == "success") == ok]
                v = np.concatenate([r["tracking"].get(key, []) for r in sel] or [[]]) * scale
                data.append(v)
                labels.append(f"{m.replace('_', '_' + chr(10), 1)}\n({label})")
        ax.boxplot(data, tick_labels=labels, showfliers=False)
        name = "heading" if "heading" in key else "position"
        ax.set(
            ylabel=f"{name} error per step [{unit}]",
            title=f"LIP prediction vs Digit, last steps: {name}",
        )
    return fig
