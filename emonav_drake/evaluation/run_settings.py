"""A benchmark run's settings (`settings.json`): what the run is, and how two differ.

`make_settings` records the methods (planner kinds, checkpoints and their hashes), the
plant, trials, first seed, the full resolved configuration as YAML and its hash, the
emotion estimate, the package's identity and the planner modules of the user's own with
the sha256 of each one's source; `settings_difference` names the first field in which a
later run into the same directory differs (a run may only add trials; a changed plug-in
file is another setting);
`spec_from_settings` rebuilds what a worker needs (`diagrams.trials.BenchmarkSpec`).

`check_settings` is applied on every read of a run (`emonav benchmark` continuing one,
`diagnose`, `compare`): the file must be a JSON object with every field the code reads,
each of its kind, and the configuration text (`config_yaml`, `emotion_estimate_yaml`)
must still have the hash recorded beside it — an edited configuration would be
re-simulated, or its trials compared, as if the run had used it.
"""

from __future__ import annotations

import dataclasses as dc
import datetime
import logging
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from emonav_drake.diagrams.plants import PLANTS
from emonav_drake.diagrams.run_spec import RunSpec
from emonav_drake.diagrams.trials import (
    MAX_TRIALS,
    BenchmarkSpec,
    MethodSpec,
)
from emonav_drake.params import (
    ConfigError,
    EmoNavConfig,
    RouteParams,
    dump_config,
    is_deployable,
    load_config,
)
from emonav_drake.provenance import numeric_kernels, package_identity, sha256_bytes
from emonav_drake.scenarios.scenario import MAX_SEED
from emonav_drake.scenarios.scenario_families import WALLED_FAMILIES

log = logging.getLogger(__name__)


FORMAT = 1


class BenchmarkSettingsError(ConfigError):
    """A run directory holds a benchmark with other settings (or is damaged)."""


def setting_label(config: EmoNavConfig, name: str | None) -> str:
    """E.g. "var_dd [0.2, 0.35, 0.5] m" (+ ", time-varying", ", deployable (lidar state,
    sensor vlp16)", …): the DD column of Table III."""
    r = config.reward
    label = f"{name or 'config'} [{r.happy_discomfort:g}, {r.neutral_discomfort:g}, "
    label += f"{r.negative_discomfort:g}] m"
    if config.crowd.time_varying_emotions:
        label += ", time-varying"
    if is_deployable(config):
        label += f", deployable (lidar state, sensor {config.sensor.preset})"
    elif config.perception.state_source != "truth":
        label += f", {config.perception.state_source} state"
    if config.crowd.family != "paper":
        label += f", family {config.crowd.family}"
    if not config.sensor.is_exact() and not is_deployable(config):
        label += f", sensor {config.sensor.preset}"
    if config.crowd.family in WALLED_FAMILIES:  # elsewhere the route layer is never built
        rp = config.route
        if not rp.enabled:
            label += ", no global route"
        elif dc.asdict(rp) != dc.asdict(RouteParams()):
            margins = "/".join(f"{m:g}" for m in rp.margins) or "0"
            label += f", global route (margin {margins} m, look-ahead {rp.lookahead:g} m"
            label += ", line of sight)" if rp.line_of_sight else ")"
        else:
            label += ", global route"
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
    planner_modules: Sequence[str] = (),
) -> dict:
    """The `settings.json` of a run (`planner_modules` and `planner_modules_sha256`, the
    sha256 of each module's source, only when there are any, so a run of the package's
    own planners keeps the settings it always had; likewise `sensor`, the sensor section,
    and `deployable`, only for a sensor with faults)."""
    from emonav_drake.planners.plugins import modules_sha256

    cfg_yaml = dump_config(config)
    extra: dict[str, object] = {}
    if planner_modules:
        extra = {
            "planner_modules": list(planner_modules),
            "planner_modules_sha256": modules_sha256(planner_modules),
        }
    if not config.sensor.is_exact():  # the preset and its parameters, readable at a glance
        extra["sensor"] = dc.asdict(config.sensor)
        extra["deployable"] = is_deployable(config)
    return extra | {
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
        "numerics": numeric_kernels(),
        "created": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
    }


