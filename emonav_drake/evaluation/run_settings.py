"""A benchmark run's settings (`settings.json`): what the run is, and how two differ.

`make_settings` records the methods (planner kinds, checkpoints and their hashes), the
plant, trials, first seed, the full resolved configuration as YAML and its hash, the
emotion estimate and the package's identity; `settings_difference` names the first field
in which a later run into the same directory differs (a run may only add trials);
`spec_from_settings` rebuilds what a worker needs (`diagrams.trials.BenchmarkSpec`).
"""

from __future__ import annotations

import dataclasses as dc
import datetime
import logging
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from emonav_drake.diagrams.trials import (
    BenchmarkSpec,
    MethodSpec,
)
from emonav_drake.params import ConfigError, EmoNavConfig, dump_config
from emonav_drake.provenance import package_identity, sha256_bytes

log = logging.getLogger(__name__)


FORMAT = 1


class BenchmarkSettingsError(ConfigError):
    """A run directory holds a benchmark with other settings (or is damaged)."""


def setting_label(config: EmoNavConfig, name: str | None) -> str:
    """E.g. "var_dd [0.2, 0.35, 0.5] m" (+ ", time-varying"): the DD column of Table III."""
    r = config.reward
    label = f"{name or 'config'} [{r.happy_discomfort:g}, {r.neutral_discomfort:g}, "
    label += f"{r.negative_discomfort:g}] m"
    if config.crowd.time_varying_emotions:
        label += ", time-varying"
    return label


def make_settings(
    methods: Sequence[MethodSpec],
    plant: str,
    trials: int,
    first_seed: int,
    config: EmoNavConfig,
    setting: str | None = None,
    config_source: str = "defaults",
    emotion_estimate_yaml: str | None = None,
) -> dict:
    """The `settings.json` of a run."""
    cfg_yaml = dump_config(config)
    return {
        "format": FORMAT,
        "planners": [m.name for m in methods],
        "methods": {m.name: dc.asdict(m) for m in methods},
        "plant": plant,
        "trials": trials,
        "first_seed": first_seed,
        "setting": setting,
        "setting_label": setting_label(config, setting or _source_name(config_source)),
        "config_source": config_source,
        "config_sha256": sha256_bytes(cfg_yaml.encode()),
        "config_yaml": cfg_yaml,
        "time_varying": bool(config.crowd.time_varying_emotions),
        "goal_radius": config.episode.eval_goal_radius,
        "emotion_estimate_yaml": emotion_estimate_yaml,
        "emotion_estimate_sha256": (
            None if emotion_estimate_yaml is None else sha256_bytes(emotion_estimate_yaml.encode())
        ),
        "package": package_identity(),
        "created": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
    }


def _source_name(config_source: str) -> str:
    if config_source.startswith("--config"):
        return Path(config_source.split()[1]).stem
    return "default"


def spec_from_settings(settings: dict) -> BenchmarkSpec:
    return BenchmarkSpec(
        methods=[MethodSpec(**settings["methods"][n]) for n in settings["planners"]],
        plant=settings["plant"],
        config_yaml=settings["config_yaml"],
        emotion_estimate_yaml=settings["emotion_estimate_yaml"],
    )


def _short(v: Any) -> str:
    if isinstance(v, str):
        return repr(v if len(v) <= 14 else v[:12] + "…")
    return str(v)


# The settings that say what a trial is (its goal radius is in the configuration): two
# runs whose settings agree on these ran the same trial for a method and seed.
TRIAL_SETTINGS = (
    ("plant", "plant"),
    ("time_varying", "time-varying emotions"),
    ("config_sha256", "configuration (hash)"),
    ("emotion_estimate_sha256", "emotion estimate (hash)"),
)


def settings_difference(old: dict, new: dict) -> str | None:
    """The first setting in which `new` differs from a run directory's `old`, as words."""
    if old.get("format") != FORMAT:
        return f"format is {old.get('format')!r} there, {FORMAT} here"
    if set(old["planners"]) != set(new["planners"]):
        return f"planners are {','.join(old['planners'])} there, {','.join(new['planners'])} here"
    simple = [TRIAL_SETTINGS[0], ("first_seed", "first seed"), *TRIAL_SETTINGS[1:]]
    for key, what in simple:
        if old.get(key) != new.get(key):
            extra = ""
            if key == "config_sha256":
                extra = f" — {_config_diff(old['config_yaml'], new['config_yaml'])}"
            return f"{what} is {_short(old.get(key))} there, {_short(new.get(key))} here{extra}"
    for name in new["planners"]:
        a, b = old["methods"][name], new["methods"][name]
        for key, what in (("planner", "planner"), ("checkpoint_sha256", "checkpoint (hash)")):
            if a.get(key) != b.get(key):
                return f"{what} of {name} is {_short(a.get(key))} there, {_short(b.get(key))} here"
    pa, pb = old.get("package", {}), new.get("package", {})
    # the code itself, not the commit: a commit of docs or tests does not change a trial,
    # an uncommitted edit of a planner does (the commit is kept for the record only)
    for key, what in (
        ("version", "package version"),
        ("code_sha256", "package code (hash of emonav_drake/**/*.py)"),
    ):
        if pa.get(key) != pb.get(key):
            return f"{what} is {_short(pa.get(key))} there, {_short(pb.get(key))} here"
    return None


def _config_diff(a: str, b: str) -> str:
    """The first differing line of two configuration dumps, with its section."""
    section = ""
    for la, lb in zip(a.splitlines(), b.splitlines(), strict=False):
        if not la.startswith(" "):
            section = la.rstrip(":")
        if la != lb:
            key = la.strip().split(":")[0]
            there, here = (x.split(":", 1)[-1].strip() for x in (la, lb))
            return f"{section}.{key}: {there} there, {here} here"
    return "the dumps differ in length"
