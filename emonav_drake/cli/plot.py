"""`emonav plot RUN.json --png out.png [--times 0,5,10] [--gif out.gif]`: one episode, top view.

    emonav plot RUN.json --png out.png
    emonav plot runs/t2/trials.jsonl --method mpc --seed 3 --png out.png

RUN.json is written by `emonav sim ... --json RUN.json` (its "trajectory" section, for
either plant). A benchmark's `trials.jsonl` (or its run directory) keeps one line per trial
and no trajectory: `--method` and `--seed` pick the trial, which is simulated again as it
ran (the run's settings.json: plant, configuration, planner and checkpoint, emotion
estimate; the same seed gives the same episode).

The PNG shows the robot's path coloured by time, every pedestrian's path coloured by its
emotion (changes marked), the robot and the pedestrians with their
discomfort zones at the `--times` [s] (default: four evenly spaced instants), the static
discs with their discomfort rings, start, goal and the collision point; the title gives
the outcome, planner, plant and seed. `--gif` renders the episode step by step as a GIF
(or an MP4 when the name ends in .mp4 and ffmpeg is installed), without a browser.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from emonav_drake.params import ConfigError


def add_parser(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Register `emonav plot` on the CLI's sub-parsers."""
    p = subparsers.add_parser(
        "plot",
        help="draw an `emonav sim --json` episode: top-view PNG and/or animation",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument(
        "run",
        type=Path,
        metavar="RUN",
        help="written by `emonav sim --json`; or a benchmark's trials.jsonl or run directory "
        "(with --method and --seed)",
    )
    p.add_argument("--method", help="with a benchmark run: the trial's method")
    p.add_argument("--seed", type=int, help="with a benchmark run: the trial's seed")
    p.add_argument("--png", type=Path, help="write the top view of the whole episode")
    p.add_argument(
        "--times",
        help="comma-separated instants [s] at which to draw the robot and the pedestrians "
        "with their discomfort zones, e.g. 0,5,10 (default: four evenly spaced)",
    )
    p.add_argument(
        "--gif",
        "--animation",
        dest="animation",
        type=Path,
        help="write the episode step by step: .gif (Pillow) or .mp4 (needs ffmpeg)",
    )
    p.add_argument(
        "--fps",
        type=float,
        default=None,
        help="animation frames per second; one frame per walking step (default: real "
        "time, 1/T = 2.5)",
    )
    p.set_defaults(func=cmd_plot)
    return p


def parse_times(text: str) -> list[float]:
    """'0,5,10' → [0.0, 5.0, 10.0]; `ConfigError` naming --times on anything else."""
    try:
        values = [float(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise ConfigError(
            f"--times {text!r}: expected comma-separated seconds, e.g. 0,5,10"
        ) from None
    if not values:
        raise ConfigError(f"--times {text!r}: give at least one time [s]")
    return values


def _is_benchmark_run(path: Path) -> bool:
    return path.suffix == ".jsonl" or path.is_dir()


def _benchmark_trial(args: argparse.Namespace):  # noqa: ANN202 - a Trajectory
    """The trajectory of trial (--method, --seed) of a benchmark run, simulated again."""
    from emonav_drake.evaluation.run_directory import load_run
    from emonav_drake.evaluation.run_settings import spec_from_settings
    from emonav_drake.evaluation.trajectory import trajectory_from_trace

    run = args.run.parent if args.run.suffix == ".jsonl" else args.run
    settings, trials = load_run(run)
    if args.method is None or args.seed is None:
        raise ConfigError(
            f"{args.run}: a benchmark run holds {len(trials)} trials; pick one with --method "
            f"({', '.join(settings['planners'])}) and --seed"
        )
    if args.method not in settings["planners"]:
        raise ConfigError(
            f"--method {args.method}: not in {run} (its methods: {', '.join(settings['planners'])})"
        )
    seeds = sorted(t["seed"] for t in trials if t["method"] == args.method)
    if args.seed not in seeds:
        span = f"{seeds[0]}–{seeds[-1]}" if seeds else "none"
        raise ConfigError(f"--seed {args.seed}: {args.method} has no such trial in {run} ({span})")
    from emonav_drake.diagrams.trials import TrialRunner

    runner = TrialRunner(spec_from_settings(settings))
    scenario, record, trace = runner.replay(args.method, args.seed)
    if trace is None:
        raise ConfigError(f"{run}: plant {settings['plant']} keeps no per-step trace to draw")
    _, config, _ = runner.planner(args.method)  # the configuration the trial ran with
    return trajectory_from_trace(
        scenario, config, record, trace, args.method, settings["plant"], settings["goal_radius"]
    )


def cmd_plot(args: argparse.Namespace) -> int:
    """Check every flag, then draw the PNG and/or the animation."""
    from emonav_drake.atomic_io import atomic_output, check_distinct, check_output_file

    if args.png is None and args.animation is None:
        raise ConfigError("nothing to draw: give --png OUT.png and/or --gif OUT.gif")
    outputs = {}
    if args.png is not None:
        outputs["--png"] = check_output_file(args.png, "--png")
        if args.png.suffix.lower() != ".png":
            raise ConfigError(f"--png {args.png}: the file name must end in .png")
    if args.animation is not None:
        outputs["--gif"] = check_output_file(args.animation, "--gif")
    check_distinct(outputs)
    if args.fps is not None and not args.fps > 0:
        raise ConfigError(f"--fps {args.fps}: must be > 0")
    times = parse_times(args.times) if args.times is not None else None
    if times is not None and args.png is None:
        raise ConfigError("--times applies to --png (the animation shows every step)")

    from emonav_drake.evaluation.trajectory import load_trajectory
    from emonav_drake.evaluation.trajectory_animation import (
        animation_writer,
        render_trajectory_animation,
    )
    from emonav_drake.evaluation.trajectory_check import check_drawable
    from emonav_drake.evaluation.trajectory_plot import render_trajectory_figure

    if _is_benchmark_run(args.run):
        traj = _benchmark_trial(args)
    elif args.method is not None or args.seed is not None:
        raise ConfigError(
            f"--method/--seed pick a trial of a benchmark run; {args.run} is an episode"
        )
    else:
        traj = load_trajectory(args.run)
    check_drawable(traj, str(args.run))  # a null/NaN/Infinity: named, nothing drawn
    if times is not None:
        for t in times:
            try:
                traj.index_at(t)
            except ValueError as e:
                raise ConfigError(f"--times: {e}") from None
    if args.animation is not None:
        try:
            animation_writer(args.animation, 1.0)  # the suffix and ffmpeg, before any work
        except ValueError as e:
            raise ConfigError(f"--gif {e}") from None
    if args.png is not None:
        with atomic_output(args.png) as tmp:
            render_trajectory_figure(tmp, traj, times)
        print(f"wrote {args.png}")
    if args.animation is not None:
        with atomic_output(args.animation) as tmp:
            render_trajectory_animation(tmp, traj, fps=args.fps)
        print(f"wrote {args.animation} ({traj.steps + 1} steps)")
    return 0
