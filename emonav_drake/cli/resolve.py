"""The one configuration resolver of the command line (no sub-command of its own).

Every sub-command that runs on an `EmoNavConfig` resolves it here, in one order:
`--setting NAME` (a shipped setting, `emonav_drake/configs/NAME.yaml`), else
`--config F.yaml`, else the defaults; then `--time-varying`, `--state-source`,
`--family` and `--sensor` on top (`--sensor NAME` sets the whole `sensor` section from the
preset, but its seed: a configuration file's single sensor fields are overridden too).
`--setting` and `--config` are mutually exclusive (`add_config_choice`); a sub-command
without one of these flags resolves as if it were not given. `sim` and `lgm` also take a scenario
(`--scenario NAME|F.yaml`, else one sampled from the seed): `resolve_scenario`.

`sim`, `eval`, `benchmark` and `config` take `--setting`; `lgm` and `walk` only `--config`.
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from emonav_drake.configs import SETTINGS
from emonav_drake.params import (
    DEPLOYABLE_SENSOR,
    ConfigError,
    EmoNavConfig,
    apply_deployable,
    apply_sensor_preset,
    load_config,
)

if TYPE_CHECKING:
    from emonav_drake.scenarios.scenario import Scenario

CONFIG_HELP = "YAML configuration overriding the defaults"
SETTING_HELP = (
    "a named setting of the paper shipped with the package: no_emotion (0.2 m for "
    "every emotion), constant_0.5, var_dd (happy 0.2, neutral 0.35, negative 0.5 m: the "
    "defaults), time_varying (var_dd + one emotion changing every 2 s)"
)


@dataclass
class ResolvedConfig:
    """A sub-command's configuration and where it came from."""

    config: EmoNavConfig
    setting: str | None  # the --setting name, if one was given
    origin: str  # "--setting NAME", "--config F" or "the default configuration"
    time_varying: bool  # --time-varying was given (applied to `config` already)
    state_source: str | None = None  # --state-source, if given (applied to `config`)
    family: str | None = None  # --family, if given (applied to `config`)
    sensor: str | None = None  # --sensor, if given (applied to `config`)
    deployable: bool = False  # --deployable was given (applied to `config`)
    global_route: bool | None = None  # --global-route / --no-global-route (applied)

    @property
    def source(self) -> str:
        """`origin` plus " --time-varying" / " --deployable" / " --state-source S" /
        " --family F" / " --sensor P" / " --[no-]global-route" when given (recorded by
        `benchmark`, printed by `config`)."""
        flags = " --time-varying" if self.time_varying else ""
        if self.deployable:
            flags += " --deployable"
        if self.state_source is not None:
            flags += f" --state-source {self.state_source}"
        if self.family is not None:
            flags += f" --family {self.family}"
        if self.sensor is not None:
            flags += f" --sensor {self.sensor}"
        if self.global_route is not None:
            flags += " --global-route" if self.global_route else " --no-global-route"
        return self.origin + flags


def resolve_config(args: argparse.Namespace) -> ResolvedConfig:
    """The configuration of `--setting` / `--config` / the defaults, with `--time-varying`.

    A flag the sub-command does not have counts as not given. An unknown setting name
    (only possible without argparse's `choices`) is a `ConfigError` naming the choices."""
    from emonav_drake.configs import load_setting

    setting = getattr(args, "setting", None)
    config_file = getattr(args, "config", None)
    if setting is not None:
        cfg, origin = load_setting(setting), f"--setting {setting}"
    elif config_file is not None:
        check_input_file(config_file, "--config")
        cfg, origin = load_config(config_file), f"--config {config_file}"
    else:
        cfg, origin = load_config(), "the default configuration"
    time_varying = bool(getattr(args, "time_varying", False))
    if time_varying:
        cfg.crowd.time_varying_emotions = True
    state_source = getattr(args, "state_source", None)
    if state_source is not None:
        cfg.perception.state_source = state_source
    family = getattr(args, "family", None)
    if family is not None:
        cfg.crowd.family = family
    global_route = getattr(args, "global_route", None)
    if global_route is not None:
        cfg.route.enabled = bool(global_route)
    sensor = getattr(args, "sensor", None)
    deployable = bool(getattr(args, "deployable", False))
    if deployable:
        _check_deployable_flags(state_source)
        try:
            apply_deployable(cfg, sensor)
        except ConfigError as e:
            raise ConfigError(f"--deployable --sensor {sensor}: {e}") from None
        try:
            cfg.validate()
        except ConfigError as e:
            raise ConfigError(f"--deployable with {origin}: {e}") from None
    elif sensor is not None:
        apply_sensor_preset(cfg, sensor)  # a ConfigError naming sensor.preset if unknown
        try:
            cfg.validate()
        except ConfigError as e:
            raise ConfigError(f"--sensor {sensor} with {origin}: {e}") from None
    return ResolvedConfig(
        cfg, setting, origin, time_varying, state_source, family, sensor, deployable, global_route
    )


