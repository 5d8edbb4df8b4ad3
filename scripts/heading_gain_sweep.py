"""Heading error during navigation against the torso-yaw gains (hip-yaw K_D, Λ orientation).

Runs traced DWA navigation episodes on the full-order Digit (`calibration.collect_traces`,
no random commands) for one gain setting and prints the per-step heading error RMS
(heading change of step k minus u_Δθ,k, steps k >= 2, as `step_timing_regression.py`)
and the outcomes. Tuning seeds: keep them apart from the seeds the result is measured on.

    python scripts/heading_gain_sweep.py --kd-hip-yaw 40 --out /tmp/kd40.jsonl
"""

from __future__ import annotations

import argparse
import json
from collections import Counter

import numpy as np

from emonav_drake.learning.calibration import collect_traces
from emonav_drake.params import EmoNavConfig


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--kd-hip-yaw", type=float, default=None, help="[N·m·s/rad]")
    ap.add_argument("--lambda-orientation", type=float, default=None, help="[1/s]")
    ap.add_argument("--first-seed", type=int, default=3250000)
    ap.add_argument("--episodes", type=int, default=10)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--out", required=True, help="trace file (JSONL), extended")
    args = ap.parse_args()
    cfg = EmoNavConfig()
    if args.kd_hip_yaw is not None:
        cfg.walking.kd_leg[1] = args.kd_hip_yaw
    if args.lambda_orientation is not None:
        cfg.walking.lambda_orientation = args.lambda_orientation
    collect_traces(args.out, "dwa", args.episodes, args.first_seed, 0.0, args.workers, config=cfg)
    errors, outcomes = [], []
    with open(args.out, encoding="utf-8") as f:
        for line in f:
            d = json.loads(line)
            outcomes.append(d["outcome"])
            th = np.unwrap([e["robot"][2] for e in d["trace"]])
            u = [e["held"][1] for e in d["trace"]]
            errors += [th[k + 1] - th[k] - u[k + 1] for k in range(2, len(th) - 1)]
    rms = float(np.sqrt(np.mean(np.square(errors))))
    print(
        f"kd_hip_yaw {cfg.walking.kd_leg[1]:g}, lambda_orientation "
        f"{cfg.walking.lambda_orientation:g}: heading error RMS {1000 * rms:.2f} mrad over "
        f"{len(errors)} steps; outcomes {dict(Counter(outcomes))}"
    )


if __name__ == "__main__":
    main()
