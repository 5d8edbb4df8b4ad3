"""`emonav calibrate collect|fit`: Digit traces → the step-response model of the robot.

`DESCRIPTION` is its `--help` text (it also names `emonav digit-rounds`, in digit_rounds.py).
See `emonav_drake/learning/calibration.py`.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from emonav_drake.cli.common import SeedArg, check_workers, parse_methods
from emonav_drake.params import ConfigError

DESCRIPTION = """\
`emonav calibrate`: Digit traces → the step-response model of the calibrated robot.

emonav calibrate collect --planners dwa,policy --episodes 20 --first-seed 3000000
                         [--explore 0.3] [--workers W] [--ray-address ADDR] --out TRACES
emonav calibrate fit TRACES [TRACES …] [--held-out 0.25] --out MODEL.json
emonav digit-rounds --from RUN --rounds 2 --episodes 60 [--workers W] --out DIR [--resume]

How the model is fitted and used: docs/learning.md ("Learning with Digit's dynamics").
"""


def add_parser(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Register `emonav calibrate` (verbs `collect`, `fit`) on the CLI's sub-parsers."""
    c = subparsers.add_parser(
        "calibrate",
        help="fit the Digit step-response model from traced Digit episodes",
        description=DESCRIPTION,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    verbs = c.add_subparsers(dest="verb", required=True)
    col = verbs.add_parser("collect", help="run traced, exploring Digit episodes (resumable)")
    col.add_argument("--planners", default="dwa,policy", help="comma-separated planners")
    col.add_argument("--episodes", type=int, default=20, help="episodes per planner (>= 1)")
    col.add_argument(
        "--first-seed",
        action=SeedArg,
        default=3_000_000,
        help="episode i plays the scenario of seed first-seed + i (keep clear of the "
        "evaluation seeds 0-499 and the training and selection seeds)",
    )
    col.add_argument(
        "--explore",
        type=float,
        default=0.3,
        help="fraction of steps with a random command, in [0, 1]",
    )
    col.add_argument(
        "--workers", type=int, default=1, help="parallel Ray workers, >= 1 (1: serial)"
    )
    col.add_argument("--ray-address", help="run on this Ray cluster")
    col.add_argument("--out", type=Path, required=True, help="trace file (JSONL), extended")
    col.set_defaults(func=cmd_collect)
    fit = verbs.add_parser("fit", help="fit the model; report held-out errors")
    fit.add_argument("traces", type=Path, nargs="+")
    fit.add_argument(
        "--held-out", type=float, default=0.25, help="fraction of episodes held out, in (0, 1)"
    )
    fit.add_argument("--out", type=Path, required=True, help="model + report (JSON)")
    fit.set_defaults(func=cmd_fit)
    return c


def cmd_collect(args: argparse.Namespace) -> int:
    """Run traced, exploring Digit episodes into --out; print the summary as JSON."""
    from emonav_drake.learning.calibration import collect_traces

    check_workers(args.workers, args.ray_address)
    summary = collect_traces(
        args.out,
        parse_methods(args.planners),
        args.episodes,
        args.first_seed,
        explore=args.explore,
        workers=args.workers,
        ray_address=args.ray_address,
    )
    print(json.dumps(summary))
    return 0


def cmd_fit(args: argparse.Namespace) -> int:
    """Fit the step-response model to the traces; write it to --out, print the errors."""
    from emonav_drake.atomic_io import check_output_file
    from emonav_drake.learning.calibration import fit_response

    for p in args.traces:
        if not p.is_file():
            raise ConfigError(f"{p}: no such trace file")
    check_output_file(args.out, "--out")
    report = fit_response(args.traces, args.held_out, args.out)
    print(json.dumps({k: report[k] for k in ("fit", "held_out", "residual_std")}, indent=2))
    return 0
