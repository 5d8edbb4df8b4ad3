"""Success rate of planners in the Digit-calibrated reduced world (or the LIP world).

    python scripts/calibrated_world_sr.py --planners mpc,mpc_digit --first-seed 700000 \\
        --episodes 200 [--response digit|''|PATH] [--grid]
    python scripts/calibrated_world_sr.py --planners emobipednav_guide,guide_shield_digit \\
        --first-seed 700000 --episodes 300 --shield-margin 0.1 --brake-steps 2

Each planner walks `NavigationWorld(sample_scenario(seed), response=model)` (the world the
Digit/Digit routes train in, `docs/learning.md`) on the seeds first-seed … first-seed +
episodes − 1, from the default configuration, the evaluation goal radius. `--grid` rounds
every command to the nearest of the DAgger student's command grid (what a student that
imitated the planner perfectly would do). Learned planners run their default checkpoint
(`--checkpoint NAME=PATH`: another policy file) on the observation it reads;
`--shield-margin`, `--brake-steps`, `--static-margin`, `--uniform`, `--predict-motion`
and `--comfort-weight` set the LGM shield's parameters of the shielded ones
(`planning/lgm_shield.py`), whose line also counts the steps where no command passed the
shield. Prints SR, collision and timeout counts, NT and DT per planner, and the failing
seeds. Use tuning seeds (e.g. 700 000+), never the evaluation seeds 0–499.
"""

from __future__ import annotations

import argparse
import dataclasses as dc

from emonav_drake.learning.demonstrations import command_index
from emonav_drake.navigation.lip_world import NavigationWorld
from emonav_drake.navigation.metrics import summarize
from emonav_drake.params import EmoNavConfig, EpisodeParams
from emonav_drake.planners import configure_for, make_planner
from emonav_drake.planners.dwa import DwaPlanner
from emonav_drake.planners.model_aware import load_response
from emonav_drake.scenarios.scenario import sample_scenario


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--planners", default="mpc,mpc_digit")
    ap.add_argument("--first-seed", type=int, default=700_000)
    ap.add_argument("--episodes", type=int, default=200)
    ap.add_argument("--response", default="digit", help="'' = the LIP world")
    ap.add_argument("--grid", action="store_true", help="round commands to the student grid")
    ap.add_argument("--shield-margin", type=float, help="shielded planners: margin [m]")
    ap.add_argument("--brake-steps", type=int, help="shielded planners: braking steps")
    ap.add_argument("--static-margin", type=float, help="shielded planners: still points [m]")
    ap.add_argument(
        "--uniform", action="store_true", help="shielded planners: --shield-margin for all points"
    )
    ap.add_argument(
        "--comfort-weight", type=float, help="shielded planners: score off per m into still zones"
    )
    ap.add_argument(
        "--checkpoint",
        action="append",
        default=[],
        metavar="NAME=PATH",
        help="a learned planner's policy file (repeatable)",
    )
    ap.add_argument(
        "--predict-motion", action="store_true", help="shielded planners: bodies at their velocity"
    )
    args = ap.parse_args()
    cfg0 = EmoNavConfig()
    response = load_response(args.response)
    grid = DwaPlanner(cfg0).candidates
    checkpoints = dict(c.split("=", 1) for c in args.checkpoint)
    for name in args.planners.split(","):
        planner, records, blocked = make_planner(name, cfg0, checkpoints.get(name)), [], 0
        cfg = configure_for(planner, cfg0)[0]
        shielded = hasattr(planner, "last_admissible")
        if shielded:
            changes = {
                "margin": args.shield_margin,
                "brake_steps": args.brake_steps,
                "static_margin": args.static_margin,
                "comfort_weight": args.comfort_weight,
            }
            params = dc.replace(
                planner.params, **{k: v for k, v in changes.items() if v is not None}
            )
            if args.uniform:
                params = dc.replace(params, static_margin=None)
            if args.predict_motion:
                params = dc.replace(params, predict_motion=True)
            planner = type(planner)(planner.policy, cfg, planner.response, params)
        for seed in range(args.first_seed, args.first_seed + args.episodes):
            world = NavigationWorld(
                sample_scenario(seed, cfg),
                cfg,
                goal_radius=EpisodeParams.eval_goal_radius,
                response=response,
            )
            planner.reset()
            outcome = None
            while outcome is None:
                u = planner.plan(world.planner_input())
                blocked += shielded and not planner.last_admissible
                if args.grid:
                    u = grid[command_index(grid, u)]
                _, outcome = world.step(u)
            records.append(world.record)
        s = summarize(records)
        failed = [
            (args.first_seed + i, r.outcome)
            for i, r in enumerate(records)
            if r.outcome != "success"
        ]
        print(
            f"{name}: SR {s['SR']:.3f} (n={s['episodes']})  collision {s['collision_rate']:.3f}  "
            f"timeout {s['timeout_rate']:.3f}  NT {s['NT_mean']:.2f} s  DT {s['DT']}  "
            f"IDT [static; happy, neutral, negative] {s['IDT']}"
            + (f"  steps with no admissible command {blocked}" if shielded else "")
            + f"  failures {failed}"
        )


if __name__ == "__main__":
    main()