def _check_deployable_flags(state_source: str | None) -> None:
    """`--deployable` with `--state-source truth` contradicts itself (`--sensor ideal` is
    refused by `apply_deployable`)."""
    if state_source is not None and state_source != "lidar":
        raise ConfigError(
            f"--deployable with --state-source {state_source}: the deployable setting reads "
            "the crowd from the LiDAR tracker (state source lidar); drop one of the flags"
        )


def check_input_file(path: str | Path, flag: str) -> Path:
    """`path` if it is a file to read; else a `ConfigError` naming `flag` and why (no such
    file, a symlink loop, a directory)."""
    from emonav_drake.atomic_io import missing_file

    p = Path(path)
    if p.is_dir():
        raise ConfigError(f"{flag} {path}: is a directory, expected a YAML file")
    if not p.is_file():
        raise ConfigError(f"{flag} {path}: {missing_file(p)}")
    return p


def add_config_choice(p: argparse.ArgumentParser) -> None:
    """`--config F.yaml | --setting NAME`, mutually exclusive (argparse refuses both, and
    an unknown setting name with the list of choices: usage and one error line, exit 2)."""
    g = p.add_mutually_exclusive_group()
    g.add_argument("--config", type=Path, help=CONFIG_HELP)
    g.add_argument("--setting", choices=SETTINGS, help=SETTING_HELP)


STATE_SOURCE_HELP = (
    "what the state-based planners (dwa, mpc, sarl, rgl) read of the crowd: truth (the "
    "simulator's exact crowd, privileged) or lidar (pedestrians and obstacles detected in "
    "the LiDAR scan and tracked: what a robot can run); default: the configuration's "
    "perception.state_source, truth"
)


def add_state_source(p: argparse.ArgumentParser) -> None:
    """`--state-source truth|lidar` (`PerceptionParams.state_source`)."""
    from emonav_drake.params import STATE_SOURCES

    p.add_argument("--state-source", choices=STATE_SOURCES, help=STATE_SOURCE_HELP)


FAMILY_HELP = (
    "the scenario family the seeds sample (emonav config --list shows them with one line "
    "each): paper (the paper's arena), crossing and traffic patterns, a blocker, a group, "
    "corridors, dense and fast crowds; default: the configuration's crowd.family, paper"
)


def add_family(p: argparse.ArgumentParser) -> None:
    """`--family NAME` (`CrowdParams.family`, `scenarios/scenario_families.py`)."""
    from emonav_drake.params import SCENARIO_FAMILIES

    p.add_argument("--family", choices=SCENARIO_FAMILIES, metavar="NAME", help=FAMILY_HELP)


def add_global_route(p: argparse.ArgumentParser) -> None:
    """`--global-route` / `--no-global-route` (`RouteParams.enabled`, docs/global_route.md)."""
    p.add_argument(
        "--global-route",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="in a scene with walls, a global route on the known map (walls and static "
        "discs) gives the planner a sub-goal along it, drawn in Meshcat and replays "
        "(the configuration's route.enabled, on by default; --no-global-route: the "
        "planner steers to the goal itself; no effect without walls)",
    )


SENSOR_HELP = (
    "the LiDAR as a real sensor, by preset: ideal (the exact scan of the paper's "
    "simulator), vlp16 (Velodyne VLP-16 at 10 Hz, Digit's head LiDAR: 0.2°, ±3 cm), "
    "ust10lx (Hokuyo UST-10LX-class planar scanner: 270°, 0.25°, ±40 mm); the real "
    "presets add range noise, quantisation, dropouts, mixed pixels and spurious returns "
    "and show pedestrians as two legs (docs/perception.md); sets the whole sensor section "
    "but its seed; default: the configuration's sensor, ideal"
)


