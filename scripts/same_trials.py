"""Are two benchmark runs the same trial for trial? (refactors must not change results)

Reads the `trials.jsonl` of two run directories (`emonav benchmark --out`), takes the
(method, seed) pairs both hold, and compares their lines without the wall time
(`run_directory.comparable`): outcome, steps, times, distances, IDT, rewards — every
number of the record both runs have, bit for bit (fields only one has, such as metrics
added since, are named and left out). Prints one line per method and exits 1 on any
difference (listing the first few).

    python scripts/same_trials.py benchmarks/results/lip_table2 runs/after_lip
"""

from __future__ import annotations

import argparse
import sys
from collections import Counter
from pathlib import Path

from emonav_drake.evaluation.run_directory import comparable, read_trials, trial_key


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("before", type=Path, help="run directory")
    ap.add_argument("after", type=Path, help="run directory")
    ap.add_argument(
        "--rename",
        action="append",
        default=[],
        metavar="OLD=NEW",
        help="a method of `before` under another name in `after` (e.g. sac=policy: runs "
        "before the shipped policy's rename)",
    )
    args = ap.parse_args()
    rename = dict(item.split("=", 1) for item in args.rename)
    old = read_trials(args.before / "trials.jsonl")
    for t in old:
        t["method"] = rename.get(t["method"], t["method"])
    before = {trial_key(t): comparable(t) for t in old}
    after = {trial_key(t): comparable(t) for t in read_trials(args.after / "trials.jsonl")}
    shared = sorted(set(before) & set(after))
    if not shared:
        print("no (method, seed) pair in common")
        return 1
    # Record fields one run has and the other lacks (metrics added since): compared only
    # where both have them, and named.
    new = sorted({f for k in shared for f in after[k]["record"]} - _fields(before, shared))
    gone = sorted(_fields(before, shared) - {f for k in shared for f in after[k]["record"]})
    if new or gone:
        print(f"record fields only after: {new or '-'}; only before: {gone or '-'}")
        for k in shared:
            for f in new:
                after[k]["record"].pop(f, None)
            for f in gone:
                before[k]["record"].pop(f, None)
    differ = [k for k in shared if before[k] != after[k]]
    per_method = Counter(m for m, _ in shared)
    bad = Counter(m for m, _ in differ)
    for m, n in sorted(per_method.items()):
        print(f"{m}: {n} shared trials, {n - bad[m]} identical, {bad[m]} differ")
    for k in differ[:5]:
        fields = sorted(
            f
            for f in set(before[k]["record"]) | set(after[k]["record"])
            if before[k]["record"].get(f) != after[k]["record"].get(f)
        )
        print(f"  {k}: record fields differ: {fields}")
    print("IDENTICAL" if not differ else f"{len(differ)} of {len(shared)} trials differ")
    return 0 if not differ else 1


def _fields(trials: dict, keys: list) -> set[str]:
    return {f for k in keys for f in trials[k]["record"]}


if __name__ == "__main__":
    sys.exit(main())
