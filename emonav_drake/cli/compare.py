"""`emonav compare RUN RUN … --out DIR`: benchmark runs made at different times, compared
as one: the tables of all their methods, McNemar on the seeds
each pair shares.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path


def add_parser(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Register `emonav compare` on the CLI's sub-parsers."""
    c = subparsers.add_parser(
        "compare",
        help="combine benchmark runs on the same seeds and settings into one set of tables",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    c.add_argument("runs", type=Path, nargs="+", metavar="RUN", help="benchmark run directories")
    c.add_argument(
        "--out", type=Path, required=True, help="directory for the combined tables (new or empty)"
    )
    c.set_defaults(func=cmd_compare)
    return c


def cmd_compare(args: argparse.Namespace) -> int:
    """Combine the runs; write combined.json (their settings and the runs they came from) and
    the tables."""
    from emonav_drake.atomic_io import check_output_dir, write_json
    from emonav_drake.evaluation.combine import combine_runs
    from emonav_drake.evaluation.run_directory import (
        SETTINGS_FILE,
        TRIALS_FILE,
        BenchmarkSettingsError,
        RunDirectory,
    )

    out = check_output_dir(args.out, "--out")  # a file, a symlink loop: named, at once
    if any((out / f).exists() for f in (SETTINGS_FILE, TRIALS_FILE)):
        raise BenchmarkSettingsError(
            f"--out {out}: already holds a run; give a new or empty directory"
        )
    if any(out.resolve() == r.resolve() for r in args.runs):
        raise BenchmarkSettingsError(f"--out {out} is one of the runs; give another directory")
    settings, trials = combine_runs(args.runs)
    for name, m in settings["merged"].items():  # said, not merged silently
        print(
            f"emonav compare: {name} is in {len(m['runs'])} runs; merged "
            f"({m['shared_trials']} shared trials agree)",
            file=sys.stderr,
        )
    out.mkdir(parents=True, exist_ok=True)
    write_json(out / "combined.json", settings)
    md = RunDirectory(out).write_tables(settings, trials)
    print(md.read_text())
    return 0