def _source_name(config_source: str) -> str:
    if config_source.startswith("--config"):
        return Path(config_source.split()[1]).stem
    return "default"


# The fields of `settings.json` the code reads, and what each must be (`check_settings`).
_STR, _OPT_STR = (str,), (str, type(None))
_SETTINGS_KINDS: dict[str, tuple[tuple[type, ...], str]] = {
    "format": ((int,), "an integer"),
    "planners": ((list,), "a list of method names"),
    "methods": ((dict,), "an object: method name → its planner and checkpoint"),
    "plant": (_STR, f"one of {', '.join(PLANTS)}"),
    "trials": ((int,), f"an integer in [1, {MAX_TRIALS}]"),
    "first_seed": ((int,), "a seed: an integer in [0, 2**64 - 1]"),
    "setting": (_OPT_STR, "a setting name or null"),
    "setting_label": (_STR, "a string"),
    "config_source": (_STR, "a string"),
    "config_sha256": (_STR, "a SHA-256 in hex"),
    "config_yaml": (_STR, "the configuration as YAML text"),
    "time_varying": ((bool,), "true or false"),
    "goal_radius": ((int, float), "a number [m]"),
    "emotion_estimate_yaml": (_OPT_STR, "YAML text or null"),
    "emotion_estimate_sha256": (_OPT_STR, "a SHA-256 in hex or null"),
    "package": ((dict,), "an object"),
    "created": (_STR, "a date and time"),
}
_METHOD_FIELDS = {f.name for f in dc.fields(MethodSpec)}


def _kind_problem(settings: dict) -> str | None:
    """The first field of `settings` that is missing or not of its kind, in words."""
    for key, (kinds, what) in _SETTINGS_KINDS.items():
        if key not in settings:
            return f"lacks the field {key!r} (not a benchmark's settings?)"
        v = settings[key]
        if not isinstance(v, kinds) or (isinstance(v, bool) and bool not in kinds):
            return f"{key} = {_short(v)} is not {what}"
    if settings["format"] != FORMAT:
        return f"format = {settings['format']!r}: this emonav reads format {FORMAT}"
    names = settings["planners"]
    if (
        not names
        or not all(isinstance(n, str) and n for n in names)
        or len(set(names)) < len(names)
    ):
        return f"planners = {_short(names)} is not a list of distinct method names"
    for name in names:
        m = settings["methods"].get(name)
        if not isinstance(m, dict):
            return f"methods lacks the method {name!r} of planners"
        unknown = sorted(set(m) - _METHOD_FIELDS)
        if unknown:
            return f"methods.{name} has the unknown field {unknown[0]!r}"
        if m.get("name") != name or not isinstance(m.get("planner"), str):
            return f"methods.{name} is not a method (its name and planner)"
        for key in ("checkpoint", "checkpoint_sha256", "observation"):
            if not isinstance(m.get(key), _OPT_STR):
                return f"methods.{name}.{key} = {_short(m.get(key))} is not a string"
    if settings["plant"] not in PLANTS:
        return f"plant = {settings['plant']!r} is not one of {', '.join(PLANTS)}"
    trials, first = settings["trials"], settings["first_seed"]
    if not 1 <= trials <= MAX_TRIALS:
        return f"trials = {trials} is not in [1, {MAX_TRIALS}]"
    if not 0 <= first <= MAX_SEED - trials + 1:
        return f"first_seed = {first} with trials = {trials}: the seeds are not in [0, 2**64 - 1]"
    if not (math.isfinite(settings["goal_radius"]) and settings["goal_radius"] > 0):
        return f"goal_radius = {settings['goal_radius']!r} is not a number > 0"
    # added later, so optional (absent: none): the planner modules and their sources' hashes
    modules = settings.get("planner_modules", [])
    if not (isinstance(modules, list) and all(isinstance(m, str) and m for m in modules)):
        return f"planner_modules = {_short(modules)} is not a list of planner modules"
    hashes = settings.get("planner_modules_sha256", {})
    if not (
        isinstance(hashes, dict)
        and all(isinstance(h, _OPT_STR) for h in hashes.values())
        and set(hashes) <= set(modules)
    ):
        return (
            f"planner_modules_sha256 = {_short(hashes)} is not an object: planner module → "
            "SHA-256 or null"
        )
    sensor = settings.get("sensor", {})
    if not isinstance(sensor, dict):
        return f"sensor = {_short(sensor)} is not an object: the sensor section"
    if not isinstance(settings.get("deployable", False), bool):
        return f"deployable = {_short(settings.get('deployable'))} is not true or false"
    extended = settings.get("extended", [])
    if not (isinstance(extended, list) and all(isinstance(e, dict) for e in extended)):
        return f"extended = {_short(extended)} is not a list of objects"
    return None


