"""What several sub-commands share (no sub-command of its own).

Seed flags (`SeedArg`, `parse_seed`, `check_seed_range`), the Meshcat host option
(`add_meshcat_host`, `meshcat_host`), output-file checks (`check_outputs`), the planner and
emotion-estimate flags of `sim` and `eval` (`add_episode_flags`, `check_planner_flags`,
`load_emotion_estimate`), `check_workers`, the methods of `--planners` / `--checkpoint`
(`parse_methods`, for benchmark and calibrate), and the per-step tracking table written by
`sim --steps-out` and `walk --steps-out` (`episode_steps_table`, `write_steps_csv`).
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, NoReturn

from emonav_drake.atomic_io import check_distinct, check_output_file, write_text_atomic
from emonav_drake.cli.resolve import (
    add_config_choice,
    add_deployable,
    add_family,
    add_global_route,
    add_sensor,
    add_state_source,
    resolve_scenario,
)
from emonav_drake.params import ConfigError, EmoNavConfig
from emonav_drake.planners import is_learned, reads_crowd_state

if TYPE_CHECKING:
    import numpy as np

    from emonav_drake.cli.resolve import ResolvedConfig
    from emonav_drake.diagrams.run_spec import MethodSpec, RunSpec
    from emonav_drake.navigation.episode_trace import EpisodeTrace


PLANNER_HELP = (
    "the planner that chooses the walking commands; `emonav planners` lists every name with "
    "what it reads (privileged or deployable) and its checkpoint"
)
PLANT_HELP = (
    "the robot: lip (the reduced-order LIP, fast: training and large benchmarks) or digit "
    "(the full-order Digit in Drake, about 5x real time)"
)


class SuggestingParser(argparse.ArgumentParser):
    """argparse's parser whose errors suggest the closest valid word: an invalid choice
    ("invalid choice: 'ofice' (did you mean 'office'?) (choose from ...)") and an unknown
    flag ("--planer (did you mean '--planner'?)")."""

    def error(self, message: str) -> NoReturn:
        import re

        from emonav_drake.errors import did_you_mean

        bad = re.search(r"invalid choice: '([^']*)' \(choose from (.*)\)$", message)
        if bad:
            choices = re.findall(r"'([^']*)'", bad.group(2))
            hint = did_you_mean(bad.group(1), choices)
            message = message[: bad.start()] + f"invalid choice: {bad.group(1)!r}{hint} "
            message += f"(choose from {bad.group(2)})"
        unknown = re.match(r"unrecognized arguments: (.*)$", message)
        if unknown:
            flags = [k for k in self._option_string_actions if k.startswith("--")]
            words = [
                f"{w}{did_you_mean(w.split('=')[0], flags) if w.startswith('-') else ''}"
                for w in unknown.group(1).split()
            ]
            message = f"unrecognized arguments: {' '.join(words)}"
        super().error(message)


class UserHelpFormatter(argparse.RawDescriptionHelpFormatter):
    """argparse's help, the description kept as written and each option's default shown,
    "(default: X)", unless its help already speaks of the default or it has none worth
    showing (off switches, None)."""

    def _get_help_string(self, action: argparse.Action) -> str:
        text = action.help or ""
        default = action.default
        if (
            "default" in text
            or default is None
            or default == argparse.SUPPRESS
            or isinstance(default, bool)
            or not action.option_strings
        ):
            return text
        return f"{text} (default: %(default)s)" if text else "(default: %(default)s)"


def parse_seed(text: str, flag: str) -> int:
    """A seed flag's value: an integer in [0, 2**64 - 1]; else `ConfigError` naming `flag`."""
    from emonav_drake.scenarios.scenario import MAX_SEED

    try:
        value = int(text)
    except ValueError:
        raise ConfigError(f"{flag} {text!r}: must be an integer in [0, 2**64 - 1]") from None
    if value < 0:
        raise ConfigError(f"{flag} {value}: must be >= 0")
    if value > MAX_SEED:
        raise ConfigError(
            f"{flag} {value}: beyond 64 bits; seeds are in [0, 2**64 - 1] = [0, {MAX_SEED}]"
        )
    return value


