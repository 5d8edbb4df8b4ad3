"""`emonav train`: the SAC trainer (paper-scale, `--algo sac`), the CPU route (`--algo dagger`),
the SAC fine-tuning of a trained student (`--algo finetune`) or SARL (`--algo sarl`).

emonav train --algo dagger --out runs/dagger --seed 0 [--device cpu] [--resume runs/dagger]
emonav train --variant NAME [--out runs/NAME] [--seed 0] [--resume runs/NAME]
emonav train --algo sac [--config FILE] [--plant lip|digit] [--steps N] [--device cpu|cuda]
             [--envs W] [--ray-address ADDR] [--out DIR] [--resume DIR]
emonav train --algo finetune --init PATH|shipped|VARIANT [--config FILE] [--steps N]
             [--device cpu|cuda] [--out DIR] [--resume DIR]
emonav train --algo sarl [--config FILE] [--seed 0] [--device cpu|cuda] [--out DIR]
             [--resume DIR]
"""

from __future__ import annotations

import argparse
import shlex
import sys
from pathlib import Path

from emonav_drake.atomic_io import check_output_dir
from emonav_drake.cli.common import SeedArg
from emonav_drake.cli.resolve import add_sensor
from emonav_drake.diagrams.plants import PLANTS
from emonav_drake.params import ConfigError
from emonav_drake.planners.variants import VARIANTS, variant
from emonav_drake.run_lock import training_run_directory


