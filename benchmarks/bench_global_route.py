"""Global route planning time (one core): the visibility-graph planner of
`scenarios/global_route.py` on three maps, against the 50 ms budget for a 3-room floor, and
Drake's Graph of Convex Sets on the same floor (`--gcs`): IRIS regions of the free space
(seeded from a 0.5 m grid of free points until every one is covered; built once per map)
and `GcsTrajectoryOptimization` with piecewise-linear segments, the path-length cost and
Clarabel (convex relaxation, 3 rounded paths).

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

from emonav_drake.scenarios.global_route import StaticMap, plan_route, route_length  # noqa: E402

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
    p.add_argument("--gcs", action="store_true", help="also time GCS on the 3-room floor")
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
    if args.gcs:
        gcs_floor(*maps()["3-room floor"], repeats=max(3, args.repeats // 4))
    return 0


def gcs_floor(m: StaticMap, start: list[float], goal: list[float], repeats: int) -> None:
    """IRIS regions of the floor's free space, then GCS shortest paths: the times."""
    import logging

    from pydrake.geometry.optimization import (
        GraphOfConvexSetsOptions,
        HPolyhedron,
        Iris,
        IrisOptions,
        Point,
        VPolytope,
    )
    from pydrake.planning import GcsTrajectoryOptimization

    from emonav_drake.scenarios.global_route import _free

    logging.getLogger("drake").setLevel(logging.WARNING)
    obstacles = []
    for a, b in m.walls:
        u = (b - a) / np.hypot(*(b - a))
        n = np.array([-u[1], u[0]]) * CLEARANCE
        obstacles.append(
            VPolytope(
                np.array(
                    [
                        a - CLEARANCE * u + n,
                        a - CLEARANCE * u - n,
                        b + CLEARANCE * u - n,
                        b + CLEARANCE * u + n,
                    ]
                ).T
            )
        )
    ang = np.linspace(0, 2 * np.pi, 16, endpoint=False)
    for c, r in zip(m.centers, m.radii, strict=True):
        ring = (r + CLEARANCE) / np.cos(np.pi / 16) * np.stack([np.cos(ang), np.sin(ang)], 1)
        obstacles.append(VPolytope((c + ring).T))
    lo, hi = m.walls.reshape(-1, 2).min(axis=0), m.walls.reshape(-1, 2).max(axis=0)
    domain = HPolyhedron.MakeBox(lo, hi)
    xs, ys = np.meshgrid(np.arange(lo[0] + 0.25, hi[0], 0.5), np.arange(lo[1] + 0.25, hi[1], 0.5))
    grid = np.stack([xs.ravel(), ys.ravel()], axis=1)
    grid = grid[_free(grid, m, CLEARANCE)]
    t0 = time.perf_counter()
    regions, options = [], IrisOptions()
    options.iteration_limit = 5
    for seed in grid:
        if not any(r.PointInSet(seed) for r in regions):
            regions.append(Iris(obstacles, seed, domain, options))
    iris_ms = 1000 * (time.perf_counter() - t0)
    solve = GraphOfConvexSetsOptions()
    solve.convex_relaxation, solve.max_rounded_paths, solve.preprocessing = True, 3, True
    times, length = [], float("nan")
    for _ in range(repeats):
        t0 = time.perf_counter()
        gcs = GcsTrajectoryOptimization(2)
        reg = gcs.AddRegions(regions, order=1)
        src = gcs.AddRegions([Point(start)], order=0)
        tgt = gcs.AddRegions([Point(goal)], order=0)
        gcs.AddEdges(src, reg)
        gcs.AddEdges(reg, tgt)
        gcs.AddPathLengthCost()
        traj, result = gcs.SolvePath(src, tgt, solve)
        times.append(1000 * (time.perf_counter() - t0))
        if result.is_success():
            ts = np.linspace(traj.start_time(), traj.end_time(), 400)
            pts = np.array([traj.value(t).ravel() for t in ts])
            length = float(np.hypot(*np.diff(pts, axis=0).T).sum())
    print(
        f"GCS, 3-room floor: {len(regions)} IRIS regions in {iris_ms:.0f} ms (once per map); "
        f"a route in median {statistics.median(times):.0f} ms, length {length:.2f} m"
    )


if __name__ == "__main__":
    sys.exit(main())
