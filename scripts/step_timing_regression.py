"""Which command does Digit walk in step k? Per-step regression on traced navigation.

Reads trace files of `emonav calibrate collect` (one JSON line per Digit episode, the
robot at every planner instant t_k and the command held since t_{k-1}) and fits, over
every step k >= 2 of every episode (step 0 is Digit's stand, step 1 its first step):

    heading change of step k  = a u_dtheta[k] + b u_dtheta[k-1]
    sagittal speed at t_{k+1} = c u_v[k] + d u_v[k-1] + e u_v[k-2]

and prints the coefficients with their standard errors, and the heading error during
navigation (measured heading at t_{k+1} minus heading at t_k plus u_dtheta[k]) as RMS.

    python scripts/step_timing_regression.py TRACES.jsonl [...]
"""

from __future__ import annotations

import argparse
import json
import math

import numpy as np


def _fit(a: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    coef, *_ = np.linalg.lstsq(a, y, rcond=None)
    resid = y - a @ coef
    dof = max(len(y) - a.shape[1], 1)
    cov = (resid @ resid / dof) * np.linalg.inv(a.T @ a)
    return coef, np.sqrt(np.diag(cov))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("traces", nargs="+")
    args = ap.parse_args()
    turn, speed, err = [], [], []
    episodes = 0
    for path in args.traces:
        with open(path, encoding="utf-8") as f:
            for line in f:
                tr = json.loads(line)["trace"]
                episodes += 1
                th = np.unwrap([e["robot"][2] for e in tr])
                v = [e["robot"][3] for e in tr]
                u = [e["held"] for e in tr]  # u[j] = command held since t_{j-1}
                for k in range(2, len(tr) - 1):
                    uk, uk1, uk2 = u[k + 1], u[k], u[k - 1]
                    d = th[k + 1] - th[k]
                    turn.append((uk[1], uk1[1], d))
                    speed.append((uk[0], uk1[0], uk2[0], v[k + 1]))
                    err.append(d - uk[1])
    t = np.array(turn)
    s = np.array(speed)
    (a, b), (sa, sb) = _fit(t[:, :2], t[:, 2])
    (c, d, e), (sc, sd, se) = _fit(s[:, :3], s[:, 3])
    rms = math.sqrt(float(np.mean(np.square(err))))
    print(f"{episodes} episodes, {len(t)} steps (k >= 2)")
    print(
        f"heading change of step k = {a:.3f} (±{sa:.3f}) u_dtheta[k]"
        f" + {b:.3f} (±{sb:.3f}) u_dtheta[k-1]"
    )
    print(
        f"speed at t_(k+1) = {c:.3f} (±{sc:.3f}) u_v[k] + {d:.3f} (±{sd:.3f}) u_v[k-1]"
        f" + {e:.3f} (±{se:.3f}) u_v[k-2]"
    )
    print(
        "heading error during navigation (vs heading at t_k + u_dtheta[k]): "
        f"RMS {1000 * rms:.1f} mrad"
    )


if __name__ == "__main__":
    main()