def check_settings(settings: Any, where: str) -> EmoNavConfig:
    """`settings` (read from the file `where`) checked; the run's configuration.

    Raises `BenchmarkSettingsError` naming the file and the field: not a JSON object, a
    field missing or of another kind, a configuration (`config_yaml`,
    `emotion_estimate_yaml`) whose hash is not the one recorded beside it (edited after
    the run), a configuration that does not load, or `time_varying` / `goal_radius`
    that are not the configuration's.
    """
    if not isinstance(settings, dict):
        raise BenchmarkSettingsError(
            f"{where}: not a JSON object ({_a(settings)}); a benchmark's settings.json is "
            "an object (written by `emonav benchmark`)"
        )
    problem = _kind_problem(settings)
    if problem is not None:
        raise BenchmarkSettingsError(f"{where}: {problem}")
    for text_key, hash_key in (
        ("config_yaml", "config_sha256"),
        ("emotion_estimate_yaml", "emotion_estimate_sha256"),
    ):
        text, recorded = settings[text_key], settings[hash_key]
        found = None if text is None else sha256_bytes(text.encode())
        if found != recorded:
            raise BenchmarkSettingsError(
                f"{where}: {text_key} does not match {hash_key} ({_short(found)} against "
                f"{_short(recorded)} recorded): the text was edited after the run, whose "
                f"trials were not run with it; restore it, or run a new benchmark with the "
                "changed configuration"
            )
    try:
        config = load_config(data=settings["config_yaml"])
    except ConfigError as e:
        raise BenchmarkSettingsError(
            f"{where} (config_yaml): {str(e).removeprefix('<yaml>: ')}"
        ) from None
    derived = (
        ("time_varying", bool(config.crowd.time_varying_emotions), "crowd.time_varying_emotions"),
        ("goal_radius", config.episode.eval_goal_radius, "episode.eval_goal_radius"),
    )
    for key, value, source in derived:
        if settings[key] != value:
            raise BenchmarkSettingsError(
                f"{where}: {key} = {settings[key]!r} is not the configuration's {source} = "
                f"{value!r} (config_yaml)"
            )
    return config


def _a(value: Any) -> str:
    """'a list', 'a str', …: what a JSON value is."""
    return f"a {type(value).__name__}" if value is not None else "null"


def spec_from_settings(settings: dict) -> BenchmarkSpec:
    return BenchmarkSpec(
        methods=[MethodSpec(**settings["methods"][n]) for n in settings["planners"]],
        plant=settings["plant"],
        config_yaml=settings["config_yaml"],
        emotion_estimate_yaml=settings["emotion_estimate_yaml"],
        planner_modules=list(settings.get("planner_modules", [])),
    )


