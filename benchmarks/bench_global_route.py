"""Global route planning time (one core): the visibility-graph planner of
`core/global_route.py` on three maps, against the 50 ms budget for a 3-room floor.

    .venv/bin/python benchmarks/bench_global_route.py [--repeats 21]

Maps: one wall between start and goal; an L-shaped corridor (a corner); a floor of three
4 × 4 m rooms in a row, doors 1.2 m wide, one static disc (start in the first room, goal
in the last). Prints the median and the 90th percentile per map and sample count.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from emonav_drake.core.global_route import StaticMap, plan_route, route_length  # noqa: E402

BUDGET_MS = 50.0
CLEARANCE = 0.35


def maps() -> dict[str, tuple[StaticMap, list[float], list[float]]]:
    wall = StaticMap.of([[[0, -1], [0, 1]]])
    corner = StaticMap.of(
        [[[0, 0], [6, 0]], [[6, 0], [6, 6]], [[0, 2], [4, 2]], [[4, 2], [4, 6]]]
    )  # an L: along x at y 0-2, then up x 4-6
    floor = StaticMap.of(
        [
            [[0, 0], [12, 0]],
            [[12, 0], [12, 4]],
            [[12, 4], [0, 4]],
            [[0, 4], [0, 0]],
            [[4, 0], [4, 1.4]],
            [[4, 2.6], [4, 4]],
            [[8, 0], [8, 2.6]],
            [[8, 3.8], [8, 4]],
        ],
        [[6.0, 1.5]],
        [0.4],
    )
    return {
        "one wall": (wall, [-2, 0], [2, 0]),
        "L corridor": (corner, [0.5, 1.0], [5.0, 5.5]),
        "3-room floor": (floor, [1, 1], [11, 1]),
    }


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--repeats", type=int, default=21)
    args = p.parse_args()
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    print(f"budget: {BUDGET_MS:.0f} ms per route on the 3-room floor (one core)")
    for name, (m, start, goal) in maps().items():
        for samples in (8, 16):
            times = []
            for _ in range(args.repeats):
                t0 = time.perf_counter()
                route = plan_route(start, goal, m, CLEARANCE, samples=samples)
                times.append(1000 * (time.perf_counter() - t0))
            p90 = float(np.percentile(times, 90))
            print(
                f"{name:>13s}, {samples:2d} samples: median {statistics.median(times):6.2f} ms, "
                f"p90 {p90:6.2f} ms, route {route_length(route):.2f} m, {len(route)} points"
            )
    return 0


if __name__ == "__main__":
    sys.exit(main())
