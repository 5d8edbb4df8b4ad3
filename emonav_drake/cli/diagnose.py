"""`emonav diagnose`: a benchmark run's failed trials (LIP or Digit) and why they failed.

emonav diagnose RUN --failures [--methods M,…] [--rerun 3]
emonav diagnose RUN [--methods M,…] [--last 5] [--reference 10] --out DIR [--failures]

`--failures` lists, per method, the failed trials from the run's records (seed, outcome
and cause, steps, smallest pedestrian distance) and the `emonav sim` command that plays
the first few again; it simulates nothing. `--out` simulates every failure again: its
cause on both plants, and on Digit the tracking errors against the planner's LIP model
(skipped on a LIP run, with a line saying so). A run of planners of the user's own
(`planner_modules` in its settings.json) is simulated only when the same modules are
given with `--planner-module`: a run directory never makes us import code
(`planners.plugins.require_named_on_command_line`).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from emonav_drake.params import ConfigError


def add_parser(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Register `emonav diagnose` on the CLI's sub-parsers."""
    d = subparsers.add_parser(
        "diagnose",
        help="a benchmark run's failed trials (LIP or Digit): list them with the commands "
        "that re-run them (--failures), or re-simulate them for their cause and, on "
        "Digit, the tracking errors (--out)",
    )
    d.add_argument("run", type=Path, help="a benchmark run directory (LIP or Digit)")
    d.add_argument("--methods", help="comma-separated methods (default: all of the run)")
    d.add_argument(
        "--failures",
        action="store_true",
        help="list the failed trials per method: seed, outcome, steps, min pedestrian "
        "distance, and the `emonav sim` command of the first few (no simulation)",
    )
    d.add_argument(
        "--rerun",
        type=int,
        default=3,
        metavar="N",
        help="with --failures: re-run commands printed per method (>= 0, default 3)",
    )
    d.add_argument("--last", type=int, default=5, help="walking steps before the end (>= 1)")
    d.add_argument(
        "--reference",
        type=int,
        default=10,
        help="successful trials per method to compare (Digit runs)",
    )
    d.add_argument(
        "--out",
        type=Path,
        help="simulate the failures again and write diagnosis.{json,md,png}, failures.md "
        "and run_config.yaml into this directory",
    )
    d.set_defaults(func=cmd_diagnose)
    return d


def cmd_diagnose(args: argparse.Namespace) -> int:
    """List the run's failures (--failures) and/or re-simulate them (--out): print the
    list and the table, write diagnosis.{json,md,png}, failures.md, run_config.yaml."""
    from emonav_drake.evaluation.diagnosis import check_methods, diagnose_run, diagnosis_table
    from emonav_drake.evaluation.failures import format_failures
    from emonav_drake.evaluation.run_directory import load_run

    if args.last < 1 or args.reference < 0 or args.rerun < 0:
        raise ConfigError("--last must be >= 1, --reference and --rerun >= 0")
    if args.out is None and not args.failures:
        raise ConfigError(
            "give --failures (list the failed trials) or --out DIR (simulate them again)"
        )
    if args.out is not None:  # a file, a symlink loop, an unwritable folder: named at once
        from emonav_drake.atomic_io import check_output_dir

        check_output_dir(args.out, "--out")
    if not (args.run / "settings.json").is_file():
        raise ConfigError(f"{args.run}: not a benchmark run directory (no settings.json)")
    methods = args.methods.split(",") if args.methods else None
    rows = None
    if args.out is not None:
        _check_planner_modules(args.run, getattr(args, "planner_modules", []))
        # its bar where `emonav` allows bars (cli.main: a terminal, no --quiet)
        rows = diagnose_run(args.run, args.out, methods, args.last, args.reference, True)
    if args.failures:
        settings, trials = load_run(args.run)
        chosen = check_methods(settings, methods)
        run_files = None
        causes = None
        if rows is not None:  # the files written with --out, the re-simulated causes
            from emonav_drake.evaluation.failures import RUN_CONFIG_FILE, RUN_ESTIMATE_FILE

            run_files = {"config": str(args.out / RUN_CONFIG_FILE)}
            if settings.get("emotion_estimate_yaml") is not None:
                run_files["estimate"] = str(args.out / RUN_ESTIMATE_FILE)
            causes = {(r["method"], r["seed"]): r["cause"] for r in rows if r["reproduced"]}
        print(
            format_failures(settings, trials, chosen, args.run, run_files, args.rerun, causes),
            end="",
        )
    if rows is not None:
        if args.failures:
            print()
        print(diagnosis_table(rows), end="")
        print(
            f"written: {args.out}/diagnosis.json, diagnosis.md, diagnosis.png, failures.md, "
            "run_config.yaml"
        )
    return 0


def _check_planner_modules(run: Path, given: list[str]) -> None:
    """Before re-simulating: the run's settings (checked, `RunDirectory.read_settings`)
    name no planner module that is not among `given` (`--planner-module`): `ConfigError`
    naming its settings.json otherwise, and nothing is imported."""
    from emonav_drake.evaluation.run_directory import SETTINGS_FILE, RunDirectory
    from emonav_drake.planners.plugins import require_named_on_command_line

    found = RunDirectory(run).read_settings()
    if found is not None:
        recorded = found[0].get("planner_modules")
        require_named_on_command_line(recorded, given, run / SETTINGS_FILE)
