"""The `emonav` command line.

emonav sim  --planner dwa --plant lip --seed S [--scenario F.yaml] [--config F.yaml]
            [--meshcat] [--record out.html] [--json out.json] [--rays]
emonav eval --planner dwa --plant lip --episodes 100 --first-seed 0 [--json out.json]
emonav lgm  --seed S --png out.png [--steps K]
"""

from __future__ import annotations

import argparse
import json
import logging
import sys
import time
from pathlib import Path

from emonav_drake.params import ConfigError, EmoNavConfig, load_config


def _add_common(p: argparse.ArgumentParser) -> None:
    p.add_argument("--config", type=Path, help="YAML configuration overriding the defaults")
    p.add_argument(
        "--checkpoint",
        type=Path,
        help="policy checkpoint for --planner sac (default: the shipped policy)",
    )
    p.add_argument("--device", default="cpu", help="torch device for --planner sac")
    p.add_argument(
        "--emotion-estimate",
        type=Path,
        help="YAML EmotionEstimateParams: perceive emotions through a confusion "
        "matrix (mode: confusion) instead of the ground truth",
    )
    p.add_argument(
        "--time-varying",
        action="store_true",
        help="one pedestrian's emotion changes every 2 s (paper §IV-F)",
    )


def _config(args: argparse.Namespace) -> EmoNavConfig:
    cfg = load_config(args.config) if args.config else load_config()
    if getattr(args, "time_varying", False):
        cfg.crowd.time_varying_emotions = True
    return cfg


def _scenario(args: argparse.Namespace, cfg: EmoNavConfig):
    from emonav_drake.core.scenario import load_scenario, sample_scenario

    if getattr(args, "scenario", None):
        sc = load_scenario(args.scenario)
        sc.seed = args.seed if sc.seed < 0 else sc.seed
        return sc
    return sample_scenario(args.seed, cfg)


def _emotion_estimate(args: argparse.Namespace):
    if not getattr(args, "emotion_estimate", None):
        return None
    from emonav_drake.params import load_typed_yaml
    from emonav_drake.perception.noisy_emotions import EmotionEstimateParams

    return load_typed_yaml(EmotionEstimateParams, path=args.emotion_estimate).validate()


def _write_json(path: Path, data: dict) -> None:
    tmp = path.with_suffix(path.suffix + ".tmp")
    tmp.write_text(json.dumps(data, indent=2) + "\n")
    tmp.replace(path)  # atomic: never a half-written result


def cmd_sim(args: argparse.Namespace) -> int:
    from emonav_drake.diagrams.navigation import run_episode
    from emonav_drake.diagrams.navigation_digit import run_digit_episode
    from emonav_drake.planners import configure_for, make_planner

    cfg = _config(args)
    scenario = _scenario(args, cfg)
    planner = make_planner(args.planner, cfg, checkpoint=args.checkpoint, device=args.device)
    grid_kind = configure_for(planner, cfg)
    meshcat = None
    if args.meshcat or args.record:
        from pydrake.geometry import Meshcat

        from emonav_drake.systems.navigation_meshcat import set_overview_camera

        meshcat = Meshcat()
        set_overview_camera(meshcat, cfg)
        if args.meshcat:
            print(f"Meshcat: {meshcat.web_url()}")
    rates = None
    if args.rates:
        from emonav_drake.evaluation.rates import RateMeasurement

        rates = RateMeasurement()
    t0 = time.perf_counter()
    if args.plant == "digit":
        if args.emotion_estimate or args.rays:
            raise ConfigError(
                "--plant digit: --rays and --emotion-estimate are available "
                "with --plant lip only in this version"
            )

        record = run_digit_episode(
            scenario,
            cfg,
            planner,
            meshcat=meshcat,
            grid_kind=grid_kind,
            goal_radius=cfg.episode.eval_goal_radius,
            realtime_rate=1.0 if args.meshcat else 0.0,
            record_html=args.record,
            rates=rates,
        )
    else:
        record, _ = run_episode(
            scenario,
            cfg,
            planner,
            meshcat=meshcat,
            record_html=args.record,
            show_rays=args.rays,
            goal_radius=cfg.episode.eval_goal_radius,
            realtime_rate=1.0 if args.meshcat else 0.0,
            grid_kind=grid_kind,
            emotion_estimate=_emotion_estimate(args),
            rates=rates,
        )
    wall = time.perf_counter() - t0
    out = record.to_json()
    out["seed"] = scenario.seed
    if rates is not None and rates.report is not None:
        out.update(rates.report.to_json())
        print(_format_rates(rates.report))
    print(
        f"seed {scenario.seed}: {record.outcome} after {record.steps} steps "
        f"({record.nav_time:.1f} s simulated, {wall:.2f} s wall), path "
        f"{record.path_length:.2f} m, min pedestrian distance "
        f"{record.min_ped_distance:.2f} m, discomfort steps {record.discomfort_steps}, "
        f"IDT {record.idt}"
    )
    if args.record:
        print(f"replay written to {Path(args.record).resolve()} (open it in a browser)")
    if args.json:
        _write_json(args.json, out)
    return 0


