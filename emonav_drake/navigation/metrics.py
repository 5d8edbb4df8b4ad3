"""Episode bookkeeping and the paper's evaluation metrics (§IV-D, Tables II–III).

* SR: fraction of episodes that reach the goal without collision or timeout;
  collision and timeout rates likewise;
* NT: navigation time [s] over successful episodes, mean ± std;
* DT: walking steps spent inside any discomfort zone (static or pedestrian), summed;
* IDT: the same per kind, [static; happy, neutral, negative] — a step inside the zones
  of two negative pedestrians counts once for "negative";
* path length [m] and the smallest robot–pedestrian centre distance [m];
* the field's metrics (`navigation/social_metrics.py`, docs/metrics.md): path irregularity,
  jerk of the commanded motion, smallest pedestrian clearance, share of steps with a low
  time to collision, intrusion ratio and clearance during intrusions. They are measured
  when every step of the episode was added with its `StepMotion`; a record without them
  (one written before they existed) holds None: "not measured", shown as n/a.
"""

from __future__ import annotations

import dataclasses as dc
import math
from collections.abc import Sequence

import numpy as np

from emonav_drake.navigation.reward import StepEvaluation
from emonav_drake.navigation.social_metrics import (
    SOCIAL_FIELDS,
    SUPPORT,
    TTC_THRESHOLD,
    SocialMetrics,
    StepMotion,
)

SUCCESS, COLLISION, TIMEOUT, FALL = "success", "collision", "timeout", "fall"
# The global route layer found no route left to the goal (a doorway closed off mid-episode).
NO_ROUTE = "no_route"


@dc.dataclass
class EpisodeRecord:
    """The outcome and social metrics of one episode (the `--json` of `emonav sim`)."""

    outcome: str = TIMEOUT  # success | collision | timeout | fall (full-order) | no_route
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
    # The field's metrics (navigation/social_metrics.py); None: not measured (or undefined).
    path_irregularity: float | None = None  # [rad/m]
    jerk_mean: float | None = None  # [m/s³], of the commanded velocity
    min_ped_clearance: float | None = None  # [m], surface to surface
    low_ttc_ratio: float | None = None  # share of steps with a time to collision < TTC_THRESHOLD
    intrusion_ratio: float | None = None  # share of steps closer than INTRUSION_DISTANCE
    intrusion_clearance: float | None = None  # [m], mean smallest clearance in those steps

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
        # The field's metrics: started by a first step with its motion, dropped for good
        # (None, `_unmeasured`) when a step comes without one.
        self.social: SocialMetrics | None = None
        self._unmeasured = False

    def add(
        self,
        ev: StepEvaluation,
        step_length: float,
        motion: StepMotion | None = None,
        no_route: bool = False,
    ) -> str | None:
        """Record one step; return the outcome if the episode ended with it, else None.

        `motion` (the robot at both foot switches, the crowd, the command) feeds the
        field's metrics; without it they stay None for the whole episode. The paper's
        metrics do not read it. `no_route`: the global route layer has no route left to
        the goal; the episode ends with `NO_ROUTE` unless the step collided or reached
        the goal.
        """
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
        self._add_social(motion)
        if ev.collision:
            r.outcome = COLLISION
            r.collided_with = ev.collided_with
        elif ev.reached_goal:
            r.outcome = SUCCESS
        elif no_route:
            r.outcome = NO_ROUTE
        elif r.steps >= self.max_steps:
            r.outcome = TIMEOUT
        else:
            return None
        self.done = True
        return r.outcome

    def _add_social(self, motion: StepMotion | None) -> None:
        if motion is not None and self.social is None and not self._unmeasured:
            if self.record.steps == 1:  # the episode's first step
                self.social = SocialMetrics(self.step_time)
            else:  # its earlier steps came without motion
                self._unmeasured = True
        if motion is None or self._unmeasured:
            self._unmeasured = True
            self.social = None
            values = dict.fromkeys(SOCIAL_FIELDS)
        else:
            self.social.add(motion)
            values = self.social.values()
        for name, value in values.items():
            setattr(self.record, name, value)

    def social_state(self) -> dict | None:
        """The field metrics' accumulator as plain data (None: not measured)."""
        return None if self.social is None else self.social.to_plain()

    def load_social_state(self, state: dict | None) -> None:
        """Restore `social_state()`; None after steps means the metrics are not measured
        (a state saved before they existed)."""
        self.social = None if state is None else SocialMetrics.from_plain(state)
        self._unmeasured = state is None and self.record.steps > 0
        if self._unmeasured:
            for name in SOCIAL_FIELDS:
                setattr(self.record, name, None)


# Below this many values a t interval says little (from 2 values its half-width is
# 12.7 standard errors): the mean is given without one.
MIN_INTERVAL_N = 5


