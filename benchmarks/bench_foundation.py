"""Foundation benchmarks: LGM build, ORCA step, Gymnasium env throughput (one core).

Each figure is a median over repeated runs, printed beside a straightforward reference
implementation (per-beam Python LGM loop; per-agent ORCA loop) as a ratio, and against
the budgets of docs/facts.md ("Performance budgets"):

    LGM build (K 1800, M 100, 4 pedestrians + 3 discs)  ≥ 2 000 maps/s
    ORCA step, 20 agents                                 ≤ 1 ms
    ROM env step incl. crowd, scan, LGM, stack           ≥ 1 000 steps/s

Run:  .venv/bin/python benchmarks/bench_foundation.py [--quick]
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

from benchmarks.reference.lgm_reference import lgm_frame_reference  # noqa: E402
from benchmarks.reference.orca_reference import orca_velocities_reference  # noqa: E402
from emonav_drake.crowd import crowd as crowd_module  # noqa: E402
from emonav_drake.crowd.orca import OrcaParams, orca_velocities  # noqa: E402
from emonav_drake.learning.env import EmoNavLIPEnv  # noqa: E402
from emonav_drake.sensing.grid_maps import lgm_frame  # noqa: E402


def median_time(fn, args_list, repeat: int) -> float:
    """Median wall time of one call [s] over `repeat` passes through `args_list`."""
    times = []
    for _ in range(repeat):
        for args in args_list:
            t0 = time.perf_counter()
            fn(*args)
            times.append(time.perf_counter() - t0)
    return statistics.median(times)


def lgm_scenes(n: int, seed: int = 0) -> list[tuple]:
    """Robot pose + 4 pedestrians (0.3 m, emotion margins) + 3 static discs within 0.7–5 m."""
    rng = np.random.default_rng(seed)
    scenes = []
    for _ in range(n):
        d = rng.uniform(0.7, 5.0, 7)
        a = rng.uniform(-np.pi, np.pi, 7)
        centers = np.column_stack([d * np.cos(a), d * np.sin(a)])
        radii = np.r_[np.full(4, 0.3), rng.uniform(0.2, 0.4, 3)]
        margins = np.r_[rng.choice([0.2, 0.35, 0.5], 4), np.full(3, 0.2)]
        scenes.append((np.zeros(2), float(rng.uniform(-np.pi, np.pi)), centers, radii, margins))
    return scenes


def orca_crowds(n: int, agents: int = 20, seed: int = 0) -> list[tuple]:
    """Crowded 20-agent configurations in a 6 × 6 m square with 3 static discs."""
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(n):
        pos = rng.uniform(-3, 3, (agents, 2))
        vel = rng.uniform(-1, 1, (agents, 2)) * 0.7
        goal = -pos
        pref = goal - pos
        pref /= np.linalg.norm(pref, axis=1, keepdims=True)
        out.append(
            (
                pos,
                vel,
                np.full(agents, 0.5),
                pref,
                np.ones(agents),
                0.1,
                OrcaParams(),
                rng.uniform(-2, 2, (3, 2)),
                rng.uniform(0.2, 0.4, 3),
            )
        )
    return out


def env_steps_per_second(steps: int, reference: bool) -> float:
    """Random-action steps/s of EmoNavLIP-v0 (resets included), fast or reference parts."""
    env = EmoNavLIPEnv()
    saved = crowd_module.orca_velocities
    if reference:
        crowd_module.orca_velocities = lambda *a, check_inputs=True, **k: orca_velocities_reference(
            *a, **k
        )
        import emonav_drake.navigation.lip_world as nav

        saved_frame = nav.lgm_frame
        nav.lgm_frame = lambda *a, **k: lgm_frame_reference(*a[:5], kind=k.get("kind", "lgm"))
    try:
        env.reset(seed=0)
        env.action_space.seed(0)
        t0 = time.perf_counter()
        for _ in range(steps):
            _, _, term, trunc, _ = env.step(env.action_space.sample())
            if term or trunc:
                env.reset()
        return steps / (time.perf_counter() - t0)
    finally:
        crowd_module.orca_velocities = saved
        if reference:
            nav.lgm_frame = saved_frame


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="fewer repetitions")
    args = ap.parse_args()
    if hasattr(os, "sched_setaffinity"):
        os.sched_setaffinity(0, {sorted(os.sched_getaffinity(0))[0]})  # one core
    rep = 1 if args.quick else 3

    scenes = lgm_scenes(200)
    fast = median_time(lgm_frame, scenes, 5 * rep)
    ref = median_time(lgm_frame_reference, scenes[:20], 1)
    print(
        f"LGM build   fast {fast * 1e3:7.3f} ms = {1 / fast:8.0f} maps/s | reference "
        f"{ref * 1e3:7.2f} ms | ratio {ref / fast:6.1f}x | budget >= 2000 maps/s: "
        f"{'PASS' if 1 / fast >= 2000 else 'FAIL'}"
    )

    crowds = orca_crowds(50)
    fast = median_time(orca_velocities, crowds, 4 * rep)
    ref = median_time(orca_velocities_reference, crowds[:20], 1)
    print(
        f"ORCA step   fast {fast * 1e3:7.3f} ms (20 agents + 3 discs) | reference "
        f"{ref * 1e3:7.2f} ms | ratio {ref / fast:6.1f}x | budget <= 1 ms: "
        f"{'PASS' if fast <= 1e-3 else 'FAIL'}"
    )

    sps = statistics.median(env_steps_per_second(400 * rep, False) for _ in range(3))
    ref_sps = env_steps_per_second(60, True)
    print(
        f"env step    fast {sps:7.0f} steps/s | reference {ref_sps:7.1f} steps/s | ratio "
        f"{sps / ref_sps:6.1f}x | budget >= 1000 steps/s: {'PASS' if sps >= 1000 else 'FAIL'}"
    )


if __name__ == "__main__":
    main()