def add_sensor(p: argparse.ArgumentParser) -> None:
    """`--sensor PRESET` (`SensorParams`, `params_robot.SENSOR_PRESETS`)."""
    from emonav_drake.params import SENSOR_NAMES

    p.add_argument("--sensor", choices=SENSOR_NAMES, help=SENSOR_HELP)


DEPLOYABLE_HELP = (
    "what a robot could run: the state-based planners read the crowd tracked in the LiDAR "
    "scan (--state-source lidar) and the scan is a real sensor's, with its faults "
    f"(--sensor {DEPLOYABLE_SENSOR}, Digit's head LiDAR, unless --sensor names another real "
    "one); the learned policies read their grid maps of that scan; the emotions are the "
    "head camera's, kept per track (--emotion-source camera_tracks) unless "
    "--emotion-source or --emotion-estimate says otherwise"
)


def add_deployable(p: argparse.ArgumentParser) -> None:
    """`--deployable` (`params.apply_deployable`)."""
    p.add_argument("--deployable", action="store_true", help=DEPLOYABLE_HELP)


def sample(seed: int, resolved: ResolvedConfig) -> Scenario:
    """`sample_scenario`, its error naming where the configuration came from."""
    from emonav_drake.scenarios.scenario import ScenarioSamplingError, sample_scenario

    try:
        return sample_scenario(seed, resolved.config)
    except ScenarioSamplingError as e:
        raise ScenarioSamplingError(f"{resolved.origin}: {e}") from None


def resolve_scenario(args: argparse.Namespace, resolved: ResolvedConfig) -> Scenario:
    """The episode's scenario: `--scenario` (a file or a shipped example's name; its seed,
    else `--seed`; `--time-varying` gives one of its pedestrians a changing emotion), else
    the one sampled from `--seed`."""
    from emonav_drake.scenarios.scenario import add_time_varying_emotion, load_scenario

    if getattr(args, "scenario", None):
        from emonav_drake.scenarios import scenario_path

        if resolved.family is not None:
            raise ConfigError(
                f"--family {resolved.family} with --scenario {args.scenario}: a scenario file "
                "is one fixed scene and --family chooses how seeds are sampled; give one of them"
            )
        sc = load_scenario(scenario_path(args.scenario), resolved.config)
        sc.seed = args.seed if sc.seed < 0 else sc.seed
        if resolved.time_varying:
            add_time_varying_emotion(sc, sc.seed, resolved.config)
        return sc
    return sample(args.seed, resolved)


# The flags that decide a run's result, by sub-command: with `--spec` the spec gives them.
RESULT_FLAGS = (
    "planner",
    "planners",
    "plant",
    "seed",
    "first_seed",
    "episodes",
    "trials",
    "scenario",
    "config",
    "setting",
    "checkpoint",
    "emotion_source",
    "emotion_estimate",
    "deployable",
    "state_source",
    "family",
    "global_route",
    "sensor",
    "time_varying",
)


def add_spec(p: argparse.ArgumentParser, what: str) -> None:
    """`--spec FILE` (`diagrams.run_spec`), and the sub-command's defaults of the flags it
    replaces, so that `check_spec_flags` can tell which of them were given. Call it after
    every other flag is added."""
    p.add_argument(
        "--spec",
        type=Path,
        metavar="FILE",
        help=f"run again exactly what FILE records: {what}, or a run spec in YAML or JSON "
        "(docs/run_spec.md); the flags that decide the result (planner, plant, seeds, "
        "configuration, scene, emotions, sensing) come from it and may not be given",
    )
    flags = {
        a.dest: (tuple(a.option_strings), a.default)
        for a in p._actions
        if a.dest in RESULT_FLAGS and a.option_strings
    }
    p.set_defaults(result_flags=flags)


def check_spec_flags(args: argparse.Namespace) -> None:
    """With `--spec`: refuse every flag of `RESULT_FLAGS` given (its value not the
    sub-command's default), naming it."""
    given = []
    for dest, (options, default) in getattr(args, "result_flags", {}).items():
        value = getattr(args, dest, default)
        if value != default:  # --no-X for a boolean flag turned off
            given.append(options[-1] if value is False and len(options) > 1 else options[0])
    if given:
        raise ConfigError(
            f"--spec {args.spec}: {', '.join(given)} would change what the spec records; "
            "the spec gives them (edit a copy of the spec to run something else)"
        )
