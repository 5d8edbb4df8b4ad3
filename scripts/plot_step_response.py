"""Figure: how Digit answers a navigation command, and what the LIP and the fitted model
predict, on the held-out episodes of the shipped calibration (docs/learning.md).

    python scripts/plot_step_response.py [--traces F] [--model M] [--out PNG]

Colours: `palette.py` (Digit black, the LIP reddish purple, the fitted model blue,
commands grey); a trace's method is named as in every figure (`method_label`).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from emonav_drake.palette import (  # noqa: E402
    COMMAND_RGB,
    FITTED_RGB,
    LIP_DELAYED_RGB,
    LIP_RGB,
    MEASURED_RGB,
)
from emonav_drake.params import EmoNavConfig  # noqa: E402
from emonav_drake.planners.legacy import method_label  # noqa: E402
from emonav_drake.planners.model_aware import DIGIT_RESPONSE, read_response  # noqa: E402
from emonav_drake.robot import step_response as sr  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument(
        "--traces", type=Path,
        default=ROOT / "benchmarks/results/digit_calibration/traces_v2.jsonl",
    )  # fmt: skip
    ap.add_argument("--model", type=Path, default=DIGIT_RESPONSE)
    ap.add_argument("--out", type=Path, default=ROOT / "docs/figures/digit_step_response.png")
    args = ap.parse_args()
    r = EmoNavConfig().robot
    report = json.loads(args.model.read_text())
    model = read_response(args.model)
    held = set(report["held_out"]["seeds"])
    lines = [json.loads(x) for x in args.traces.read_text().splitlines()]
    episode = next(h for h in lines if h["seed"] in held and h["method"] in ("sac", "policy"))
    data = sr.transitions_from_trace(episode["trace"], r.step_time)
    y = sr.outcome(data.states, data.next_states)
    k = np.arange(len(data)) + 2
    lip0 = y - sr.lip_errors(data, r.omega, r.step_time, 0)
    fitted = model.predict(data.states[:, 3], data.commands)

    fig, axes = plt.subplots(2, 2, figsize=(11, 6.5), constrained_layout=True)
    ax = axes[0, 0]
    ax.step(k, data.commands[:, 2, 1], where="post", color=COMMAND_RGB, label="command $u_{Δθ,k}$")
    ax.plot(k, y[:, 2], ".-", color=MEASURED_RGB, label="Digit: turn over step k")
    ax.plot(k, lip0[:, 2], "x--", color=LIP_RGB, label="LIP (Eq. 1): turns by $u_{Δθ,k}$")
    ax.plot(k, fitted[:, 2], "o:", color=FITTED_RGB, mfc="none", label="fitted model")
    ax.set(xlabel="walking step k", ylabel="heading change [rad]",
           title="turn: in the step it was planned for")  # fmt: skip
    ax.legend(fontsize=8)
    ax = axes[0, 1]
    ax.step(k, data.commands[:, 2, 0], where="post", color=COMMAND_RGB, label="command $u_{v,k}$")
    ax.plot(
        k, y[:, 3], ".-", color=MEASURED_RGB, label="Digit: step-averaged speed $\\bar v_{k+1}$"
    )
    ax.plot(k, lip0[:, 3], "x--", color=LIP_RGB, label="LIP: $u_{v,k}$ reached at $t_{k+1}$")
    ax.plot(k, fitted[:, 3], "o:", color=FITTED_RGB, mfc="none", label="fitted model")
    ax.set(xlabel="walking step k", ylabel="speed [m/s]", title="speed: one step late (the ALIP's)")
    ax.legend(fontsize=8)
    ax = axes[1, 0]
    names = ["forward [cm]", "lateral [cm]", "turn [0.01 rad]", "speed [cm/s]"]
    scale = np.array([100, 100, 100, 100])
    ho = report["held_out"]
    rows = [
        ("LIP (Eq. 1), $u_k$", ho["rms_lip"], LIP_RGB),
        ("LIP driven by $u_{k-1}$", ho["rms_lip_delay1"], LIP_DELAYED_RGB[0]),
        ("LIP driven by $u_{k-2}$", ho["rms_lip_delay2"], LIP_DELAYED_RGB[1]),
        ("fitted model", ho["rms_model"], FITTED_RGB),
    ]
    width = 0.2
    for i, (label, d, color) in enumerate(rows):
        ax.bar(np.arange(4) + (i - 1.5) * width, np.array(list(d.values())) * scale, width,
               label=label, color=color)  # fmt: skip
    ax.set_xticks(range(4), names)
    ax.set(ylabel="RMS error per step", title=f"held-out: {ho['episodes']} episodes, "
           f"{ho['transitions']} steps")  # fmt: skip
    ax.legend(fontsize=8)
    ax = axes[1, 1]
    all_data, _ = sr.Transitions.concatenate(
        [sr.transitions_from_trace(h["trace"], r.step_time, episode=i)
         for i, h in enumerate(lines) if h["seed"] in held]
    ), None  # fmt: skip
    e_lip = sr.lip_errors(all_data, r.omega, r.step_time, 0)[:, 2]
    e_fit = sr.evaluate(model, all_data)[:, 2]
    lim = max(0.05, float(np.percentile(np.abs(np.concatenate([e_lip, e_fit])), 99.5)))
    bins = np.linspace(-lim, lim, 41)
    ax.hist(e_lip, bins, color=LIP_RGB, alpha=0.6, label="LIP (Eq. 1)")
    ax.hist(e_fit, bins, color=FITTED_RGB, alpha=0.6, label="fitted model")
    ax.set(xlabel="turn error per step [rad]", ylabel="steps", title="held-out turn errors")
    ax.legend(fontsize=8)
    fig.suptitle(
        f"Digit's response to navigation commands ({method_label(episode['method'])} "
        f"episode, seed "
        f"{episode['seed']}, held out of the fit)"
    )
    args.out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(args.out, dpi=110)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
