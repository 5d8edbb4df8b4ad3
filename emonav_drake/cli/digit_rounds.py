"""`emonav digit-rounds`: DAgger rounds on the full-order Digit after the calibrated route.

emonav digit-rounds --from RUN --rounds 2 --episodes 60 [--workers W] --out DIR [--resume]
                    [--planner-module MODULE]

See `emonav_drake/learning/digit_dagger.py`. A source run whose expert is a planner of the
user's own (`planner_modules` in its saved configuration) is continued only when the same
modules are given with `--planner-module`: a run directory never makes us import code.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from emonav_drake.atomic_io import check_output_dir
from emonav_drake.cli.common import SeedArg, check_workers
from emonav_drake.params import ConfigError
from emonav_drake.run_lock import training_run_directory


def add_parser(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Register `emonav digit-rounds` on the CLI's sub-parsers."""
    r = subparsers.add_parser(
        "digit-rounds",
        help="DAgger rounds on the full-order Digit after the calibrated route (Ray)",
    )
    r.add_argument(
        "--from",
        dest="source",
        type=Path,
        required=True,
        help="the calibrated DAgger run (its dagger_state.pt and policy.pt)",
    )
    r.add_argument("--rounds", type=int, default=2, help="Digit rounds, >= 1")
    r.add_argument("--episodes", type=int, default=60, help="Digit episodes per round, >= 1")
    r.add_argument(
        "--first-seed",
        action=SeedArg,
        default=4_000_000,
        help="round r's episodes play seeds first-seed + r * episodes + i",
    )
    r.add_argument(
        "--beta",
        type=float,
        default=0.25,
        help="expert-acting probability in round 0, in [0, 1] (halved every round)",
    )
    r.add_argument("--grad-steps", type=int, default=1500, help="gradient steps per round, >= 1")
    r.add_argument("--workers", type=int, default=1, help="parallel Ray workers, >= 1")
    r.add_argument("--ray-address")
    r.add_argument(
        "--out", type=Path, required=True, help="run directory: new or empty, unless --resume"
    )
    r.add_argument("--resume", action="store_true", help="continue the rounds in --out")
    r.set_defaults(func=cmd_digit_rounds)
    return r


def cmd_digit_rounds(args: argparse.Namespace) -> int:
    """Run (or --resume) the Digit DAgger rounds from --from's run; print the policy path."""
    from emonav_drake.learning.digit_dagger import run_digit_rounds
    from emonav_drake.learning.digit_rounds_config import DigitRoundsConfig

    cfg = DigitRoundsConfig(
        rounds=args.rounds,
        episodes=args.episodes,
        first_seed=args.first_seed,
        beta=args.beta,
        grad_steps=args.grad_steps,
    ).validate()
    check_workers(args.workers, args.ray_address)
    if not (args.source / "dagger_state.pt").is_file():
        raise ConfigError(f"--from {args.source}: no DAgger run there (dagger_state.pt)")
    check_output_dir(args.out, "--out")
    with training_run_directory(args.out, args.resume):  # a new run: an empty --out only
        # before any work (a refused new --out is removed again, empty)
        _check_planner_modules(args.source, list(getattr(args, "planner_modules", None) or []))
        policy = run_digit_rounds(
            args.out, args.source, cfg, args.workers, args.ray_address, resume=args.resume
        )
    print(f"policy written to {policy}")
    return 0


def _check_planner_modules(source: Path, given: list[str]) -> None:
    """Before any work (nothing imported, nothing written): the source run's DAgger state
    is readable and its configuration names no planner module that is not among `given`
    (`--planner-module`; `ConfigError` naming its dagger_state.pt otherwise)."""
    from emonav_drake.learning.dagger_state import STATE_FILE, read_dagger_state

    read_dagger_state(source / STATE_FILE, command_line=given)
