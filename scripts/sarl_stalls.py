"""Where and why a planner's timeouts stall: re-simulates every timeout of a method in a
benchmark run and reports where the robot stopped for good.

    python scripts/sarl_stalls.py --run benchmarks/results/lip_table2_all --method sarl

For each timeout (re-simulated from its seed with the run's planner and configuration):
the step after which the speed command stays 0 (the freeze), the robot's distance to the
goal there, the gap to the nearest static disc's surface, the nearest pedestrian, and the
clearance of the straight line from the robot to the goal past the discs (negative: the
line crosses a disc). Prints a Markdown table and a summary.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from emonav_drake.diagrams.trials import TrialRunner
from emonav_drake.evaluation.run_directory import replay_outcomes


def stall(runner: TrialRunner, method: str, seed: int) -> dict:
    """The freeze of one timeout (see the module)."""
    scenario, record, trace = runner.replay(method, seed)
    robot, commands = np.asarray(trace.robot), trace.commands
    k = len(commands)
    while k > 0 and abs(commands[k - 1, 0]) < 1e-9:
        k -= 1
    x, goal = robot[k, :2], np.asarray(scenario.robot_goal, float)
    centres = np.array([o.center for o in scenario.obstacles], float).reshape(-1, 2)
    radii = np.array([o.radius for o in scenario.obstacles], float)
    peds = np.asarray(trace.pedestrians[k], float).reshape(-1, 2)
    seg = goal - x
    t = np.clip((centres - x) @ seg / max(seg @ seg, 1e-12), 0.0, 1.0)
    line = np.hypot(*(centres - (x + np.outer(t, seg))).T) - radii
    return {
        "seed": seed,
        "freeze_step": k,
        "steps": len(commands),
        "goal_distance": float(np.hypot(*seg)),
        "disc_gap": float(np.min(np.hypot(*(centres - x).T) - radii)) if len(radii) else np.inf,
        "pedestrian": float(np.min(np.hypot(*(peds - x).T))) if len(peds) else np.inf,
        "line_clearance": float(np.min(line)) if len(radii) else np.inf,
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--run", type=Path, required=True)
    ap.add_argument("--method", required=True)
    ap.add_argument("--blocked", type=float, default=0.5, help="line clearance below: blocked [m]")
    args = ap.parse_args()
    runner, seeds = replay_outcomes(args.run, args.method, "timeout")
    rows = [stall(runner, args.method, s) for s in seeds]
    print("| seed | freeze step / steps | goal [m] | disc surface [m] | pedestrian [m] "
          "| goal line past discs [m] |")  # fmt: skip
    print("|---|---|---|---|---|---|")
    for r in rows:
        cells = [f"{r['seed']}", f"{r['freeze_step']} / {r['steps']}"]
        cells += [f"{r[k]:.2f}" for k in ("goal_distance", "disc_gap", "pedestrian")]
        cells.append(f"{r['line_clearance']:.2f}")
        print("| " + " | ".join(cells) + " |")
    if not rows:
        print(f"no timeouts of {args.method} in {args.run}")
        return
    frozen = [r for r in rows if r["freeze_step"] < r["steps"]]
    blocked = [r for r in frozen if r["line_clearance"] < args.blocked]
    gaps = [r["disc_gap"] for r in frozen]
    print(
        f"\n{len(rows)} timeouts of {args.method}; {len(frozen)} end standing still "
        f"(median freeze at step {np.median([r['freeze_step'] for r in frozen]):.0f}, "
        f"{np.median([r['goal_distance'] for r in frozen]):.2f} m from the goal); "
        f"{len(blocked)} of them with a disc within {args.blocked} m of the straight line "
        f"to the goal, stopped {np.median(gaps):.2f} m (median) from its surface"
    )


if __name__ == "__main__":
    main()
