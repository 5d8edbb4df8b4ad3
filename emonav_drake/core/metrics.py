"""Episode bookkeeping and the paper's evaluation metrics (§IV-D, Tables II–III).

* SR: fraction of episodes that reach the goal without collision or timeout;
  collision and timeout rates likewise;
* NT: navigation time [s] over successful episodes, mean ± std;
* DT: walking steps spent inside any discomfort zone (static or pedestrian), summed;
* IDT: the same per kind, [static; happy, neutral, negative] — a step inside the zones
  of two negative pedestrians counts once for "negative";
* path length [m] and the smallest robot–pedestrian centre distance [m].
"""

from __future__ import annotations

import dataclasses as dc
import math

import numpy as np

from emonav_drake.core.reward import StepEvaluation

SUCCESS, COLLISION, TIMEOUT, FALL = "success", "collision", "timeout", "fall"


@dc.dataclass
class EpisodeRecord:
    """The outcome and social metrics of one episode (the `--json` of `emonav sim`)."""

    outcome: str = TIMEOUT  # success | collision | timeout | fall (full-order robot)
    steps: int = 0
    nav_time: float = 0.0  # [s]
    path_length: float = 0.0  # [m]
    min_ped_distance: float = math.inf  # [m], centre to centre
    discomfort_steps: int = 0
    idt: list[int] = dc.field(default_factory=lambda: [0, 0, 0, 0])
    total_reward: float = 0.0
    seed: int = -1
    fall_reason: str = ""  # why the full-order robot fell (outcome "fall" only)
    collided_with: str = ""  # outcome "collision": "static" or the pedestrian's emotion

    def to_json(self) -> dict:
        d = dc.asdict(self)
        d["min_ped_distance"] = None if math.isinf(self.min_ped_distance) else self.min_ped_distance
        for key in ("fall_reason", "collided_with"):
            if not d[key]:
                del d[key]
        return d


class EpisodeTracker:
    """Accumulates `StepEvaluation`s into an `EpisodeRecord` and decides termination.

    Args:
        max_steps: the time limit in walking steps (a timeout is not terminal for
            bootstrapping: the Gymnasium env reports it as `truncated`).
        step_time: T [s].
        seed: stored in the record.
    """

    def __init__(self, max_steps: int, step_time: float, seed: int = -1) -> None:
        self.max_steps = max_steps
        self.step_time = step_time
        self.record = EpisodeRecord(seed=seed)
        self.done = False

    def add(self, ev: StepEvaluation, step_length: float) -> str | None:
        """Record one step; return the outcome if the episode ended with it, else None."""
        if self.done:
            raise RuntimeError("the episode has already ended")
        r = self.record
        r.steps += 1
        r.nav_time = r.steps * self.step_time
        r.path_length += step_length
        r.min_ped_distance = min(r.min_ped_distance, ev.min_ped_distance)
        r.discomfort_steps += int(ev.in_discomfort)
        r.idt = [a + b for a, b in zip(r.idt, ev.idt, strict=True)]
        r.total_reward += ev.reward
        if ev.collision:
            r.outcome = COLLISION
            r.collided_with = ev.collided_with
        elif ev.reached_goal:
            r.outcome = SUCCESS
        elif r.steps >= self.max_steps:
            r.outcome = TIMEOUT
        else:
            return None
        self.done = True
        return r.outcome


def summarize(records: list[EpisodeRecord]) -> dict:
    """SR, collision/timeout rates, NT (mean ± std over successes), DT, IDT and more."""
    n = len(records)
    if n == 0:
        raise ValueError("no episodes to summarise")
    outcomes = [r.outcome for r in records]
    nt = np.array([r.nav_time for r in records if r.outcome == SUCCESS])
    ped = [r.min_ped_distance for r in records if not math.isinf(r.min_ped_distance)]
    return {
        "episodes": n,
        "SR": outcomes.count(SUCCESS) / n,
        "collision_rate": outcomes.count(COLLISION) / n,
        "timeout_rate": outcomes.count(TIMEOUT) / n,
        "fall_rate": outcomes.count(FALL) / n,
        "NT_mean": float(nt.mean()) if nt.size else None,
        "NT_std": float(nt.std()) if nt.size else None,
        "DT": int(sum(r.discomfort_steps for r in records)),
        "IDT": [int(sum(r.idt[i] for r in records)) for i in range(4)],
        "path_length_mean": float(np.mean([r.path_length for r in records])),
        "min_ped_distance": float(min(ped)) if ped else None,
    }


def format_summary(s: dict) -> str:
    """One line in the paper's notation."""
    nt = "n/a" if s["NT_mean"] is None else f"{s['NT_mean']:.2f} ± {s['NT_std']:.2f}"
    idt = s["IDT"]
    fall = f"fall {s['fall_rate']:.3f}  " if s.get("fall_rate") else ""
    return (
        f"SR {s['SR']:.3f}  collision {s['collision_rate']:.3f}  timeout "
        f"{s['timeout_rate']:.3f}  {fall}NT {nt} s  DT {s['DT']}  "
        f"IDT [{idt[0]}; {idt[1]}, {idt[2]}, {idt[3]}]  ({s['episodes']} episodes)"
    )


def record_from_json(d: dict) -> EpisodeRecord:
    """An `EpisodeRecord` back from its `to_json()` (null distance → inf)."""
    d = dict(d)
    if d.get("min_ped_distance") is None:
        d["min_ped_distance"] = math.inf
    return EpisodeRecord(**d)
