"""Learning benchmarks: SAC update rate (paper scale and CPU-route scale), the speed work as
ratios, the CPU route's student training rate, and the policy decision latency.

    SAC update, paper scale: 9 × 100 × 100 LGM, batch 128, hidden 1024
    SAC update, CPU scale:   2 × 2 max-pooled LGM, batch 128, hidden 1024
    each "before" (SAC-AE's re-encoding, NCHW) and "after" (one conv pass per stack,
    features reused by the actor step; channels-last where it helps)
    DAgger student update (categorical head, pooled encoder, batch 64)
    policy decision (PolicyPlanner.act, batch 1): budget ≤ 5 ms

Run:  .venv/bin/python benchmarks/bench_learning.py [--quick] [--threads 1]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np
import torch

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from emonav_drake.learning.config import DaggerConfig  # noqa: E402
from emonav_drake.learning.dagger_student import Student  # noqa: E402
from emonav_drake.learning.demonstrations import Demonstrations, FrameStore  # noqa: E402
from emonav_drake.learning.sac import SacAgent  # noqa: E402
from emonav_drake.learning.sac_config import SacConfig  # noqa: E402
from emonav_drake.params import EmoNavConfig  # noqa: E402
from emonav_drake.planners.policy import DEFAULT_POLICY, PolicyPlanner  # noqa: E402


def batch(b: int, size: int = 100, frames: int = 9) -> dict[str, torch.Tensor]:
    g = torch.Generator().manual_seed(0)
    obs = (torch.rand(b, frames, size, size, generator=g) < 0.02).to(torch.uint8) * 255
    return {
        "obs": obs,
        "state": torch.randn(b, 4, generator=g),
        "action": torch.rand(b, 2, generator=g) * 2 - 1,
        "reward": torch.randn(b, 1),
        "next_obs": obs.roll(1, 0),
        "next_state": torch.randn(b, 4, generator=g),
        "not_done": torch.ones(b, 1),
    }


def updates_per_second(cfg: SacConfig, n: int) -> float:
    agent = SacAgent(cfg, (0.4, 0.2))
    b = batch(cfg.batch_size)
    agent.update(b)  # warm-up
    times = []
    for _ in range(n):
        t0 = time.perf_counter()
        agent.update(b)
        times.append(time.perf_counter() - t0)
    return 1.0 / statistics.median(times)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--threads", type=int, default=1)
    args = ap.parse_args()
    torch.set_num_threads(args.threads)
    n = 2 if args.quick else 5
    print(f"torch {torch.__version__}, {args.threads} thread(s)")
    for name, pool, reps in (("paper scale", 1, n), ("CPU scale (pool 2)", 2, 3 * n)):
        before = updates_per_second(SacConfig(pool=pool, reuse_features=False), reps)
        after = updates_per_second(SacConfig(pool=pool, reuse_features=True), reps)
        cl = updates_per_second(SacConfig(pool=pool, reuse_features=True, channels_last=True), reps)
        best = max(after, cl)
        print(
            f"SAC update, {name:18s}: before {before:6.2f}/s ({1 / before:6.3f} s) | after "
            f"{after:6.2f}/s | +channels-last {cl:6.2f}/s | ratio {best / before:4.2f}x"
        )

    env_cfg = EmoNavConfig()
    cfg = DaggerConfig()
    student = Student(cfg, env_cfg, np.zeros((99, 2)))
    demos = Demonstrations(FrameStore(100))
    rng = np.random.default_rng(0)
    for _ in range(200):
        demos.store.add((rng.random((100, 100)) < 0.02).astype(np.uint8) * 255)
        demos.windows.append(rng.integers(0, demos.store.count, 9))
        demos.states.append(rng.standard_normal(4).astype(np.float32))
        demos.labels.append(int(rng.integers(99)))
    steps = 20 if args.quick else 60
    t0 = time.perf_counter()
    student.train(demos, steps, cfg.batch_size, rng, "student")
    rate = steps * cfg.batch_size / (time.perf_counter() - t0)
    print(f"DAgger student update (batch {cfg.batch_size}): {rate:7.0f} samples/s")

    if DEFAULT_POLICY.is_file():
        planner = PolicyPlanner()
        stack = np.zeros(planner.expected_shape, np.uint8)
        for _ in range(5):
            planner.act(stack, np.array([8.0, 0.0]), np.zeros(2))
        times = []
        for _ in range(200):
            t0 = time.perf_counter()
            planner.act(stack, np.array([8.0, 0.0]), np.zeros(2))
            times.append(time.perf_counter() - t0)
        med = statistics.median(times)
        print(
            f"policy decision (shipped policy): median {med * 1e3:.2f} ms, p95 "
            f"{np.percentile(times, 95) * 1e3:.2f} ms | budget <= 5 ms: "
            f"{'PASS' if med <= 5e-3 else 'FAIL'}"
        )


if __name__ == "__main__":
    main()
