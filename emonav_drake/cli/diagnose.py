"""`emonav diagnose`: why a Digit benchmark run's trials failed (cause, tracking errors).

emonav diagnose RUN [--methods M,…] [--last 5] [--reference 10] --out DIR
"""

from __future__ import annotations

import argparse
from pathlib import Path

from emonav_drake.params import ConfigError


def add_parser(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Register `emonav diagnose` on the CLI's sub-parsers."""
    d = subparsers.add_parser(
        "diagnose",
        help="why Digit trials failed: cause and tracking errors (re-simulates failures)",
    )
    d.add_argument("run", type=Path, help="a Digit benchmark run directory")
    d.add_argument("--methods", help="comma-separated methods (default: all of the run)")
    d.add_argument("--last", type=int, default=5, help="walking steps before the end (>= 1)")
    d.add_argument(
        "--reference", type=int, default=10, help="successful trials per method to compare"
    )
    d.add_argument("--out", type=Path, required=True, help="output directory")
    d.set_defaults(func=cmd_diagnose)
    return d


def cmd_diagnose(args: argparse.Namespace) -> int:
    """Re-simulate the run's failures; print the table, write diagnosis.{json,md,png}."""
    from emonav_drake.evaluation.diagnosis import diagnose_run, diagnosis_table

    if args.last < 1 or args.reference < 0:
        raise ConfigError("--last must be >= 1 and --reference >= 0")
    if not (args.run / "settings.json").is_file():
        raise ConfigError(f"{args.run}: not a benchmark run directory (no settings.json)")
    methods = args.methods.split(",") if args.methods else None
    rows = diagnose_run(args.run, args.out, methods, args.last, args.reference)
    print(diagnosis_table(rows))
    print(f"written: {args.out}/diagnosis.json, diagnosis.md, diagnosis.png")
    return 0
