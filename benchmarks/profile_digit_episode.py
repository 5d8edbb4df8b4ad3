"""Where a Digit navigation episode's wall time goes: a native profile, by part of the loop.

    .venv/bin/python benchmarks/profile_digit_episode.py [--seed 1001] [--planner dwa]
        [--config F.yaml] [--rate 200] [--raw out.txt]

Samples `emonav sim --plant digit --planner P --seed S` with py-spy (`--native`: Drake's
C++ frames too, `--rate` samples per second of wall time) and sorts every sample into one
part, the first of `PARTS` that any frame of its stack belongs to: the start (imports,
building the diagram), the passivity controller (Python, evaluated inside the plant's
step as its actuation input), the plant's step (SAP contact solve and dynamics), the
other systems, and the rest (the framework's dispatch, Python's garbage collector, output
ports). Prints the share of each, of all samples and of the loop (all but the start).

The shares hold on a shared machine (every part is slowed alike); the absolute times do
not: `benchmarks/bench_digit_speed.py` measures real-time factors, pinned and interleaved.
py-spy is a development dependency (BUILD.md).
"""

from __future__ import annotations

import argparse
import collections
import re
import shutil
import subprocess
import sys
import tempfile
from collections.abc import Callable
from pathlib import Path

# (part, whether a frame's name belongs to it); the first that matches a stack wins
PARTS: list[tuple[str, Callable[[str], bool]]] = [
    ("start: imports, building the diagram", lambda n: "_find_and_load" in n or n == "Build"),
    ("passivity controller (Python, in the plant's step)", lambda n: "PassivityController" in n),
    ("ALIP footstep planner", lambda n: "AlipFootstepPlanner" in n),
    ("fall monitor", lambda n: "FallMonitor" in n),
    ("navigation planner", lambda n: "NavigationPlanner" in n or n.startswith("DwaPlanner")),
    ("crowd (ORCA)", lambda n: "CrowdSystem" in n),
    ("LiDAR grid maps", lambda n: "LidarGridMapBuilder" in n),
    ("episode monitor", lambda n: "EpisodeMonitor" in n),
    (
        "plant: SAP contact solve and dynamics",
        lambda n: "SapDriver" in n or "MultibodyPlant<double>::CalcStep" in n,
    ),
]
REST = "the rest: dispatch, state copies, gc, outputs"
START = PARTS[0][0]


def parts_of(raw: str) -> tuple[collections.Counter, int]:
    """Samples per part of py-spy's raw (collapsed) output, and the total."""
    shares: collections.Counter = collections.Counter()
    total = 0
    for line in raw.splitlines():
        stack, _, count = line.rstrip().rpartition(" ")
        if not stack:
            continue
        n = int(count)
        total += n
        names = [re.sub(r" \(.*", "", f) for f in stack.split(";")]
        part = next((p for p, belongs in PARTS if any(belongs(x) for x in names)), REST)
        shares[part] += n
    return shares, total


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, default=1001)
    ap.add_argument("--planner", default="dwa")
    ap.add_argument("--config", type=Path, help="a configuration YAML for emonav sim")
    ap.add_argument("--rate", type=int, default=200, help="py-spy samples per second")
    ap.add_argument("--raw", type=Path, help="keep py-spy's raw output here")
    args = ap.parse_args()
    bin_dir = Path(sys.executable).parent
    spy = shutil.which("py-spy", path=str(bin_dir)) or shutil.which("py-spy")
    if spy is None:
        sys.exit("py-spy is not installed: .venv/bin/pip install py-spy (a dev dependency)")
    sim = [str(bin_dir / "emonav"), "sim", "--plant", "digit", "--planner", args.planner]
    sim += ["--seed", str(args.seed), "--quiet"]
    if args.config:
        sim += ["--config", str(args.config)]
    with tempfile.TemporaryDirectory() as tmp:
        raw_path = args.raw or Path(tmp) / "raw.txt"
        cmd = [spy, "record", "--native", "-r", str(args.rate), "-f", "raw", "-o", str(raw_path)]
        subprocess.run([*cmd, "--", *sim], check=True)
        shares, total = parts_of(raw_path.read_text())
    loop = total - shares[START]
    print(f"{total} samples at {args.rate}/s; `{' '.join(sim[1:])}`")
    print(f"{'part':58s} {'of all':>7s} {'of the loop':>12s}")
    for part, n in shares.most_common():
        of_loop = "" if part == START else f"{100 * n / loop:11.1f}%"
        print(f"{part:58s} {100 * n / total:6.1f}% {of_loop:>12s}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
