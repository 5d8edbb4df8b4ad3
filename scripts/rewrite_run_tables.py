"""Rewrite the tables of committed benchmark runs after the tables' format changed.

    python scripts/rewrite_run_tables.py [RUN_DIR ...]   # default: benchmarks/results/*

A run directory (`settings.json` + `trials.jsonl`) gets its `tables.md` and CSVs written
again from its own trials and settings (`RunDirectory.write_tables`), so they show what
today's tables show (e.g. the column saying what each method reads and whether a robot
could run it) while every number stays the run's. A comparison directory of `emonav
compare` (`combined.json`) is combined again from its runs, found beside it under
`benchmarks/results/`. Nothing is simulated. Then `python scripts/sync_results_doc.py`
brings the quotes in docs/ up to date.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from emonav_drake.evaluation.combine import combine_runs  # noqa: E402
from emonav_drake.evaluation.run_directory import (  # noqa: E402
    ERRORS_FILE,
    RunDirectory,
    load_run,
)

RESULTS = ROOT / "benchmarks" / "results"


def rewrite(run: Path) -> str:
    """Rewrite one directory's tables; what was done, in words."""
    if (run / "settings.json").is_file():
        settings, trials = load_run(run)
        errors = run / ERRORS_FILE
        failed = len(errors.read_text().splitlines()) if errors.is_file() else 0
        old = (run / "tables.md").read_text() if (run / "tables.md").is_file() else ""
        RunDirectory(run).write_tables(
            settings, trials, interrupted="INTERRUPTED" in old, failed=failed
        )
        return f"{run.name}: {len(trials)} trials"
    if (run / "combined.json").is_file():
        recorded = json.loads((run / "combined.json").read_text())
        sources = [RESULTS / Path(r["path"]).name for r in recorded["runs"]]
        settings, trials = combine_runs(sources)
        RunDirectory(run).write_tables(settings, trials)
        return f"{run.name}: combined from {', '.join(s.name for s in sources)}"
    return f"{run.name}: not a run directory, skipped"


def main() -> int:
    runs = [Path(a) for a in sys.argv[1:]] or sorted(p for p in RESULTS.iterdir() if p.is_dir())
    for run in runs:
        if (run / "tables.md").is_file():
            print(rewrite(run))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
