"""MPC benchmark: solve time of the OSQP MPC with 4 pedestrians and 3 static discs (one core).

The planner drives the LIP world in closed loop (so every solve is warm-started from the
previous step, as in use) over episodes sampled with exactly 4 pedestrians and 3 discs;
each `plan` call is timed. Printed, as median and 95th percentile:

    plan            one planning step: seed choice + all SCP QPs (rollouts, linearisation,
                    in-place OSQP updates, solves) — what the 2.5 Hz planner costs
    plan, warm      the same without each episode's first step (cold start and the
                    once-per-episode guide path)
    plan, CPU time  the thread's CPU time for a step: on a shared machine the wall-clock
                    tail includes time the process spent descheduled
    OSQP per step   OSQP's own run time summed over the step's QPs
    OSQP per QP     one QP (update + solve as OSQP reports it)

against the budget of docs/facts.md: MPC solve (OSQP, warm) median ≤ 5 ms — checked on
the whole planning step, which is stricter.

Run:  .venv/bin/python benchmarks/bench_mpc.py [--episodes 20] [--quick] [--json out.json]
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from emonav_drake.navigation.lip_world import NavigationWorld  # noqa: E402
from emonav_drake.params import EmoNavConfig, load_config  # noqa: E402
from emonav_drake.planners.mpc import MpcPlanner  # noqa: E402
from emonav_drake.scenarios.scenario import sample_scenario  # noqa: E402

BUDGET_MS = 5.0


def crowded_config() -> EmoNavConfig:
    """The default configuration with exactly 4 pedestrians and 3 static discs."""
    cfg = load_config()
    c = cfg.crowd
    c.min_pedestrians = c.max_pedestrians = 4
    c.min_static = c.max_static = 3
    return cfg.validate()


def run(episodes: int, first_seed: int = 0) -> dict:
    """Closed-loop episodes; per-step and per-QP timings [ms] and solver statistics."""
    cfg = crowded_config()
    planner = MpcPlanner(cfg)
    plan_ms, warm_ms, cpu_ms, osqp_step_ms, osqp_qp_ms = [], [], [], [], []
    iters, qps, outcomes = [], [], []
    for seed in range(first_seed, first_seed + episodes):
        world = NavigationWorld(
            sample_scenario(seed, cfg),
            cfg,
            goal_radius=cfg.episode.eval_goal_radius,
            grid_kind=None,
        )
        planner.reset()
        obs = world.planner_input()
        while True:
            t0, c0 = time.perf_counter(), time.thread_time()
            u = planner.plan(obs)
            dt = 1e3 * (time.perf_counter() - t0)
            cpu_ms.append(1e3 * (time.thread_time() - c0))
            info = planner.last_info
            plan_ms.append(dt)
            if obs.step > 0:
                warm_ms.append(dt)
            osqp_step_ms.append(1e3 * info["run_time"])
            osqp_qp_ms.extend(1e3 * np.asarray(info["qp_run_times"]))
            qps.append(info["solves"])
            iters.extend(info["qp_iterations"])
            _, outcome = world.step(u)
            obs = world.planner_input()
            if outcome:
                outcomes.append(outcome)
                break

    def stats(x: list[float]) -> dict:
        a = np.asarray(x, dtype=float)
        return {"median": float(np.median(a)), "p95": float(np.percentile(a, 95)), "n": a.size}

    return {
        "episodes": episodes,
        "pedestrians": 4,
        "discs": 3,
        "horizon_steps": cfg.mpc.horizon_steps,
        "plan_ms": stats(plan_ms),
        "plan_warm_ms": stats(warm_ms),
        "plan_cpu_ms": stats(cpu_ms),
        "osqp_per_step_ms": stats(osqp_step_ms),
        "osqp_per_qp_ms": stats(osqp_qp_ms),
        "qps_per_step": float(np.mean(qps)),
        "admm_iterations_per_qp": stats(iters),
        "fallbacks": planner.fallbacks,
        "success_rate": outcomes.count("success") / len(outcomes),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--episodes", type=int, default=20)
    ap.add_argument("--quick", action="store_true", help="5 episodes")
    ap.add_argument("--json", type=Path, help="write the figures to this file")
    args = ap.parse_args()
    if hasattr(os, "sched_setaffinity"):
        os.sched_setaffinity(0, {sorted(os.sched_getaffinity(0))[0]})  # one core
    res = run(5 if args.quick else args.episodes)
    print(
        f"MPC (OSQP), {res['pedestrians']} pedestrians + {res['discs']} discs, "
        f"N = {res['horizon_steps']}, {res['episodes']} closed-loop episodes, "
        f"{res['plan_ms']['n']} planning steps"
    )
    for key, label in (
        ("plan_ms", "plan (all steps)"),
        ("plan_warm_ms", "plan, warm"),
        ("plan_cpu_ms", "plan, CPU time"),
        ("osqp_per_step_ms", "OSQP per step"),
        ("osqp_per_qp_ms", "OSQP per QP"),
    ):
        s = res[key]
        print(f"  {label:<18} median {s['median']:6.2f} ms   p95 {s['p95']:6.2f} ms")
    it = res["admm_iterations_per_qp"]
    print(
        f"  {res['qps_per_step']:.2f} QPs per step, ADMM iterations per QP median "
        f"{it['median']:.0f} p95 {it['p95']:.0f}; fallbacks {res['fallbacks']}; "
        f"SR {res['success_rate']:.2f}"
    )
    med = res["plan_warm_ms"]["median"]
    verdict = "OK" if med <= BUDGET_MS else "OVER BUDGET"
    print(f"budget: MPC solve median <= {BUDGET_MS} ms -> {med:.2f} ms  {verdict}")
    if args.json:
        args.json.write_text(json.dumps(res, indent=2))


if __name__ == "__main__":
    main()