class SeedArg(argparse.Action):
    """The argparse action shared by every seed flag (`--seed`, `--first-seed`): the value
    is an integer in [0, 2**64 - 1] (`parse_seed`). Unlike a `type`, an action knows the
    flag, so a bad value is a `ConfigError` naming it: one line, exit 2 (`main`)."""

    def __call__(
        self,
        parser: argparse.ArgumentParser,
        namespace: argparse.Namespace,
        values: object,
        option_string: str | None = None,
    ) -> None:
        setattr(namespace, self.dest, parse_seed(str(values), option_string or self.dest))


def check_seed_range(first: int, count: int, flag: str) -> None:
    """Seeds `first` … `first + count - 1` must all fit in 64 bits (`ConfigError` naming `flag`)."""
    from emonav_drake.scenarios.scenario import MAX_SEED

    if first + count - 1 > MAX_SEED:
        raise ConfigError(
            f"{flag} {first}: with {count} seeds the last one, {first + count - 1}, is beyond "
            "64 bits (2**64 - 1)"
        )


def add_meshcat_host(p: argparse.ArgumentParser) -> None:
    """`--meshcat-host`: where a live Meshcat listens (loopback unless asked)."""
    p.add_argument(
        "--meshcat-host",
        default=None,
        metavar="HOST",
        help="with --meshcat: the interface Meshcat listens on (default localhost: this "
        "machine only); '*' = every interface, or one address of this machine. Meshcat has "
        "no authentication: anyone who reaches it can watch and change the scene (a warning "
        "is printed); prefer `ssh -L 7000:localhost:7000` to watch from another machine",
    )


def meshcat_host(args: argparse.Namespace) -> str:
    """The Meshcat host of `--meshcat-host` (checked: only with `--meshcat`, not empty, an
    interface of this machine — `check_meshcat_host` — so a bad one fails before work)."""
    from emonav_drake.diagrams.meshcat_viewing import LOOPBACK_HOST, check_meshcat_host

    if args.meshcat_host is None:
        return LOOPBACK_HOST
    if not args.meshcat:
        raise ConfigError("--meshcat-host is used with --meshcat only")
    if not args.meshcat_host.strip():
        raise ConfigError("--meshcat-host '': give a host name or address, or '*'")
    return check_meshcat_host(args.meshcat_host.strip())


def check_outputs(args: argparse.Namespace, *flags: str) -> None:
    """Every output flag given: a writable file path (checked before any work), all distinct."""
    outputs = {}
    for flag in flags:
        path = getattr(args, flag.removeprefix("--").replace("-", "_"), None)
        if path is not None:
            outputs[flag] = check_output_file(path, flag)
    check_distinct(outputs)


def check_workers(workers: int, address: str | None = None) -> None:
    """`--workers` must be >= 1 and, without `--ray-address`, at most 4 per CPU core
    (`parallel.check_workers`)."""
    from emonav_drake.parallel import check_workers as check

    check(workers, address)


def add_episode_flags(p: argparse.ArgumentParser) -> None:
    """The flags `sim` and `eval` share: the configuration (`--config | --setting`), the
    learned planner's checkpoint and device, the emotion estimate, the state source, the
    scenario family, the LiDAR sensor (`--sensor`), `--deployable`, `--time-varying`."""
    add_config_choice(p)
    p.add_argument(
        "--checkpoint",
        type=Path,
        help="policy checkpoint for a learned planner (default: the one shipped under its name)",
    )
    p.add_argument(
        "--device", default="cpu", help="torch device for a learned planner (cpu, cuda, cuda:N)"
    )
    add_emotion_flags(p)
    add_deployable(p)
    add_state_source(p)
    add_family(p)
    add_global_route(p)
    add_sensor(p)
    p.add_argument(
        "--time-varying",
        action="store_true",
        help="one pedestrian's emotion changes every 2 s (paper §IV-F); with --scenario, "
        "a pedestrian of the file chosen by --seed",
    )


