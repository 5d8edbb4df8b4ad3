"""`emonav walk`: the full-order Digit walking under navigation commands.

emonav walk --seconds S --seed K [--command random|straight|turn|stand] [--speed V]
            [--config F.yaml] [--meshcat] [--record out.html] [--json out.json]
"""

from __future__ import annotations

import argparse
import contextlib
import math
from pathlib import Path

from emonav_drake.atomic_io import atomic_output, check_distinct, check_output_file, write_json
from emonav_drake.params import ConfigError


def _validate_walk_args(args: argparse.Namespace, max_speed: float) -> None:
    """Every flag checked before the (minutes-long) simulation starts."""
    if not (math.isfinite(args.seconds) and args.seconds > 0):
        raise ConfigError(f"--seconds {args.seconds}: must be a finite number > 0")
    if args.seed < 0:
        raise ConfigError(f"--seed {args.seed}: must be >= 0")
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
    for flag in ("json", "record"):
        if getattr(args, flag) is not None:
            check_output_file(getattr(args, flag), f"--{flag}")
    check_distinct({"--json": args.json, "--record": args.record})


def _fmt(value: float, digits: int) -> str:
    return f"{value:.{digits}f}" if math.isfinite(value) else "n/a"


def cmd_walk(args: argparse.Namespace) -> int:
    """Run one walk and print / write its JSON summary."""
    from emonav_drake.params import load_config

    cfg = load_config(args.config) if args.config else load_config()
    _validate_walk_args(args, cfg.robot.max_speed)
    from emonav_drake.diagrams.walking import run_walk

    meshcat = None
    if args.meshcat or args.record:
        from pydrake.geometry import Meshcat

        meshcat = Meshcat()
        if args.meshcat:
            print(f"Meshcat: {meshcat.web_url()}")
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
    return 0


def add_walk_parser(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Register `emonav walk` on the CLI's sub-parsers."""
    w = subparsers.add_parser("walk", help="simulate the full-order Digit walking (Drake, 1 kHz)")
    w.add_argument("--seconds", type=float, default=10.0, help="simulated time [s], > 0")
    w.add_argument("--seed", type=int, default=0, help="seed of the random commands (>= 0)")
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
    w.add_argument("--config", type=Path, help="YAML configuration overriding the defaults")
    w.add_argument("--meshcat", action="store_true", help="draw live in Meshcat (real time)")
    w.add_argument("--record", type=Path, help="write a self-contained HTML replay")
    w.add_argument("--json", type=Path, help="write the result as JSON (NaN written as null)")
    w.set_defaults(func=cmd_walk)
    return w
