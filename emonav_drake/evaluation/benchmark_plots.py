"""Figures of a benchmark run (`notebooks/benchmark.ipynb`): rates with their 95 %
intervals and the trajectories of chosen trials.

* `plot_summary(trials, methods, labels)`: SR per method with its Wilson interval; DT and
  IDT per trial (mean over the trials with a 95 % Student-t interval of the mean).
* `plot_trajectory(ax, scenario, trace, config)`: from an episode's `EpisodeTrace`
  (`TrialRunner.replay`, either plant), the robot's path, every pedestrian's
  path coloured by its emotion at each step (a time-varying emotion changes colour along
  the path), the static discs with their discomfort rings, start and goal.
* `run_labels(settings)`: the name each method of a run is shown under (the LIP-trained
  policy is "emobipednav", also in old runs that call it "policy" or "sac":
  `method_label`).

Colours: the shared palette (`palette.py`): the scene's roles as in every view, the
methods `palette.METHOD_RGB` (never an emotion's colour).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from emonav_drake import palette
from emonav_drake.evaluation import tables
from emonav_drake.navigation.episode_trace import EpisodeTrace
from emonav_drake.palette import (
    EMOTION_RGB,
    GOAL_RADIUS_RGB,
    GOAL_RGB,
    INK_RGB,
    PAPER_RGB,
    ROBOT_RGB,
    STATIC_RGB,
)
from emonav_drake.params import EMOTION_NAMES, EmoNavConfig
from emonav_drake.planners.legacy import method_label

EMOTION_COLORS = dict(zip(EMOTION_NAMES, EMOTION_RGB, strict=True))  # the shared palette
IDT_LABELS = ("static", "happy", "neutral", "negative")


def run_labels(settings: dict) -> dict[str, str]:
    """Method → the label a figure shows for it (`method_label`, judged by the
    method's checkpoint in the run's `settings.json`); a label two methods would share
    leaves both under their own names."""
    methods = settings.get("methods", {})
    labels = {
        m: method_label(m, (methods.get(m) or {}).get("checkpoint")) for m in settings["planners"]
    }
    taken = list(labels.values())
    return {m: lab if taken.count(lab) == 1 else m for m, lab in labels.items()}


def mean_interval(values: Sequence[float]) -> tuple[float, float]:
    """Mean and the half width of its 95 % Student-t interval (0 for fewer than 2 values)."""
    x = np.asarray(values, dtype=float)
    if x.size < 2:
        return float(x.mean()) if x.size else math.nan, 0.0
    from scipy.stats import t

    half = t.ppf(0.975, x.size - 1) * x.std(ddof=1) / math.sqrt(x.size)
    return float(x.mean()), float(half)


def plot_summary(
    trials: Sequence[dict],
    methods: Sequence[str] | None = None,
    labels: dict[str, str] | None = None,
):
    """A figure with SR (Wilson 95 %), DT per trial and IDT per trial (t 95 %) by method.

    Args:
        trials: the run's trials (`load_run`).
        methods: the methods to show, in order (default: all, in the trials' order).
        labels: method → shown name (`run_labels`); default `method_label`.
    """
    import matplotlib.pyplot as plt

    summary = tables.summarize_methods(trials, methods)
    names = list(summary)
    shown = [(labels or {}).get(m) or method_label(m) for m in names]
    fig, axes = plt.subplots(1, 3, figsize=(14.5, 3.8), gridspec_kw={"width_ratios": [1, 1, 2]})
    x = np.arange(len(names))
    colors = palette.method_colours(shown)

    sr = np.array([summary[m]["SR"] for m in names])
    ci = np.array([summary[m]["SR_ci"] for m in names])
    ax = axes[0]
    ax.bar(x, sr, color=colors)
    ax.errorbar(x, sr, yerr=[sr - ci[:, 0], ci[:, 1] - sr], fmt="none", ecolor=INK_RGB, capsize=4)
    counts = {summary[m]["episodes"] for m in names}
    if len(counts) == 1:  # one trial count: said once, in the title
        ax.set_xticks(x, shown)
        ax.set_title(f"SR (95 % Wilson interval, n = {counts.pop()} each)")
    else:
        ax.set_xticks(
            x, [f"{s}\n(n={summary[m]['episodes']})" for m, s in zip(names, shown, strict=True)]
        )
        ax.set_title("SR (95 % Wilson interval)")
    ax.set_ylim(0, 1.05)
    ax.set_ylabel("success rate")

    per = {m: [t for t in trials if t["method"] == m] for m in names}
    ax = axes[1]
    dt = [mean_interval([t["record"]["discomfort_steps"] for t in per[m]]) for m in names]
    ax.bar(x, [d[0] for d in dt], color=colors)
    ax.errorbar(
        x, [d[0] for d in dt], yerr=[d[1] for d in dt], fmt="none", ecolor=INK_RGB, capsize=4
    )
    ax.set_xticks(x, shown)
    if len(names) > 4:  # many methods: slanted names stay apart
        for a in axes[:2]:
            a.tick_params(axis="x", labelrotation=35)
            for label in a.get_xticklabels():
                label.set_horizontalalignment("right")
                label.set_rotation_mode("anchor")
    ax.set_ylabel("discomfort steps per trial")
    ax.set_title("DT per trial (95 % t interval)")

    ax = axes[2]
    width = 0.8 / len(names)
    for j, m in enumerate(names):
        idt = [mean_interval([t["record"]["idt"][i] for t in per[m]]) for i in range(4)]
        pos = np.arange(4) + (j - (len(names) - 1) / 2) * width
        ax.bar(pos, [v[0] for v in idt], width, color=colors[j], label=shown[j])
        ax.errorbar(
            pos,
            [v[0] for v in idt],
            yerr=[v[1] for v in idt],
            fmt="none",
            ecolor=INK_RGB,
            capsize=3,
        )
    ax.set_xticks(np.arange(4), IDT_LABELS)
    ax.set_ylabel("steps per trial")
    ax.set_title("IDT per trial [static; happy, neutral, negative] (95 % t interval)")
    # beside the axes, never over the bars
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, frameon=False)
    for ax in axes:
        ax.set_ylim(bottom=0)
        ax.grid(axis="y", alpha=0.3)
    fig.tight_layout()
    return fig


def _emotion_at(ped, k: int, step_time: float, period: float) -> str:
    """A pedestrian's emotion during walking step k (its schedule, or its constant one)."""
    if not ped.emotion_schedule:
        return ped.emotion
    i = min(int(k * step_time / period + 1e-9), len(ped.emotion_schedule) - 1)
    return ped.emotion_schedule[i]


def plot_trajectory(
    ax,
    scenario,
    trace: EpisodeTrace,
    config: EmoNavConfig,
    title: str = "",
    goal_radius: float | None = None,
) -> None:
    """Draw one episode from its `EpisodeTrace` (world frame, metres): robot path,
    pedestrians coloured by emotion, discs, start, goal (with its goal radius:
    `goal_radius`, default `config.episode.eval_goal_radius`)."""
    from matplotlib.collections import LineCollection
    from matplotlib.lines import Line2D
    from matplotlib.patches import Circle

    robot = np.array([r[:2] for r in trace.robot])
    peds = np.array(trace.pedestrians)  # (K + 1, P, 2)
    T = config.robot.step_time
    rd = config.reward
    for ob in scenario.obstacles:
        c, r = ob.center, ob.radius
        ax.add_patch(Circle(c, r, color=STATIC_RGB, zorder=2))
        ax.add_patch(
            Circle(
                c, r + rd.static_discomfort, fill=False, ls="--", ec=STATIC_RGB, lw=0.8, zorder=2
            )
        )
    dist = dict(zip(EMOTION_NAMES, rd.emotion_distances(), strict=True))
    rp = config.crowd.pedestrian_radius
    for i, ped in enumerate(scenario.pedestrians):
        path = peds[:, i, :]
        colors = [
            EMOTION_COLORS[_emotion_at(ped, k, T, scenario.emotion_change_period)]
            for k in range(len(path) - 1)
        ]
        segments = np.stack([path[:-1], path[1:]], axis=1)
        ax.add_collection(LineCollection(segments, colors=colors, lw=1.8, zorder=3))
        end = _emotion_at(ped, len(path) - 1, T, scenario.emotion_change_period)
        ax.add_patch(Circle(path[-1], rp, fc="none", ec=EMOTION_COLORS[end], lw=1.5, zorder=4))
        ax.add_patch(
            Circle(path[-1], rp + dist[end], fc="none", ec=EMOTION_COLORS[end], ls=":", zorder=4)
        )
        ax.plot(*path[0], "o", color=EMOTION_COLORS[ped.emotion], ms=4, zorder=4)
    ax.plot(*robot.T, color=ROBOT_RGB, lw=2.2, zorder=5)
    ax.add_patch(Circle(robot[-1], config.robot.radius, fc="none", ec=ROBOT_RGB, lw=1.5, zorder=5))
    ax.plot(*scenario.robot_start, "s", color=ROBOT_RGB, mec=INK_RGB, ms=7, zorder=6)
    radius = config.episode.eval_goal_radius if goal_radius is None else goal_radius
    ax.add_patch(
        Circle(scenario.robot_goal, radius, fill=False, ls=":", ec=GOAL_RADIUS_RGB, zorder=6)
    )
    ax.plot(*scenario.robot_goal, "*", color=GOAL_RGB, mec=PAPER_RGB, mew=0.8, ms=15, zorder=7)
    handles = [Line2D([], [], color=ROBOT_RGB, lw=2.2, label="robot")]
    handles += [Line2D([], [], color=c, lw=2, label=e) for e, c in EMOTION_COLORS.items()]
    handles.append(Line2D([], [], color=STATIC_RGB, marker="o", ls="none", label="static disc"))
    handles.append(Line2D([], [], color=GOAL_RGB, marker="*", ms=9, ls="none", label="goal"))
    ax.legend(handles=handles, loc="lower left", fontsize=7, ncol=2)
    ax.set_aspect("equal")
    ax.set_xlim(-5.5, 5.5)
    ax.set_ylim(-5, 5)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.grid(alpha=0.3)
    if title:
        ax.set_title(title, fontsize=9)