def check_planner_flags(args: argparse.Namespace) -> None:
    """--checkpoint / --device only mean something with a learned planner, --state-source
    only with a planner that reads the crowd state; check them early."""
    source = getattr(args, "state_source", None)
    if source is not None and not reads_crowd_state(args.planner):
        raise ConfigError(
            f"--state-source {source}: --planner {args.planner} reads its LiDAR map "
            "observation, not the crowd state, so the state source changes nothing for it; "
            "it applies to the state-based planners (dwa, mpc, sarl, …: emonav planners)"
        )
    if not is_learned(args.planner):
        if args.checkpoint is not None:
            raise ConfigError(
                f"--checkpoint applies to a learned planner (--planner policy, sac or a variant), "
                f"not {args.planner}"
            )
        if args.device != "cpu":
            raise ConfigError(
                f"--device applies to a learned planner (--planner policy, sac or a variant), "
                f"not {args.planner}"
            )
        return
    from emonav_drake.torch_device import resolve_device

    resolve_device(args.device)


EMOTION_SOURCES = ("truth", "camera", "camera_tracks")


def add_emotion_flags(p: argparse.ArgumentParser) -> None:
    """--emotion-source and --emotion-estimate: where the perceived emotions come from."""
    p.add_argument(
        "--emotion-source",
        choices=EMOTION_SOURCES,
        default=None,
        help="truth: the simulator's emotions; camera: the robot's head camera renders the "
        "pedestrians' faces and the face cascade + CNN read them at 0.5 Hz, neutral when no "
        "face is seen (the paper's pipeline: the Haar cascade); camera_tracks: faces found by "
        "BlazeFace at each pedestrian's head (to 6 m), each emotion kept with the LiDAR "
        "track of its person until 10 s after the last sighting (needs --state-source lidar "
        "or --deployable; docs/perception.md); default: truth, with --deployable "
        "camera_tracks",
    )
    p.add_argument(
        "--emotion-estimate",
        type=Path,
        help="YAML EmotionEstimateParams: the perceived emotions in full (mode: confusion "
        "through a confusion matrix, or camera with its camera settings)",
    )


def emotion_estimate_of(args: argparse.Namespace) -> Any:
    """The `EmotionEstimateParams` of --emotion-source / --emotion-estimate, or None for
    the ground truth; `ConfigError` when the two disagree."""
    source = getattr(args, "emotion_source", None)
    if source is None:  # what a robot could run also sees emotions with its own camera
        deployable = bool(getattr(args, "deployable", False))
        source = "camera_tracks" if deployable and not args.emotion_estimate else "truth"
    params = load_emotion_estimate(args.emotion_estimate)
    if source in ("camera", "camera_tracks"):
        if params is None:
            from emonav_drake.perception.noisy_emotions import EmotionEstimateParams

            if source == "camera_tracks":  # ours: BlazeFace at the tracked heads, 2.5 Hz
                return EmotionEstimateParams.tracked_faces()
            return EmotionEstimateParams(mode=source).validate()
        if params.mode != source:
            raise ConfigError(
                f"--emotion-source {source} and --emotion-estimate {args.emotion_estimate} "
                f"(mode {params.mode}) disagree: give one of them"
            )
    return params


def load_emotion_estimate(path: Path | None) -> Any:
    """The validated `EmotionEstimateParams` of `--emotion-estimate`, or None without it.

    Every error names the flag and the file. Mode "classifier" is refused: it reads the
    estimates of a classifier that a Python program wires into the diagram, and the
    command line wires none (mode "camera" is the CLI's face classifier).
    """
    if not path:
        return None
    from emonav_drake.perception.noisy_emotions import EmotionEstimateParams
    from emonav_drake.typed_yaml import load_typed_yaml

    params = load_typed_yaml(EmotionEstimateParams, path=path)  # its errors name the file
    where = f"--emotion-estimate {path}"
    try:
        params.validate()
    except ConfigError as e:
        raise ConfigError(f"{where}: {e}") from None
    if params.mode == "classifier":
        raise ConfigError(
            f"{where}: mode: classifier reads the emotions of a face classifier that a Python "
            "program connects to the diagram (EmotionEstimateSource's estimated_emotions "
            "input); the command line connects none: use mode: camera (the head camera and "
            "the face classifier, as --emotion-source camera), confusion or ground_truth"
        )
    return params


FLAG_NAMES = {"planners": "--planners", "checkpoint": "--checkpoint"}