def _format_rates(report) -> str:
    """The measured rates and wall-time shares as a small table."""
    shares = report.wall_time_share
    rates = report.rates()
    # the plant's wall time is the C++ remainder, listed as "<plant> + framework"
    rows = {n.removesuffix(" + framework"): n for n in shares}
    names = sorted(set(rates) | set(rows), key=lambda n: -shares.get(rows.get(n, n), 0.0))
    lines = [f"{'system':32s} {'rate [1/s sim]':>15s} {'wall share':>11s}"]
    for n in names:
        r = f"{rates[n]:.1f}" if n in rates else "-"
        label = rows.get(n, n)
        lines.append(f"{label:32s} {r:>15s} {100 * shares.get(label, 0.0):10.1f}%")
    lines.append(
        f"(profiled: {report.sim_seconds:.1f} s simulated in {report.wall_seconds:.1f} s wall)"
    )
    return "\n".join(lines)


def cmd_eval(args: argparse.Namespace) -> int:
    from tqdm import tqdm

    from emonav_drake.core.metrics import format_summary, summarize
    from emonav_drake.core.scenario import sample_scenario
    from emonav_drake.diagrams.navigation import run_episode
    from emonav_drake.diagrams.navigation_digit import run_digit_episode
    from emonav_drake.planners import configure_for, make_planner

    cfg = _config(args)
    planner = make_planner(args.planner, cfg, checkpoint=args.checkpoint, device=args.device)
    grid_kind = configure_for(planner, cfg)
    estimate = _emotion_estimate(args)
    if args.plant == "digit" and estimate is not None:
        raise ConfigError("--emotion-estimate is available with --plant lip only")
    records = []
    seeds = range(args.first_seed, args.first_seed + args.episodes)
    for seed in tqdm(seeds, desc=f"{args.planner}/{args.plant}", unit="ep"):
        scenario = sample_scenario(seed, cfg)
        if args.plant == "digit":
            rec = run_digit_episode(
                scenario,
                cfg,
                planner,
                grid_kind=grid_kind,
                goal_radius=cfg.episode.eval_goal_radius,
            )
        else:
            rec, _ = run_episode(
                scenario,
                cfg,
                planner,
                goal_radius=cfg.episode.eval_goal_radius,
                grid_kind=grid_kind,
                emotion_estimate=estimate,
            )
        records.append(rec)
    summary = summarize(records)
    print(format_summary(summary))
    if args.json:
        _write_json(
            args.json,
            {
                "planner": args.planner,
                "plant": args.plant,
                "seeds": [seeds.start, seeds.stop],
                "summary": summary,
                "episodes": [r.to_json() for r in records],
            },
        )
    return 0


