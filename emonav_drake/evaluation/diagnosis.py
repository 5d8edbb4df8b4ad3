"""Why a benchmark run's trials fail: the failing trials, their causes, and on Digit
the tracking before them.

    emonav diagnose benchmarks/results/digit_table2 [--methods policy] [--last 5]
                    --out runs/diagnosis
    emonav diagnose benchmarks/results/lip_table2 --failures

`evaluation/failures.py` (`--failures`) lists, per method, the failed trials of a run
from its `trials.jsonl` alone (no simulation), with the `emonav sim` command that plays
each again.

`diagnose_run` (`--out`) simulates every failed trial (outcome collision, timeout or
fall) again from its seed (the benchmark is deterministic: the same record, checked), on
the run's plant. On a LIP run that gives each failure its cause (the records of runs
made before `collided_with` was recorded do not say what a collision hit). On a run of a
plant with a step-response model (`Plant.response`: Digit) it does so with the episode's
`EpisodeTrace` (the robot and the held command at every planner instant), and each
failure gets:

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

from collections import Counter
from pathlib import Path

import numpy as np

from emonav_drake.evaluation.failures import failure_cause, format_failures, write_run_files
from emonav_drake.navigation.episode_trace import EpisodeTrace
from emonav_drake.params import ConfigError, EmoNavConfig
from emonav_drake.robot import step_response as sr


def tracking_errors(
    trace: EpisodeTrace | list[dict], config: EmoNavConfig, last: int, model=None
) -> dict:
    """Per-step errors over the last `last` transitions of a trace (an `EpisodeTrace` or
    its row dicts): position [m] and heading [rad] of the LIP driven by u_k (and of
    `model`, if given) against the robot."""
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
    """Simulate one trial of `runner`'s run again: its cause, and on a plant with a
    response model (`Plant.response`, Digit's) the tracking errors over the last `last`
    steps, from the episode's `EpisodeTrace` (`tracking` is None on another plant, or
    when the plant keeps no trace)."""
    from emonav_drake.diagrams.plants import plant_named

    plant = runner.spec.plant
    if plant_named(plant).response is not None:
        _, rec, trace = runner.replay(method, seed)
        record = rec.to_json()
        cfg = runner.planner(method)[1]
        tracking = None if trace is None else tracking_errors(trace, cfg, last, model)
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
    from emonav_drake.atomic_io import write_json, write_text_atomic
    from emonav_drake.diagrams.plants import plant_named
    from emonav_drake.diagrams.trials import TrialRunner
    from emonav_drake.evaluation.run_directory import SETTINGS_FILE, load_run
    from emonav_drake.evaluation.run_settings import spec_from_settings
    from emonav_drake.progress import progress_bar

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
    robot = plant_named(settings["plant"], flag=f"{where}: plant")
    model = None
    if robot.response is not None:
        from emonav_drake.planners.model_aware import load_response

        model = load_response(robot.response)
    else:  # successes are the reference of the tracking comparison only
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
    for t in progress_bar(todo, desc="re-simulating", unit="trial", enabled=progress):
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
    order = ["collision: static", "collision: wall", "collision: happy", "collision: neutral"]
    order += ["collision: negative", "timeout"]
    return (order.index(cause) if cause in order else len(order), cause)


def _cause_color(cause: str) -> tuple[float, float, float]:
    """The world's colours (`palette`): emotions as everywhere, static discs and walls grey;
    timeouts purple, falls and anything else black."""
    from emonav_drake import palette
    from emonav_drake.params import EMOTION_NAMES

    kind = cause.removeprefix("collision: ")
    if kind in EMOTION_NAMES:
        return palette.EMOTION_RGB[EMOTION_NAMES.index(kind)]
    if kind in ("static", "wall"):
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

    from emonav_drake import palette

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