def parse_methods(
    planners: str | Sequence[str], checkpoints: Sequence[str] = ()
) -> list[MethodSpec]:
    """`--planners policy,mpc,dwa` and `--checkpoint NAME=PATH …` → the validated methods
    (`diagrams.trials.method_specs`, a list of `MethodSpec`); a refusal is a `ConfigError`
    naming the flag."""
    from emonav_drake.diagrams.trials import MethodError, method_specs

    try:
        return method_specs(planners, checkpoints)
    except MethodError as e:
        raise ConfigError(e.worded(FLAG_NAMES)) from None


def write_steps_csv(path: str | Path, table: np.ndarray) -> int:
    """Write a tracking table (`robot.tracking.COLUMNS`, one row per step) as CSV, atomically.

    The header is the column names; `step` is an integer, every other value a float in
    SI units (m, rad, s, m/s: `robot.tracking.UNITS`) with full precision (NaN as "nan").
    Returns the number of rows written."""
    import csv
    import io

    import numpy as np

    from emonav_drake.robot.tracking import COLUMNS

    rows = np.asarray(table, float).reshape(-1, len(COLUMNS))
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(COLUMNS)
    for r in rows:
        writer.writerow([int(r[0]), *(repr(float(v)) for v in r[1:])])
    write_text_atomic(path, buf.getvalue())
    return len(rows)


def episode_steps_table(config: EmoNavConfig, trace: EpisodeTrace) -> np.ndarray:
    """The tracking table of a navigation episode, on either plant, against the planner's
    LIP (ω = √(g/H) of `config.robot`), from its `EpisodeTrace` (`Plant.simulate` with
    `trace=True`): one row per step (`robot.tracking.trace_tracking`)."""
    from emonav_drake.robot.tracking import trace_tracking

    r = config.robot
    return trace_tracking(trace, r.omega, r.step_time)


def run_spec_from_args(
    args: argparse.Namespace,
    resolved: ResolvedConfig,
    methods: list[MethodSpec] | None = None,
    episodes: int = 1,
    first_seed: int | None = None,
) -> RunSpec:
    """The `RunSpec` of a sub-command's flags, its configuration `resolved` (by
    `resolve_config`): `methods` (default: `sim`'s or `eval`'s one, `--planner` with
    `--checkpoint`), the seeds (default: `--seed`), the fixed scene of `--scenario` (in
    full, its changing pedestrian included), the emotion estimate, the planner modules."""
    from emonav_drake.diagrams.run_spec import RunSpec
    from emonav_drake.planners.plugins import import_planner_modules

    if methods is None:
        methods = _sim_methods(args.planner, getattr(args, "checkpoint", None), resolved.config)
    scene, scene_name = None, ""
    seed = args.seed if first_seed is None else first_seed
    if getattr(args, "scenario", None):
        scene = resolve_scenario(args, resolved)
        scene_name, seed = Path(args.scenario).stem, scene.seed
    config_file = getattr(args, "config", None)
    return RunSpec(
        plant=args.plant,
        setting_name=resolved.setting or (Path(config_file).stem if config_file else ""),
        methods=methods,
        first_seed=seed,
        episodes=episodes,
        scene_name=scene_name,
        scenario=scene,
        emotion_estimate=emotion_estimate_of(args),
        planner_modules=import_planner_modules(getattr(args, "planner_modules", None) or []),
        config=resolved.config,
    )


def _sim_methods(planner: str, checkpoint: Path | None, config: EmoNavConfig) -> list[MethodSpec]:
    """The one method of `sim` / `eval`: `--planner` with `--checkpoint`. A refusal says
    what the planner itself says when built (worded for `--planner`, e.g. `sac` without a
    SAC actor), not the benchmark's `--planners` wording."""
    from emonav_drake.diagrams.trials import MethodError, method_specs

    try:
        return method_specs([planner], [f"{planner}={checkpoint}"] if checkpoint else [])
    except MethodError as e:
        from emonav_drake.planners import make_planner

        make_planner(planner, config, checkpoint=checkpoint)  # its own message, if it has one
        raise ConfigError(
            e.worded({"planners": "--planner", "checkpoint": "--checkpoint"})
        ) from None