def add_parser(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Register `emonav train` on the CLI's sub-parsers."""
    t = subparsers.add_parser(
        "train",
        help="train a navigation policy (SAC, the CPU DAgger route, or SAC fine-tuning of a "
        "trained student)",
    )
    t.add_argument(
        "--algo",
        choices=["sac", "dagger", "finetune", "sarl"],
        help="sac (default), dagger (the CPU route), finetune (discrete SAC on a trained "
        "categorical student, --init) or sarl (CrowdNav's SARL: imitation, then value "
        "learning)",
    )
    t.add_argument(
        "--init",
        help="--algo finetune: the student to fine-tune: a policy file, shipped (the shipped "
        "LGM policy) or a shipped variant's name (e.g. emobipednav_digit); required unless "
        "--resume",
    )
    t.add_argument(
        "--variant",
        choices=list(VARIANTS),
        help="train one of the paper's observation variants by the CPU route of the shipped "
        "policy (--algo dagger with emonav_drake/configs/variants/NAME.yaml; default --out "
        "runs/NAME)",
    )
    t.add_argument(
        "--config",
        type=Path,
        help="YAML training configuration: top-level SacConfig fields for --algo sac, "
        "DaggerConfig fields for --algo dagger, FinetuneConfig fields for --algo finetune, "
        "SarlConfig fields for --algo sarl "
        "(e.g. emonav_drake/configs/finetune_digit.yaml; every field is commented in "
        "emonav_drake/learning/config.py; a DAgger route picks its world with `setting` and "
        "`family`)",
    )
    t.add_argument(
        "--steps",
        type=int,
        help="SAC or fine-tuning environment steps, >= 1 (default from the config)",
    )
    t.add_argument(
        "--plant",
        choices=list(PLANTS),
        help="--algo sac: train on EmoNavLIP-v0 (lip, the default) or on the full-order "
        "Digit, EmoNavDigit-v0 (digit: the paper's Digit/Digit route, a GPU or cluster job)",
    )
    t.add_argument(
        "--envs",
        type=int,
        help="--algo sac: environments stepped together (num_envs; > 1 runs them on Ray)",
    )
    t.add_argument(
        "--ray-address",
        help="--algo sac with num_envs > 1: step the environments on this Ray cluster "
        "(e.g. auto or HOST:6379; default: a local Ray)",
    )
    t.add_argument(
        "--seed",
        action=SeedArg,
        help="seed of the run, in [0, 2**64 - 1] (default: the --config's seed, 0; with "
        "--resume: the run's own)",
    )
    t.add_argument(
        "--device", help="cpu or cuda (cuda:N) (default cpu; with --resume: the run's own)"
    )
    add_sensor(t)  # the training configuration's `sensor`: the training world's LiDAR
    t.add_argument(
        "--out",
        type=Path,
        help="run directory, new or empty (default: runs/train, or runs/NAME with --variant); "
        "a directory that holds files is refused unless --overwrite",
    )
    t.add_argument(
        "--overwrite",
        action="store_true",
        help="start a new run in --out although it holds one: the previous run's files "
        "(states, policies, history, learning curve) are removed, other files kept",
    )
    t.add_argument(
        "--resume",
        type=Path,
        help="continue the run in this directory, with its own configuration (route and "
        "--config are read from the run; flags given override them)",
    )
    t.set_defaults(func=cmd_train)
    return t


# The state file each route keeps in its run directory: what `--resume` reads.
STATE_FILES = {
    "sac": "checkpoint.pt",
    "dagger": "dagger_state.pt",
    "finetune": "finetune_state.pt",
    "sarl": "sarl_state.pt",
}


def _resumed_algo(resume: Path) -> str:
    """The route of the run in `resume`, from the state file it holds."""
    if not resume.is_dir():
        raise ConfigError(f"--resume {resume}: no such run directory")
    found = [algo for algo, name in STATE_FILES.items() if (resume / name).is_file()]
    if len(found) != 1:
        names = ", ".join(STATE_FILES.values())
        what = "none of" if not found else "more than one of"
        raise ConfigError(
            f"--resume {resume}: holds {what} the training states ({names}); give --algo"
        )
    return found[0]


def _apply_variant(args: argparse.Namespace) -> None:
    """--variant NAME → --algo dagger --config <the variant's YAML>, --out runs/NAME; a
    --resume without --algo takes the route of the run it continues."""
    if args.variant is None:
        if args.algo is None and args.resume is not None:
            args.algo = _resumed_algo(args.resume)
        args.algo = args.algo or "sac"
        if args.out is None:
            args.out = Path("runs/train")
        return
    if args.config is not None:
        raise ConfigError(
            f"--variant {args.variant} brings its configuration "
            f"({variant(args.variant).config.name}); --config cannot be combined with it"
        )
    if args.algo in ("sac", "finetune"):
        raise ConfigError(f"--variant trains by the CPU route: drop --algo {args.algo}")
    args.algo, args.config = "dagger", variant(args.variant).config
    if args.out is None:
        args.out = Path("runs") / args.variant


def _training_config(args: argparse.Namespace):
    """The typed configuration with the command-line overrides, validated (field named)."""
    from emonav_drake.typed_yaml import load_typed_yaml

    if args.algo == "dagger":
        from emonav_drake.learning.config import DaggerConfig as schema

        if args.steps is not None:
            raise ConfigError("--steps applies to --algo sac only (DAgger counts rounds)")
        if args.ray_address is not None or args.envs is not None:
            flag = "--envs" if args.envs is not None else "--ray-address"
            raise ConfigError(f"{flag} applies to --algo sac only")
        if args.plant is not None:
            raise ConfigError(
                "--plant applies to --algo sac only (the CPU route learns Digit's dynamics "
                "through its calibrated world: `response: digit` in its configuration)"
            )
    elif args.algo == "finetune":
        from emonav_drake.learning.sac_config import FinetuneConfig as schema

        _refuse_sac_flags(
            args,
            ("--plant", "--envs", "--ray-address"),
            "fine-tuning learns in the reduced world of its configuration's `response`",
        )
    elif args.algo == "sarl":
        from emonav_drake.learning.config import SarlConfig as schema

        _refuse_sac_flags(
            args,
            ("--steps", "--plant", "--envs", "--ray-address"),
            "SARL learns in the LIP world and counts episodes: il_episodes, rl_episodes in "
            "its --config",
        )
    else:
        from emonav_drake.learning.sac_config import SacConfig as schema
    _check_init(args)
    # code only from the command line: a route's YAML or a run's saved state that names
    # planner modules is refused unless they are given with --planner-module (checked
    # before anything is imported: validating a configuration imports its modules)
    given = list(getattr(args, "planner_modules", None) or [])
    saved = None
    if args.resume is not None and args.algo in ("dagger", "sarl"):
        saved = _saved_config(args.resume, args.algo, schema, given)
    if args.config is not None:
        from emonav_drake.cli.resolve import check_input_file

        check_input_file(args.config, "--config")  # missing, a symlink loop: the flag named
        cfg = load_typed_yaml(schema, path=args.config)
        if hasattr(cfg, "planner_modules"):
            from emonav_drake.planners.plugins import require_named_on_command_line

            cfg.planner_modules = require_named_on_command_line(
                cfg.planner_modules, given, args.config
            )
    elif args.resume is not None and args.variant is None:
        cfg = saved if saved is not None else _saved_config(args.resume, args.algo, schema)
    else:
        cfg = schema()
    if args.steps is not None and args.steps < 1:
        raise ConfigError(f"--steps {args.steps}: must be >= 1")
    if args.seed is not None:  # else the configuration's (0 by default; a run's own)
        cfg.seed = args.seed
    if args.device is not None:
        cfg.device = args.device
    if args.sensor is not None:  # every route's world: its configuration's `sensor`
        cfg.sensor = args.sensor
    if args.steps is not None:
        cfg.total_steps = args.steps
    if args.plant is not None:
        cfg.plant = args.plant
    if args.planner_modules:
        if args.algo not in ("dagger", "sarl"):
            raise ConfigError(
                "--planner-module applies to --algo dagger and sarl (a planner as expert)"
            )
        from emonav_drake.planners.plugins import import_planner_modules

        recorded = import_planner_modules(args.planner_modules)
        cfg.planner_modules = list(dict.fromkeys([*cfg.planner_modules, *recorded]))
    if args.envs is not None:
        from emonav_drake.config_fields import field_range
        from emonav_drake.learning.sac_config import SacConfig

        low, high = field_range(SacConfig, "num_envs")
        if not low <= args.envs <= high:
            raise ConfigError(f"--envs {args.envs}: must be in [{low}, {high}]")
        cfg.num_envs = args.envs
    where = f"{args.config}: " if args.config else ""
    try:
        cfg.validate()
    except ConfigError as e:
        raise ConfigError(f"{where}{e}") from None
    return cfg


def _saved_config(run: Path, algo: str, schema: type, given: list[str] | None = None):
    """The configuration the run in `run` was started with (its state file's `config`),
    checked as a --config file would be; `RunStateError` if the state cannot be read.

    `given`: the command line's `--planner-module` values; the saved configuration's
    `planner_modules` must be among them (`ConfigError` naming the state file otherwise),
    checked before it is validated (which imports them)."""
    import json

    from emonav_drake.learning.run_state import RunStateError, read_state_config
    from emonav_drake.planners.plugins import require_named_on_command_line
    from emonav_drake.typed_yaml import load_typed_yaml

    name = STATE_FILES[algo]
    given = list(given or [])
    if not (run / name).is_file():
        return schema()  # the trainer says there is nothing to resume
    if algo == "dagger":  # the routes with a reader of their own: the same checks
        from emonav_drake.learning.dagger_state import read_dagger_state

        return read_dagger_state(run / name, command_line=given)[0]
    if algo == "finetune":
        from emonav_drake.learning.finetune_state import read_finetune_state

        return read_finetune_state(run / name)[0]
    saved = read_state_config(run / name)
    require_named_on_command_line(saved.get("planner_modules"), given, f"{run / name} (config)")
    try:
        if hasattr(schema, "from_saved"):  # a configuration with a planner spec (SARL's)
            return schema.from_saved(saved)
        return load_typed_yaml(schema, data=json.dumps(saved))
    except ConfigError as e:
        raise RunStateError(
            f"{name} in {run}: its configuration does not load ({e}); give --config"
        ) from None


def _refuse_sac_flags(args: argparse.Namespace, flags: tuple[str, ...], why: str) -> None:
    """`ConfigError` for the first of `flags` (SAC-only options) that was given."""
    for flag in flags:
        if getattr(args, flag.lstrip("-").replace("-", "_")) is not None:
            raise ConfigError(f"{flag} applies to --algo sac only ({why})")


def _check_init(args: argparse.Namespace) -> None:
    """--init: required by a new --algo finetune run, refused otherwise."""
    if args.algo != "finetune":
        if args.init is not None:
            raise ConfigError(
                f"--init applies to --algo finetune only (--algo {args.algo}"
                + (": `init_policy` in its --config)" if args.algo == "dagger" else ")")
            )
        return
    if args.resume is not None and args.init is not None:
        raise ConfigError(
            f"--init {args.init}: a resumed run continues from the state in {args.resume} "
            "(which records its initial policy): drop --init"
        )
    if args.resume is None and args.init is None:
        raise ConfigError(
            "--algo finetune needs --init: the categorical student to fine-tune (a policy "
            "file, shipped, or a shipped variant's name such as emobipednav_digit)"
        )


def resume_command(args: argparse.Namespace, out: Path) -> str:
    """The `emonav train` command that continues the run in `out`: the same route
    (`--variant`, or `--algo` and `--config`) and command-line overrides."""
    words = ["emonav", "train"]
    if args.variant is not None:
        words += ["--variant", args.variant]
    else:
        words += ["--algo", args.algo]
        if args.config is not None:
            words += ["--config", str(args.config)]
    for flag, value in (
        ("--plant", args.plant),
        ("--steps", args.steps),
        ("--envs", args.envs),
        ("--ray-address", args.ray_address),
        ("--seed", args.seed or None),
        ("--device", None if args.device in (None, "cpu") else args.device),
        ("--sensor", args.sensor),
    ):
        if value is not None:
            words += [flag, str(value)]
    return shlex.join([*words, "--resume", str(out)])


def cmd_train(args: argparse.Namespace) -> int:
    """Train by the chosen route into --out (or continue --resume)."""
    from emonav_drake.torch_device import resolve_device

    _apply_variant(args)
    if args.resume is not None:
        if args.overwrite:
            raise ConfigError("--overwrite starts a new run: it cannot be combined with --resume")
        if not args.resume.is_dir():
            raise ConfigError(f"--resume {args.resume}: no such run directory")
    cfg = _training_config(args)
    resolve_device(cfg.device)
    if args.resume is not None:
        out = args.resume
    else:
        out = check_output_dir(args.out, "--out")
    flag = "--resume" if args.resume else "--out"
    with training_run_directory(out, args.resume is not None, args.overwrite, flag):
        return _run_training(args, cfg, out)


def _run_training(args: argparse.Namespace, cfg, out: Path) -> int:
    """The chosen trainer, into the locked run directory `out`."""
    command = "emonav " + " ".join(shlex.quote(a) for a in sys.argv[1:])
    if args.algo == "finetune":
        from emonav_drake.learning.finetune import train_finetune
        from emonav_drake.learning.finetune_agent import load_init
        from emonav_drake.params import EmoNavConfig

        if args.resume is None:
            load_init(args.init, EmoNavConfig(), cfg.device, "--init")  # before --out exists
        path = train_finetune(
            out,
            cfg,
            init=args.init,
            resume=args.resume is not None,
            command=command,
            resume_command=resume_command(args, out),
        )
        print(f"policy written to {path}")
        return 0
    if args.algo == "sarl":
        from emonav_drake.learning.sarl_train import train_sarl

        path = train_sarl(out, cfg, resume=args.resume is not None, command=command)
        print(f"SARL checkpoint written to {path}")
        return 0
    if args.algo == "dagger":
        from emonav_drake.learning.dagger import train_dagger

        path = train_dagger(
            out,
            cfg,
            resume=args.resume is not None,
            command=command,
            variant=args.variant,
            resume_command=resume_command(args, out),
        )
        print(f"policy written to {path}")
        return 0
    from emonav_drake.learning.sac_trainer import train_sac

    train_sac(
        out,
        cfg,
        resume=args.resume is not None,
        ray_address=args.ray_address,
        resume_command=resume_command(args, out),
    )
    return 0
