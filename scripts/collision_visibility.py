"""Were a method's collisions with pedestrians it could see? Re-simulates every collision of
a method in a benchmark run (LIP or Digit) and reports, for the pedestrian it hit, whether
that pedestrian was in the LiDAR's line of sight on each of the last steps.

    python scripts/collision_visibility.py --run benchmarks/results/lip_guide \\
        --method emobipednav_guide

Per collision: what was hit (a static disc when one is nearer than every pedestrian, less
0.3 m), the pedestrian's emotion, a string of the last `--steps` + 1 steps (1: in range of
the LiDAR and no other disc or pedestrian across the line from the robot to its centre),
its speed towards the robot and the robot's speed at the collision [m/s]. Prints a
Markdown table and a summary.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from emonav_drake.diagrams.trials import TrialRunner
from emonav_drake.evaluation.run_directory import replay_outcomes
from emonav_drake.params import EMOTION_NAMES


def _crosses(p: np.ndarray, q: np.ndarray, centres: np.ndarray, radii: np.ndarray) -> bool:
    """Does the open segment p → q pass through one of the discs?"""
    d = q - p
    length2 = float(d @ d)
    if length2 < 1e-18 or not len(radii):
        return False
    t = (centres - p) @ d / length2
    gap = np.hypot(*(centres - (p + np.outer(np.clip(t, 0.0, 1.0), d))).T)
    return bool(np.any((gap < radii) & (t > 0.0) & (t < 1.0)))


def collision(runner: TrialRunner, method: str, seed: int, steps: int) -> dict:
    """What one collision hit, and how long it was visible (module docstring)."""
    scenario, _, trace = runner.replay(method, seed)
    cfg = runner.config
    robot = np.asarray(trace.robot)
    peds = [np.asarray(p, float).reshape(-1, 2) for p in trace.pedestrians]
    k = len(robot) - 1
    x = robot[k, :2]
    centres = np.array([o.center for o in scenario.obstacles], float).reshape(-1, 2)
    radii = np.array([o.radius for o in scenario.obstacles], float)
    ped_gap = np.hypot(*(peds[k] - x).T) - cfg.crowd.pedestrian_radius
    disc_gap = np.hypot(*(centres - x).T) - radii
    if not len(ped_gap) or (len(disc_gap) and disc_gap.min() < ped_gap.min()):
        return {"seed": seed, "hit": "static disc"}
    j = int(np.argmin(ped_gap))
    seen = []
    for i in range(max(0, k - steps), k + 1):
        others = np.delete(peds[i], j, axis=0)
        blockers = np.vstack([centres, others])
        blocker_r = np.concatenate([radii, np.full(len(others), cfg.crowd.pedestrian_radius)])
        near = np.hypot(*(peds[i][j] - robot[i, :2])) <= cfg.lidar.max_range
        seen.append(near and not _crosses(robot[i, :2], peds[i][j], blockers, blocker_r))
    away = x - peds[k][j]
    v_ped = (peds[k][j] - peds[max(0, k - 1)][j]) / cfg.robot.step_time
    return {
        "seed": seed,
        "hit": "pedestrian",
        "emotion": EMOTION_NAMES[int(trace.emotions[k][j])],
        "visible": "".join("1" if s else "0" for s in seen),
        "towards_robot": float(v_ped @ away / max(np.linalg.norm(away), 1e-9)),
        "robot_speed": float(robot[k, 3]),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--run", type=Path, required=True)
    ap.add_argument("--method", required=True)
    ap.add_argument("--steps", type=int, default=10, help="steps before the collision")
    args = ap.parse_args()
    runner, seeds = replay_outcomes(args.run, args.method, "collision")
    rows = [collision(runner, args.method, s, args.steps) for s in seeds]
    print("| seed | hit | emotion | visible (last steps, 1 = in sight) | pedestrian → robot "
          "[m/s] | robot speed [m/s] |")  # fmt: skip
    print("|---|---|---|---|---|---|")
    for r in rows:
        if r["hit"] == "static disc":
            print(f"| {r['seed']} | static disc | | | | |")
            continue
        cells = [str(r["seed"]), "pedestrian", r["emotion"], r["visible"]]
        cells += [f"{r['towards_robot']:.2f}", f"{r['robot_speed']:.2f}"]
        print("| " + " | ".join(cells) + " |")
    hits = [r for r in rows if r["hit"] == "pedestrian"]
    always = [r for r in hits if set(r["visible"]) == {"1"}]
    fast = [r for r in hits if r["robot_speed"] >= 0.35]
    emotions = {e: sum(r["emotion"] == e for r in hits) for e in EMOTION_NAMES}
    print(
        f"\n{len(rows)} collisions of {args.method}: {len(rows) - len(hits)} with a static "
        f"disc, {len(hits)} with a pedestrian ({emotions}); {len(always)} of those in sight "
        f"on each of the last {args.steps + 1} steps; the robot at ≥ 0.35 m/s in {len(fast)}"
    )


if __name__ == "__main__":
    main()