def cmd_lgm(args: argparse.Namespace) -> int:
    import numpy as np

    from emonav_drake.core.crowd import obstacle_discs
    from emonav_drake.core.dwa import DwaPlanner
    from emonav_drake.core.navigation import NavigationWorld
    from emonav_drake.evaluation.grid_map_figure import render_grid_map_figure

    cfg = _config(args)
    world = NavigationWorld(_scenario(args, cfg), cfg, grid_kind=None)
    planner = DwaPlanner(cfg)
    for _ in range(args.steps):  # walk a little so the crowd comes close
        _, outcome = world.step(planner.plan(world.planner_input()))
        if outcome is not None:
            break
    obs = world.planner_input()
    centers, radii, margins = obstacle_discs(obs.crowd)
    kinds = np.concatenate(
        [np.ones(len(obs.crowd.positions), int), np.zeros(len(obs.crowd.static_radii), int)]
    )
    render_grid_map_figure(
        args.png,
        np.array([obs.robot.x, obs.robot.y]),
        obs.robot.heading,
        centers,
        radii,
        margins,
        kinds,
        goal_xy=obs.goal_xy,
        grid_size=cfg.lidar.grid_size,
    )
    print(f"wrote {args.png} (seed {args.seed}, after {world.step_count} steps)")
    return 0


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="emonav", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    p.add_argument("-v", "--verbose", action="store_true")
    sub = p.add_subparsers(dest="command", required=True)

    s = sub.add_parser("sim", help="run one navigation episode in the Drake diagram")
    s.add_argument("--planner", default="dwa", choices=["dwa", "mpc", "sac"])
    s.add_argument("--plant", default="lip", choices=["lip", "digit"])
    s.add_argument("--seed", type=int, default=0)
    s.add_argument("--scenario", type=Path, help="YAML scenario instead of a sampled one")
    s.add_argument("--meshcat", action="store_true", help="draw live in Meshcat (real time)")
    s.add_argument("--record", type=Path, help="write a self-contained HTML replay")
    s.add_argument("--rays", action="store_true", help="draw the LiDAR rays in Meshcat")
    s.add_argument("--json", type=Path, help="write the outcome as JSON")
    s.add_argument(
        "--rates",
        action="store_true",
        help="profile the run: events per simulated second and wall-time share of every "
        "system (printed, and added to --json as 'rates' and 'wall_time_share')",
    )
    _add_common(s)
    s.set_defaults(func=cmd_sim)

    e = sub.add_parser("eval", help="evaluate a planner over many seeds (SR, NT, DT, IDT)")
    e.add_argument("--planner", default="dwa", choices=["dwa", "mpc", "sac"])
    e.add_argument("--plant", default="lip", choices=["lip", "digit"])
    e.add_argument("--episodes", type=int, default=100)
    e.add_argument("--first-seed", type=int, default=0)
    e.add_argument("--json", type=Path)
    _add_common(e)
    e.set_defaults(func=cmd_eval)

    g = sub.add_parser("lgm", help="render a scenario's LiDAR grid map and OGM as a PNG")
    g.add_argument("--seed", type=int, default=0)
    g.add_argument("--scenario", type=Path)
    g.add_argument("--steps", type=int, default=8, help="DWA steps to walk before the snapshot")
    g.add_argument("--png", type=Path, required=True)
    _add_common(g)
    g.set_defaults(func=cmd_lgm)

    from emonav_drake.learning.cli_train import add_export_parser, add_train_parser

    add_train_parser(sub)
    add_export_parser(sub)
    from emonav_drake.cli_emotion import add_emotion_parser

    add_emotion_parser(sub)
    from emonav_drake.cli_walk import add_walk_parser

    add_walk_parser(sub)
    return p


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    logging.basicConfig(
        level=logging.INFO if args.verbose else logging.WARNING,
        format="%(levelname)s %(name)s: %(message)s",
    )
    try:
        return args.func(args)
    except (ConfigError, ValueError, NotImplementedError, FileNotFoundError) as e:
        print(f"emonav: error: {e}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
