"""Several benchmark runs as one comparison: methods run at different times (a baseline
trained later, a planner added after the others) on the same seeds and settings.

`combine_runs([RUN, …])` reads each run directory and returns one `(settings, trials)` as
if the methods had been run together; `emonav compare RUN RUN … --out DIR` writes its
tables (Table II, Table III style, social metrics, McNemar on the seeds each pair shares).

A comparison is only made of runs that agree on what a trial is: the plant, the setting
(the configuration's hash, which holds the goal radius), time-varying emotions and the
emotion estimate (`run_settings.TRIAL_SETTINGS`); anything else is refused, naming the
first difference. The runs may cover different seed ranges (the pairs are tested on the
seeds both ran) and may come from different commits (each run's commit is listed in the
combined settings). A method name
may appear in two runs only for the same planner and checkpoint; its trials must then
agree seed for seed (a deterministic planner gives the same trial twice) — on the fields
both records have: a run recorded before the field's metrics (`navigation/social_metrics.py`)
agrees with a later one that has them, and the trial that has them is kept.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from emonav_drake.evaluation.run_directory import (
    BenchmarkSettingsError,
    comparable,
    load_run,
    trial_key,
)
from emonav_drake.evaluation.run_settings import TRIAL_SETTINGS, config_difference
from emonav_drake.navigation.social_metrics import SOCIAL_FIELDS


def _measured(t: dict) -> bool:
    """Whether a trial's record carries the field's metrics (a record from before them
    lacks every one)."""
    return any(name in t["record"] for name in SOCIAL_FIELDS)


def same_trial(a: dict, b: dict) -> bool:
    """Two trial lines of one method and seed agree: equal but for the wall time, and
    but for the field's metrics when one record was written before they existed."""
    if _measured(a) == _measured(b):
        return comparable(a) == comparable(b)
    old, new = (a, b) if _measured(b) else (b, a)
    trimmed = {k: v for k, v in new["record"].items() if k not in SOCIAL_FIELDS}
    return comparable(old) == comparable(new | {"record": trimmed})


def combine_runs(paths: Sequence[str | Path]) -> tuple[dict, list[dict]]:
    """(settings, trials) of the runs in `paths` as one comparison (module docstring).

    Raises:
        BenchmarkSettingsError: fewer than two runs, a path that is not a run directory,
            runs that differ in what a trial is, a method name used by two runs for
            different planners or checkpoints, or two different results for one trial.
    """
    if len(paths) < 2:
        raise BenchmarkSettingsError("give at least two run directories to combine")
    runs = [(Path(p), *load_run(p)) for p in paths]
    first_path, first, _ = runs[0]
    settings = {k: first[k] for k in first if k not in ("planners", "methods", "extended")}
    settings |= {"planners": [], "methods": {}, "runs": []}
    trials: dict[tuple[str, int], dict] = {}
    origin: dict[str, list[str]] = {}  # the runs each method's trials come from
    shared: dict[str, int] = {}  # trials of a method found in two runs (and equal there)
    lo, hi = first["first_seed"], first["first_seed"] + first["trials"]
    for path, s, run_trials in runs:
        for key, what in TRIAL_SETTINGS:
            if s.get(key) != first.get(key):
                detail = ""
                if key == "config_sha256" and "config_yaml" in s and "config_yaml" in first:
                    where = (f"in {first_path.name}", f"in {path.name}")
                    diff = config_difference(first["config_yaml"], s["config_yaml"], where)
                    detail = f"; first difference {diff}"
                raise BenchmarkSettingsError(
                    f"{path}: its {what} is {s.get(key)!r}, {first_path}'s is "
                    f"{first.get(key)!r}{detail}: the runs measure different trials"
                )
        for name in s["planners"]:
            method = s["methods"][name]
            known = settings["methods"].get(name)
            if known is None:
                settings["planners"].append(name)
                settings["methods"][name] = method
                origin[name] = [str(path)]
            elif (known["planner"], known["checkpoint_sha256"]) != (
                method["planner"],
                method["checkpoint_sha256"],
            ):
                raise BenchmarkSettingsError(
                    f"{path}: method {name!r} is another planner or checkpoint than in an "
                    "earlier run; rename it in one run (--checkpoint NAME=PATH)"
                )
            else:
                origin[name].append(str(path))
        for t in run_trials:
            key = trial_key(t)
            if key in trials and not same_trial(trials[key], t):
                raise BenchmarkSettingsError(
                    f"{path}: {key[0]} seed {key[1]} differs from the same trial in an earlier run"
                )
            if key in trials:
                shared[key[0]] = shared.get(key[0], 0) + 1
            if key not in trials or (_measured(t) and not _measured(trials[key])):
                trials[key] = t
        lo, hi = min(lo, s["first_seed"]), max(hi, s["first_seed"] + s["trials"])
        pkg = s.get("package", {})
        settings["runs"].append(
            {"path": str(path), "planners": s["planners"], "commit": pkg.get("commit")}
        )
    settings["first_seed"], settings["trials"] = lo, hi - lo
    settings["merged"] = {  # a method in several runs: said, never merged silently
        name: {"runs": runs_of, "shared_trials": shared.get(name, 0)}
        for name, runs_of in origin.items()
        if len(runs_of) > 1
    }
    rank = {m: i for i, m in enumerate(settings["planners"])}
    ordered = sorted(trials.values(), key=lambda t: (rank[t["method"]], t["seed"]))
    return settings, ordered
