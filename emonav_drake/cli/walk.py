"""`emonav walk`: the full-order Digit walking under navigation commands.

emonav walk --seconds S --seed K [--command random|straight|turn|stand] [--speed V]
            [--config F.yaml] [--meshcat [--no-wait] [--meshcat-host H]]
            [--record out.html] [--json out.json]
            [--steps-out steps.csv] [--quiet]

A progress bar over simulated time (and the real-time factor) goes to stderr while Digit
walks, when stderr is a terminal and --quiet is not given.

The steps CSV is written by `common.write_steps_csv` (also `emonav sim --steps-out`).
"""

from __future__ import annotations

import argparse
import contextlib
import math
from pathlib import Path

from emonav_drake.atomic_io import (
    atomic_output,
    check_distinct,
    check_output_file,
    write_json,
)
from emonav_drake.cli.common import SeedArg, add_meshcat_host, meshcat_host, write_steps_csv
from emonav_drake.cli.resolve import CONFIG_HELP, resolve_config
from emonav_drake.params import ConfigError

STEPS_OUT_HELP = (
    "write one CSV row per walking step: its command, the desired LIP step (paper Eq. 1), "
    "the achieved CoM and heading and the errors (columns: docs/walking.md)"
)


def _validate_walk_args(args: argparse.Namespace, max_speed: float) -> None:
    """Every flag checked before the (minutes-long) simulation starts (the seed while
    parsing: `common.SeedArg`)."""
    from emonav_drake.diagrams.walking import MAX_WALK_SECONDS

    if not (math.isfinite(args.seconds) and args.seconds > 0):
        raise ConfigError(f"--seconds {args.seconds}: must be a finite number > 0")
    if args.seconds > MAX_WALK_SECONDS:
        raise ConfigError(
            f"--seconds {args.seconds:g}: at most {MAX_WALK_SECONDS:g} (one simulated hour, "
            "about an hour of wall time); run longer walks in parts"
        )
    if args.speed is not None:
        if args.command != "straight":
            raise ConfigError(
                f"--speed {args.speed}: applies to --command straight only "
                f"(not --command {args.command})"
            )
        if not (math.isfinite(args.speed) and 0.0 <= args.speed <= max_speed):
            raise ConfigError(
                f"--speed {args.speed}: must be in [0, {max_speed}] m/s (robot.max_speed)"
            )
    for flag in ("json", "record", "steps_out"):
        if getattr(args, flag) is not None:
            check_output_file(getattr(args, flag), f"--{flag.replace('_', '-')}")
    check_distinct({"--json": args.json, "--record": args.record, "--steps-out": args.steps_out})


def _fmt(value: float, digits: int) -> str:
    return f"{value:.{digits}f}" if math.isfinite(value) else "n/a"


def cmd_walk(args: argparse.Namespace) -> int:
    """Run one walk and print / write its JSON summary."""
    cfg = resolve_config(args).config
    _validate_walk_args(args, cfg.robot.max_speed)
    meshcat_host(args)
    from emonav_drake.diagrams.walking import run_walk

    meshcat = None
    if args.meshcat or args.record:
        from emonav_drake.diagrams.meshcat_viewing import make_meshcat, start_live_view

        # record only: no "listening at" line
        meshcat = make_meshcat(live=args.meshcat, host=meshcat_host(args))
        if args.meshcat:
            start_live_view(meshcat, wait=not args.no_wait)
    with contextlib.ExitStack() as stack:
        # the replay goes to a temporary sibling, renamed when complete
        record = stack.enter_context(atomic_output(args.record)) if args.record else None
        result = run_walk(
            args.seconds,
            seed=args.seed,
            command=args.command,
            config=cfg,
            meshcat=meshcat,
            record_html=record,
            realtime_rate=1.0 if args.meshcat else 0.0,
            speed=args.speed,
            progress=True,  # drawn only where `emonav` allows bars (cli.main)
        )
    out = result.to_json()
    rms = result.tracking_rms
    status = f"fall ({result.fall_reason})" if result.fell else "walked"
    print(
        f"seed {args.seed} [{args.command}]: {status} {result.sim_seconds:.2f} s simulated in "
        f"{result.wall_seconds:.2f} s ({result.real_time_factor:.2f}x real time), "
        f"{len(result.steps)} steps, mean forward speed {result.mean_forward_speed:.3f} m/s, "
        f"tracking RMS x {_fmt(rms['x'], 4)} m, y {_fmt(rms['y'], 4)} m, "
        f"heading {_fmt(rms['heading'], 4)} rad"
    )
    if args.record:
        print(f"replay written to {args.record}")
    if args.json:
        write_json(args.json, out)  # NaN (too short a walk to measure) becomes null
    if args.steps_out:
        n = write_steps_csv(args.steps_out, result.tracking(cfg))
        print(f"{n} steps written to {args.steps_out}")
    if args.meshcat:  # the last pose stays on screen until Ctrl-C
        from emonav_drake.diagrams.meshcat_viewing import finish_live_view

        finish_live_view(meshcat, keep_serving=not args.no_wait)
    return 0


def add_parser(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Register `emonav walk` on the CLI's sub-parsers."""
    w = subparsers.add_parser(
        "walk",
        help="simulate the full-order Digit walking (plant and controller at 10 ms by default)",
    )
    w.add_argument(
        "--seconds",
        type=float,
        default=10.0,
        help="simulated time [s], in (0, 3600]: the walk runs at about real time and its "
        "step logs keep ~2 MB per simulated minute",
    )
    w.add_argument(
        "--seed",
        action=SeedArg,
        default=0,
        help="seed of the random commands, in [0, 2**64 - 1]",
    )
    w.add_argument(
        "--command",
        default="random",
        choices=["random", "straight", "turn", "stand"],
        help="random: new (u_v, u_dtheta) every step; straight: constant speed; "
        "turn: turning in place; stand: standing still",
    )
    w.add_argument(
        "--speed",
        type=float,
        help="u_v for --command straight [m/s], in [0, robot.max_speed] (default the maximum)",
    )
    w.add_argument("--config", type=Path, help=CONFIG_HELP)
    w.add_argument(
        "--meshcat",
        action="store_true",
        help="draw live in Meshcat (real time): waits for a browser to connect, keeps "
        "serving after the walk until Ctrl-C",
    )
    w.add_argument(
        "--no-wait",
        action="store_true",
        help="with --meshcat: neither wait for a browser nor keep serving afterwards",
    )
    add_meshcat_host(w)
    w.add_argument("--record", type=Path, help="write a self-contained HTML replay")
    w.add_argument("--json", type=Path, help="write the result as JSON (NaN written as null)")
    w.add_argument("--steps-out", type=Path, metavar="FILE.csv", help=STEPS_OUT_HELP)
    w.set_defaults(func=cmd_walk)
    return w
