"""`emonav report RUN [RUN …] --out DIR`: benchmark runs side by side, with figures.

Writes `DIR/report.md` (each run's settings and Table II, with what each method reads)
and `DIR/report.png`: SR with its 95 % Wilson interval and DT per trial of every method in
every run, and a heat map of SR by scenario family when the runs differ in family. Any run
directories compare — other seeds, settings or plants (unlike `emonav compare`, which
merges runs of the same trials into one table with McNemar tests). A single run also
gets its own `summary.png` and `social.png` redrawn (as `emonav benchmark` writes them).
"""

from __future__ import annotations

import argparse
from pathlib import Path


def add_parser(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Register `emonav report` on the CLI's sub-parsers."""
    r = subparsers.add_parser(
        "report",
        help="draw and compare benchmark run directories (figures and one Markdown page)",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    r.add_argument("runs", type=Path, nargs="+", metavar="RUN", help="benchmark run directories")
    r.add_argument("--out", type=Path, required=True, help="directory for report.md and .png")
    r.set_defaults(func=cmd_report)
    return r


def cmd_report(args: argparse.Namespace) -> int:
    """Check the runs, then write the report (and a single run's own figures)."""
    from emonav_drake.atomic_io import check_output_dir
    from emonav_drake.evaluation.run_directory import load_run
    from emonav_drake.evaluation.run_figures import write_report, write_run_figures

    out = check_output_dir(args.out, "--out")
    for run in args.runs:
        load_run(run)  # not a run directory: named, before anything is drawn
    md = write_report(args.runs, out)
    print(f"wrote {md} and {md.with_suffix('.png')}")
    if len(args.runs) == 1:
        for path in write_run_figures(args.runs[0]):
            print(f"wrote {path}")
    return 0
