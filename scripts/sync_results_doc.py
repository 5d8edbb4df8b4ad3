"""Rewrite the measured tables quoted in docs/*.md from their benchmark run directories.

    python scripts/sync_results_doc.py          # rewrite stale blocks, list them
    python scripts/sync_results_doc.py --check  # exit 1 if any block is stale

See `emonav_drake/evaluation/results_doc.py` for the block syntax.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from emonav_drake.evaluation.results_doc import check, sync

ROOT = Path(__file__).resolve().parent.parent


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__)
    p.add_argument("--check", action="store_true", help="only report stale blocks")
    args = p.parse_args()
    stale_any = False
    for doc in sorted((ROOT / "docs").glob("*.md")):
        stale = check(doc, ROOT) if args.check else sync(doc, ROOT)
        for block in stale:
            stale_any = True
            print(f"{doc.relative_to(ROOT)}: {'stale' if args.check else 'updated'} {block}")
    return 1 if (args.check and stale_any) else 0


if __name__ == "__main__":
    sys.exit(main())
