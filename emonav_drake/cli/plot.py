"""`emonav plot RUN.json --png out.png [--times 0,5,10] [--gif out.gif]`: one episode, top view.

RUN.json is written by `emonav sim ... --json RUN.json` (its "trajectory" section, for
either plant). The PNG shows the robot's path coloured by time, every pedestrian's path
coloured by its emotion (changes marked), the robot and the pedestrians with their
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
    p.add_argument("run", type=Path, metavar="RUN.json", help="written by `emonav sim --json`")
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
