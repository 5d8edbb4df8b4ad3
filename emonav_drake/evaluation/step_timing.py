"""Which command does Digit walk in step k? Per-step regression on traced navigation.

Over every step k >= 2 of traced Digit episodes (`emonav calibrate collect` lines: the
robot at every planner instant t_k and the command held since t_{k-1}; step 0 is Digit's
stand, step 1 its first step) it fits

    heading change of step k  = a u_dtheta[k] + b u_dtheta[k-1]
    sagittal speed at t_{k+1} = c u_v[k] + d u_v[k-1] + e u_v[k-2]

by least squares, with standard errors, and the heading error during navigation
(heading at t_{k+1} minus heading at t_k plus u_dtheta[k]) as RMS. "In-step" walking has
a ≈ 1, b ≈ 0: the turn is walked in the step it was planned for (docs/walking.md).
"""

from __future__ import annotations

import dataclasses as dc
import json
import math
from collections.abc import Iterable
from pathlib import Path

import numpy as np


@dc.dataclass(frozen=True)
class StepTiming:
    """The fit (module docstring): coefficients and their standard errors.

    Attributes:
        episodes, steps: how many episodes and steps (k >= 2) were fitted.
        turn, turn_se: (a, b) of the heading change of step k.
        speed, speed_se: (c, d, e) of the speed at t_{k+1}.
        heading_rms: the heading error during navigation [rad].
    """

    episodes: int
    steps: int
    turn: tuple[float, float]
    turn_se: tuple[float, float]
    speed: tuple[float, float, float]
    speed_se: tuple[float, float, float]
    heading_rms: float

    def lines(self) -> list[str]:
        """The fit as three printable lines."""
        (a, b), (sa, sb) = self.turn, self.turn_se
        (c, d, e), (sc, sd, se) = self.speed, self.speed_se
        return [
            f"{self.episodes} episodes, {self.steps} steps (k >= 2)",
            f"heading change of step k = {a:.3f} (±{sa:.3f}) u_dtheta[k]"
            f" + {b:.3f} (±{sb:.3f}) u_dtheta[k-1]",
            f"speed at t_(k+1) = {c:.3f} (±{sc:.3f}) u_v[k] + {d:.3f} (±{sd:.3f}) u_v[k-1]"
            f" + {e:.3f} (±{se:.3f}) u_v[k-2]",
            "heading error during navigation (vs heading at t_k + u_dtheta[k]): "
            f"RMS {1000 * self.heading_rms:.1f} mrad",
        ]


def _fit(a: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    coef, *_ = np.linalg.lstsq(a, y, rcond=None)
    resid = y - a @ coef
    dof = max(len(y) - a.shape[1], 1)
    cov = (resid @ resid / dof) * np.linalg.inv(a.T @ a)
    return coef, np.sqrt(np.diag(cov))


def fit_step_timing(traces: Iterable[list[dict]]) -> StepTiming:
    """The fit over `traces` (one list of trace entries per episode: "robot" (x, y, θ, v)
    and "held" (u_v, u_Δθ) at every planner instant). `ValueError` with fewer than three
    steps to fit."""
    turn, speed, err = [], [], []
    episodes = 0
    for tr in traces:
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
    if len(turn) < 3:
        raise ValueError(f"{len(turn)} steps (k >= 2) in {episodes} episodes: too few to fit")
    t, s = np.array(turn), np.array(speed)
    ab, sab = _fit(t[:, :2], t[:, 2])
    cde, scde = _fit(s[:, :3], s[:, 3])
    return StepTiming(
        episodes,
        len(t),
        tuple(float(x) for x in ab),
        tuple(float(x) for x in sab),
        tuple(float(x) for x in cde),
        tuple(float(x) for x in scde),
        math.sqrt(float(np.mean(np.square(err)))),
    )


def read_traces(paths: Iterable[str | Path]) -> list[list[dict]]:
    """The episodes' traces of `emonav calibrate collect` files (one JSON line each)."""
    out = []
    for path in paths:
        with open(path, encoding="utf-8") as f:
            out += [json.loads(line)["trace"] for line in f if line.strip()]
    return out