def _short(v: Any) -> str:
    if isinstance(v, str):
        return repr(v if len(v) <= 14 else v[:12] + "…")
    text = repr(v)
    return text if len(text) <= 40 else text[:38] + "…"


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
    simple.append(("planner_modules", "planner modules (--planner-module)"))
    for key, what in simple:
        if old.get(key) != new.get(key):
            extra = ""
            if key == "config_sha256":
                extra = f" — {config_difference(old['config_yaml'], new['config_yaml'])}"
            return f"{what} is {_short(old.get(key))} there, {_short(new.get(key))} here{extra}"
    changed = _changed_module(old, new)
    if changed is not None:
        return changed
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


def _changed_module(old: dict, new: dict) -> str | None:
    """The first planner module whose source's hash (`planner_modules_sha256`) differs
    between two runs with the same `planner_modules`, as words. A run directory written
    before the hashes were recorded has none: its modules' sources are not compared."""
    if "planner_modules_sha256" not in old:
        return None
    there, here = old["planner_modules_sha256"], new.get("planner_modules_sha256", {})
    for module in new.get("planner_modules", []):
        if there.get(module) != here.get(module):
            return (
                f"planner_modules: the source of {module} has changed (sha256 "
                f"{_short(there.get(module))} there, {_short(here.get(module))} here)"
            )
    return None


def config_difference(a: str, b: str, labels: tuple[str, str] = ("there", "here")) -> str:
    """The first differing field of two configuration dumps, with its section: "reward.
    negative_discomfort: 0.5 there, 0.2 here" (`labels` name where `a` and `b` come from)."""
    section = ""
    for la, lb in zip(a.splitlines(), b.splitlines(), strict=False):
        if not la.startswith(" "):
            section = la.rstrip(":")
        if la != lb:
            key = la.strip().split(":")[0]
            there, here = (x.split(":", 1)[-1].strip() for x in (la, lb))
            return f"{section}.{key}: {there} {labels[0]}, {here} {labels[1]}"
    return "the dumps differ in length"


def run_spec_of_settings(settings: dict, where: str) -> RunSpec:
    """The `RunSpec` of a benchmark's `settings.json` (checked first: `check_settings`):
    its methods in the run's order with their checkpoints and hashes, plant, trials, first
    seed, configuration, emotion estimate and planner modules. Runs of any date read."""
    from emonav_drake.diagrams.run_spec import RunSpec

    config = check_settings(settings, where)
    estimate = None
    if settings["emotion_estimate_yaml"] is not None:
        from emonav_drake.perception.noisy_emotions import EmotionEstimateParams
        from emonav_drake.typed_yaml import load_typed_yaml

        estimate = load_typed_yaml(EmotionEstimateParams, data=settings["emotion_estimate_yaml"])
    bench = spec_from_settings(settings)
    return RunSpec(
        plant=bench.plant,
        methods=bench.methods,
        first_seed=settings["first_seed"],
        episodes=settings["trials"],
        setting_name=settings.get("setting") or "",
        emotion_estimate=estimate,
        planner_modules=bench.planner_modules,
        config=config,
    ).check(where)


def read_run_spec(path: str | Path) -> RunSpec:
    """The `RunSpec` of `--spec FILE`: a benchmark's `settings.json` (or its run
    directory), a sim's or eval's `--json`, or a spec file (`diagrams.run_spec`); the
    file is read once."""
    from emonav_drake.diagrams.run_spec import (
        is_settings,
        load_run_spec,
        read_record,
        spec_from_record,
    )

    path = Path(path)
    if path.is_dir() and (path / "settings.json").is_file():
        path = path / "settings.json"
    where = f"--spec {path}"
    data = read_record(path, where)
    if not isinstance(data, dict):
        return load_run_spec(path)  # YAML, or the refusal of what is no JSON object
    if is_settings(data):
        return run_spec_of_settings(data, where)
    return spec_from_record(data, where)
