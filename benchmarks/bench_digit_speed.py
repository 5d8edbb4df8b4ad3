"""Full-order Digit speed: walking and navigation, one configuration against another.

    .venv/bin/python benchmarks/bench_digit_speed.py [--configs A.yaml B.yaml ...]
        [--trees DIR DIR ...] [--repeats 3] [--walk-seconds 10]
        [--nav-seeds 1001 1002 1003] [--core N]

For every configuration (default: the 1 ms / 1 kHz reference `configs/walking_1ms.yaml`
and the package default), pinned to one CPU core and interleaved run by run (so a change of
load on the shared machine hits every configuration alike):

* walk: `--repeats` open-loop walks of `--walk-seconds` with seeded random commands
  (seeds 0, 1, ...): real-time factor, tracking RMS (x, y, heading), falls;
* navigation: one DWA navigation episode on Digit per `--nav-seed` and repeat: real-time
  factor of the whole loop (plant, controller, ALIP, crowd, LiDAR grid maps, planner).

With `--trees`, the code versions are compared instead: every run is a fresh process
importing the package from one checkout (e.g. a `git worktree` of the commit before a
change, and this one), interleaved the same way; each tree runs the first configuration.

Prints each run, then per configuration (or tree) the medians and the ratio to the first.
Budgets (docs/facts.md): navigation loop >= 3x real time (aim 5x).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

from emonav_drake.configs import CONFIG_DIR
from emonav_drake.diagrams.navigation_digit import run_digit_episode
from emonav_drake.diagrams.walking import run_walk
from emonav_drake.params import load_config
from emonav_drake.planners.dwa import DwaPlanner

try:
    from emonav_drake.scenarios.scenario import sample_scenario
except ImportError:  # a --trees checkout from before the maths folders (December 2026)
    from emonav_drake.core.scenario import sample_scenario


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--configs",
        nargs="+",
        default=None,
        help="YAML configurations ('default' = the package defaults); the first is the base "
        "(default: walking_1ms.yaml and default; with --trees: default)",
    )
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--walk-seconds", type=float, default=10.0)
    ap.add_argument("--nav-seeds", type=int, nargs="*", default=[1001])
    ap.add_argument("--core", type=int, default=None, help="CPU to pin to (default: last)")
    ap.add_argument("--trees", nargs="+", default=None, help="checkouts to compare (see above)")
    ap.add_argument("--single", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--seed", type=int, default=0, help=argparse.SUPPRESS)
    args = ap.parse_args()
    core = args.core if args.core is not None else max(os.sched_getaffinity(0))
    os.sched_setaffinity(0, {core})
    if args.configs is None:
        args.configs = (
            ["default"]
            if args.trees or args.single
            else [
                str(CONFIG_DIR / "walking_1ms.yaml"),
                "default",
            ]
        )
    if args.single:  # one walk and the navigation seeds, as a JSON line (a --trees run)
        print(json.dumps(_one_run(args.configs[0], args.seed, args)))
        return
    if args.trees:
        _compare_trees(args, core)
        return
    cfgs = {c: load_config() if c == "default" else load_config(c) for c in args.configs}
    walk = {c: [] for c in cfgs}
    nav = {c: [] for c in cfgs}
    for k in range(args.repeats):
        for name, cfg in cfgs.items():
            r = run_walk(args.walk_seconds, seed=k, command="random", config=cfg)
            walk[name].append(r)
            print(
                f"{Path(name).stem}: walk seed {k}: {'FELL ' if r.fell else ''}"
                f"{r.real_time_factor:.2f}x real time, RMS x {100 * r.tracking_rms['x']:.2f} cm "
                f"y {100 * r.tracking_rms['y']:.2f} cm heading "
                f"{1000 * r.tracking_rms['heading']:.1f} mrad",
                flush=True,
            )
            for seed in args.nav_seeds:
                t0 = time.perf_counter()
                rec, _ = run_digit_episode(sample_scenario(seed, cfg), cfg, DwaPlanner(cfg))
                wall = time.perf_counter() - t0
                sim = rec.steps * cfg.robot.step_time
                nav[name].append(sim / wall)
                print(
                    f"{Path(name).stem}: navigation seed {seed}: {rec.outcome} after "
                    f"{rec.steps} steps, {sim / wall:.2f}x real time",
                    flush=True,
                )
    base = args.configs[0]
    b_walk = statistics.median(r.real_time_factor for r in walk[base])
    b_nav = statistics.median(nav[base])
    print(f"\ncore {core}, {args.repeats} repeats; medians (ratio to {Path(base).stem}):")
    for name in cfgs:
        rw = statistics.median(r.real_time_factor for r in walk[name])
        rn = statistics.median(nav[name])
        rms = {
            key: statistics.median(r.tracking_rms[key] for r in walk[name])
            for key in ("x", "y", "heading")
        }
        falls = sum(r.fell for r in walk[name])
        print(
            f"  {Path(name).stem}: walk {rw:.2f}x ({rw / b_walk:.2f}), navigation {rn:.2f}x "
            f"({rn / b_nav:.2f}); RMS x {100 * rms['x']:.2f} cm, y {100 * rms['y']:.2f} cm, "
            f"heading {1000 * rms['heading']:.1f} mrad; falls {falls}"
        )


def _one_run(config: str, seed: int, args: argparse.Namespace) -> dict:
    cfg = load_config() if config == "default" else load_config(config)
    r = run_walk(args.walk_seconds, seed=seed, command="random", config=cfg)
    nav = []
    for s in args.nav_seeds:
        t0 = time.perf_counter()
        rec, _ = run_digit_episode(sample_scenario(s, cfg), cfg, DwaPlanner(cfg))
        nav.append(rec.steps * cfg.robot.step_time / (time.perf_counter() - t0))
    return {"walk": r.real_time_factor, "fell": r.fell, "rms": r.tracking_rms, "nav": nav}


def _compare_trees(args: argparse.Namespace, core: int) -> None:
    """Each tree's runs in fresh processes importing that tree's package, interleaved."""
    runs: dict[str, list[dict]] = {t: [] for t in args.trees}
    script = str(Path(__file__).resolve())
    for k in range(args.repeats):
        for tree in args.trees:
            cmd = [sys.executable, script, "--single", "--seed", str(k), "--core", str(core)]
            cmd += ["--configs", args.configs[0], "--walk-seconds", str(args.walk_seconds)]
            cmd += ["--nav-seeds", *map(str, args.nav_seeds)]
            env = {**os.environ, "PYTHONPATH": str(Path(tree).resolve())}
            out = subprocess.run(cmd, env=env, capture_output=True, text=True, check=True)
            r = json.loads(out.stdout.strip().splitlines()[-1])
            runs[tree].append(r)
            nav = ", ".join(f"{x:.2f}x" for x in r["nav"])
            print(f"{tree}: seed {k}: walk {r['walk']:.2f}x, navigation {nav}", flush=True)
    base = args.trees[0]
    b_walk = statistics.median(r["walk"] for r in runs[base])
    b_nav = statistics.median(x for r in runs[base] for x in r["nav"]) if args.nav_seeds else 1.0
    print(f"\ncore {core}, {args.repeats} repeats; medians (ratio to {base}):")
    for tree, rs in runs.items():
        w = statistics.median(r["walk"] for r in rs)
        n = statistics.median(x for r in rs for x in r["nav"]) if args.nav_seeds else float("nan")
        falls = sum(r["fell"] for r in rs)
        print(
            f"  {tree}: walk {w:.2f}x ({w / b_walk:.2f}), navigation {n:.2f}x "
            f"({n / b_nav:.2f}); falls {falls}"
        )


if __name__ == "__main__":
    main()
