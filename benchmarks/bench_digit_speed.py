"""Full-order Digit speed: walking and navigation, one configuration against another.

    .venv/bin/python benchmarks/bench_digit_speed.py [--configs A.yaml B.yaml ...]
        [--trees DIR DIR ...] [--repeats 3] [--walk-seconds 10]
        [--nav-seeds 1001 1002 1003] [--core N]

For every configuration (default: the 4 ms stack `configs/walking_4ms.yaml`, every K_D
explicit, and the package default: 10 ms with the solver's implicit damping), pinned to
one CPU core and interleaved run by run (so a change of load on the shared machine hits
every configuration alike):

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
        "(default: walking_4ms.yaml and default; with --trees: default)",
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
                str(CONFIG_DIR / "walking_4ms.yaml"),
                "default",
            ]
        )
    if args.single:  # one walk and the navigation seeds, as a JSON line (a --trees run)
        print(json.dumps(_one_run(args.configs[0], args.seed, args, "")))
        return
    if args.trees:  # every run a fresh process importing that tree's package
        runs = {tree: [] for tree in args.trees}
        for k in range(args.repeats):
            for tree in args.trees:
                runs[tree].append(_run_in_tree(tree, k, core, args))
    else:  # every configuration in this process
        runs = {name: [] for name in args.configs}
        for k in range(args.repeats):
            for name in args.configs:
                runs[name].append(_one_run(name, k, args, Path(name).stem))
    _summary(runs, core, args.repeats)


def _one_run(config: str, seed: int, args: argparse.Namespace, label: str) -> dict:
    """One walk of `seed` and a DWA episode per navigation seed on `config`, printed under
    `label` ("": silent): real-time factors, the walk's fall and tracking RMS."""
    cfg = load_config() if config == "default" else load_config(config)
    r = run_walk(args.walk_seconds, seed=seed, command="random", config=cfg)
    if label:
        rms = r.tracking_rms
        print(
            f"{label}: walk seed {seed}: {'FELL ' if r.fell else ''}"
            f"{r.real_time_factor:.2f}x real time, RMS x {100 * rms['x']:.2f} cm "
            f"y {100 * rms['y']:.2f} cm heading {1000 * rms['heading']:.1f} mrad",
            flush=True,
        )
    nav = []
    for s in args.nav_seeds:
        t0 = time.perf_counter()
        rec, _ = run_digit_episode(sample_scenario(s, cfg), cfg, DwaPlanner(cfg))
        nav.append(rec.steps * cfg.robot.step_time / (time.perf_counter() - t0))
        if label:
            print(
                f"{label}: navigation seed {s}: {rec.outcome} after {rec.steps} steps, "
                f"{nav[-1]:.2f}x real time",
                flush=True,
            )
    return {"walk": r.real_time_factor, "fell": r.fell, "rms": r.tracking_rms, "nav": nav}


def _run_in_tree(tree: str, seed: int, core: int, args: argparse.Namespace) -> dict:
    """`_one_run` of the first configuration in a fresh process importing `tree`."""
    cmd = [sys.executable, str(Path(__file__).resolve()), "--single", "--seed", str(seed)]
    cmd += ["--core", str(core), "--configs", args.configs[0]]
    cmd += ["--walk-seconds", str(args.walk_seconds), "--nav-seeds", *map(str, args.nav_seeds)]
    env = {**os.environ, "PYTHONPATH": str(Path(tree).resolve())}
    out = subprocess.run(cmd, env=env, capture_output=True, text=True, check=True)
    r = json.loads(out.stdout.strip().splitlines()[-1])
    nav = ", ".join(f"{x:.2f}x" for x in r["nav"])
    print(f"{tree}: seed {seed}: walk {r['walk']:.2f}x, navigation {nav}", flush=True)
    return r


def _summary(runs: dict[str, list[dict]], core: int, repeats: int) -> None:
    """Per configuration (or tree): medians and their ratio to the first one's."""

    def medians(rs: list[dict]) -> tuple[float, float, dict]:
        nav = [x for r in rs for x in r["nav"]]
        rms = {k: statistics.median(r["rms"][k] for r in rs) for k in ("x", "y", "heading")}
        return (
            statistics.median(r["walk"] for r in rs),
            (statistics.median(nav) if nav else float("nan")),
            rms,
        )

    base = next(iter(runs))
    b_walk, b_nav, _ = medians(runs[base])
    print(f"\ncore {core}, {repeats} repeats; medians (ratio to {Path(base).stem or base}):")
    for name, rs in runs.items():
        w, n, rms = medians(rs)
        print(
            f"  {Path(name).stem or name}: walk {w:.2f}x ({w / b_walk:.2f}), navigation {n:.2f}x "
            f"({n / b_nav:.2f}); RMS x {100 * rms['x']:.2f} cm, y {100 * rms['y']:.2f} cm, "
            f"heading {1000 * rms['heading']:.1f} mrad; falls {sum(r['fell'] for r in rs)}"
        )


if __name__ == "__main__":
    main()