def mean_interval(
    values: list[float], support: tuple[float | None, float | None] = (None, None)
) -> tuple[float | None, list[float] | None]:
    """The mean and its 95 % Student-t interval [lo, hi] (None below `MIN_INTERVAL_N`
    values; both None for no value), clipped to the values' `support` (a share cannot
    fall below 0)."""
    x = np.asarray(values, dtype=float)
    if x.size == 0:
        return None, None
    mean = float(x.mean())
    if x.size < MIN_INTERVAL_N:
        return mean, None
    from scipy.stats import t

    half = float(t.ppf(0.975, x.size - 1) * x.std(ddof=1) / math.sqrt(x.size))
    lo, hi = mean - half, mean + half
    if support[0] is not None:
        lo = max(lo, support[0])
    if support[1] is not None:
        hi = min(hi, support[1])
    return mean, [lo, hi]


def summarize(records: list[EpisodeRecord]) -> dict:
    """SR, collision/timeout rates, NT (mean ± std over successes), DT, IDT and more.

    The field's metrics: for each `SOCIAL_FIELDS` name f, `f_mean` over the episodes
    that measured it, `f_ci` its 95 % t interval (clipped to the metric's `SUPPORT`) and
    `f_n` their number (0: n/a).
    """
    n = len(records)
    if n == 0:
        raise ValueError("no episodes to summarise")
    outcomes = [r.outcome for r in records]
    nt = np.array([r.nav_time for r in records if r.outcome == SUCCESS])
    ped = [r.min_ped_distance for r in records if not math.isinf(r.min_ped_distance)]
    out = {
        "episodes": n,
        "SR": outcomes.count(SUCCESS) / n,
        "collision_rate": outcomes.count(COLLISION) / n,
        "timeout_rate": outcomes.count(TIMEOUT) / n,
        "fall_rate": outcomes.count(FALL) / n,
        "no_route_rate": outcomes.count(NO_ROUTE) / n,
        "NT_mean": float(nt.mean()) if nt.size else None,
        "NT_std": float(nt.std()) if nt.size else None,
        "DT": int(sum(r.discomfort_steps for r in records)),
        "IDT": [int(sum(r.idt[i] for r in records)) for i in range(4)],
        "path_length_mean": float(np.mean([r.path_length for r in records])),
        "min_ped_distance": float(min(ped)) if ped else None,
    }
    for name in SOCIAL_FIELDS:
        values = [v for r in records if (v := getattr(r, name)) is not None]
        mean, ci = mean_interval(values, SUPPORT[name])
        out |= {f"{name}_mean": mean, f"{name}_ci": ci, f"{name}_n": len(values)}
    return out


IDT_KINDS = ("static", "happy", "neutral", "negative")  # the order of every IDT list


def format_idt(idt: Sequence[int]) -> str:
    """IDT for people, each count named: "IDT [static 11; happy 0, neutral 0, negative 4]"
    (the paper's [static; happy, neutral, negative] with the names written in)."""
    named = [f"{k} {int(v)}" for k, v in zip(IDT_KINDS, idt, strict=True)]
    return f"IDT [{named[0]}; {', '.join(named[1:])}]"


def format_summary(s: dict) -> str:
    """One line in the paper's notation, then (where measured) the field's metrics: means
    per episode with their 95 % t intervals."""
    nt = "n/a" if s["NT_mean"] is None else f"{s['NT_mean']:.2f} ± {s['NT_std']:.2f}"
    idt = s["IDT"]
    fall = f"fall {s['fall_rate']:.3f}  " if s.get("fall_rate") else ""
    line = (
        f"SR {s['SR']:.3f}  collision {s['collision_rate']:.3f}  timeout "
        f"{s['timeout_rate']:.3f}  {fall}NT {nt} s  DT {s['DT']}  "
        f"{format_idt(idt)}  ({s['episodes']} episodes)"
    )
    if not any(s.get(f"{name}_n") for name in SOCIAL_FIELDS):
        return line

    def mean(name: str, digits: int, unit: str = "") -> str:
        m, ci = s.get(f"{name}_mean"), s.get(f"{name}_ci")
        if m is None:
            return "n/a"
        text = f"{m:.{digits}f}"
        if ci is not None:
            text += f" [{ci[0]:.{digits}f}, {ci[1]:.{digits}f}]"
        return f"{text} {unit}" if unit else text

    return (
        f"{line}  |  irregularity {mean('path_irregularity', 3, 'rad/m')}  jerk "
        f"{mean('jerk_mean', 3, 'm/s³')}  min clearance {mean('min_ped_clearance', 2, 'm')}  "
        f"TTC < {TTC_THRESHOLD:g} s {mean('low_ttc_ratio', 3)}  intrusion "
        f"{mean('intrusion_ratio', 3)} (clearance {mean('intrusion_clearance', 2, 'm')})  "
        "(means per episode, 95 % t intervals)"
    )


def record_from_json(d: dict) -> EpisodeRecord:
    """An `EpisodeRecord` back from its `to_json()` (null distance → inf). A record
    written before the field's metrics existed lacks them: they read as None (not
    measured)."""
    d = dict(d)
    if d.get("min_ped_distance") is None:
        d["min_ped_distance"] = math.inf
    return EpisodeRecord(**d)
