"""Whether one line of a benchmark's `trials.jsonl` is a valid trial: `check_trial`.

Each record is checked in itself (its fields, a known outcome, counts, times and distances
in range, DT against IDT, the field's social metrics) and, given the run's configuration,
against the episode's bookkeeping (`nav_time` is `steps` × `robot.step_time`, a timeout
ends at `episode.max_steps`, …). `run_directory.read_trials` checks every line it reads
with it.
"""

from __future__ import annotations

import dataclasses as dc
import math
from typing import TYPE_CHECKING, Any

from emonav_drake.diagrams.plants import PLANTS
from emonav_drake.navigation.metrics import (
    COLLISION,
    FALL,
    NO_ROUTE,
    SUCCESS,
    TIMEOUT,
    EpisodeRecord,
)
from emonav_drake.navigation.social_metrics import check_social_fields
from emonav_drake.scenarios.scenario import MAX_SEED

if TYPE_CHECKING:
    from emonav_drake.params import EmoNavConfig

OUTCOMES = (SUCCESS, COLLISION, TIMEOUT, FALL, NO_ROUTE)

_LINE_FIELDS = {"method", "seed", "plant", "record", "wall_seconds"}
_RECORD_FIELDS = {f.name for f in dc.fields(EpisodeRecord)}
_RECORD_REQUIRED = (
    "outcome",
    "steps",
    "nav_time",
    "path_length",
    "min_ped_distance",
    "discomfort_steps",
    "idt",
    "total_reward",
)


def _is_int(v: Any) -> bool:
    return isinstance(v, int) and not isinstance(v, bool)


def _is_number(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def check_trial(t: dict, config: EmoNavConfig | None = None) -> str | None:
    """What is wrong with one `trials.jsonl` line (a dict with `method`, `seed`, `record`),
    in words; None if it is a valid trial: no fields but `_LINE_FIELDS`, a method name, a
    seed in [0, 2**64 - 1], a record with every field of `EpisodeRecord.to_json()` and no
    other, a known outcome, step counts that are integers in [0, steps], lengths and times
    that are finite and >= 0 (`min_ped_distance` may be null: no pedestrian), a finite
    reward, DT between the largest IDT entry and their sum, `collided_with` only on a
    collision and `fall_reason` only on a fall, the field's metrics absent, null or valid
    (`navigation.social_metrics.check_social_fields`). With the run's `config`, also what the
    episode's bookkeeping (`navigation.metrics.EpisodeTracker`, on either plant) makes of it:
    `nav_time` = `steps` × `robot.step_time`, at most `episode.max_steps` steps, a
    timeout exactly at `episode.max_steps`, at least one step before a success or a
    collision."""
    unknown = sorted(set(t) - _LINE_FIELDS)
    if unknown:
        fields = ", ".join(sorted(_LINE_FIELDS))
        return f"the line has the unknown field {unknown[0]!r} (a trial line has {fields})"
    if not isinstance(t["method"], str) or not t["method"]:
        return f"method = {t['method']!r} is not a method name"
    if not (_is_int(t["seed"]) and 0 <= t["seed"] <= MAX_SEED):
        return f"seed = {t['seed']!r} is not a seed (an integer in [0, 2**64 - 1])"
    if "plant" in t and t["plant"] not in PLANTS:
        return f"plant = {t['plant']!r} is not {' or '.join(PLANTS)}"
    if "wall_seconds" in t and not (_is_number(t["wall_seconds"]) and t["wall_seconds"] >= 0):
        return f"wall_seconds = {t['wall_seconds']!r} must be a number >= 0"
    r = t["record"]
    if not isinstance(r, dict):
        return f"record = {r!r} is not an object"
    missing = [k for k in _RECORD_REQUIRED if k not in r]
    if missing:
        return f"record lacks {', '.join(missing)}"
    unknown = sorted(set(r) - _RECORD_FIELDS)
    if unknown:
        return f"record has the unknown field {unknown[0]!r}"
    if r["outcome"] not in OUTCOMES:
        return f"record.outcome = {r['outcome']!r} is not one of {', '.join(OUTCOMES)}"
    if not (_is_int(r["steps"]) and r["steps"] >= 0):
        return f"record.steps = {r['steps']!r} must be an integer >= 0"
    idt = r["idt"]
    if not (isinstance(idt, list) and len(idt) == 4):
        return f"record.idt = {idt!r} must be a list of 4 step counts"
    counts = [("discomfort_steps", r["discomfort_steps"])]
    counts += [(f"idt[{i}]", v) for i, v in enumerate(idt)]
    for name, v in counts:
        if not (_is_int(v) and 0 <= v <= r["steps"]):
            return f"record.{name} = {v!r} must be an integer in [0, steps = {r['steps']}]"
    for name in ("nav_time", "path_length", "min_ped_distance"):
        v = r[name]
        if v is None and name == "min_ped_distance":
            continue
        if not (_is_number(v) and v >= 0):
            return f"record.{name} = {v!r} must be a finite number >= 0"
    if not _is_number(r["total_reward"]):
        return f"record.total_reward = {r['total_reward']!r} must be a finite number"
    if "seed" in r and r["seed"] != t["seed"]:
        return f"record.seed = {r['seed']!r} differs from the line's seed {t['seed']!r}"
    for name, outcome in (("fall_reason", FALL), ("collided_with", COLLISION)):
        if name in r and not isinstance(r[name], str):
            return f"record.{name} = {r[name]!r} must be a string"
        if r.get(name) and r["outcome"] != outcome:
            return (
                f"record.{name} = {r[name]!r} with outcome {r['outcome']}: only a {outcome} has one"
            )
    social = check_social_fields(r)
    if social is not None:
        return social
    if r["idt"] and not max(r["idt"]) <= r["discomfort_steps"] <= sum(r["idt"]):
        return (
            f"record.discomfort_steps = {r['discomfort_steps']} does not fit record.idt = "
            f"{r['idt']}: a step in a zone counts once in DT and once per kind of zone in IDT"
        )
    return None if config is None else _check_against_config(r, config)


def _check_against_config(r: dict, config: EmoNavConfig) -> str | None:
    """What `check_trial` finds wrong in record `r` given the run's configuration."""
    steps, most, period = r["steps"], config.episode.max_steps, config.robot.step_time
    if steps > most:
        return f"record.steps = {steps} is more than the run's episode.max_steps = {most}"
    if r["outcome"] == TIMEOUT and steps != most:
        return (
            f"record.steps = {steps} with outcome timeout: a timeout ends at the run's "
            f"episode.max_steps = {most}"
        )
    if r["outcome"] in (SUCCESS, COLLISION) and steps < 1:
        return f"record.steps = 0 with outcome {r['outcome']}: it ends on a step"
    expected = steps * period
    if not math.isclose(r["nav_time"], expected, rel_tol=1e-9, abs_tol=1e-9):
        return (
            f"record.nav_time = {r['nav_time']!r} s is not record.steps × robot.step_time = "
            f"{steps} × {period:g} = {expected:g} s"
        )
    return None
