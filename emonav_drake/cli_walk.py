"""`emonav walk`: the full-order Digit walking under navigation commands.

emonav walk --seconds S --seed K [--command random|straight|turn|stand] [--speed V]
            [--config F.yaml] [--meshcat] [--record out.html] [--json out.json]
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path


def _write_json(path: Path, data: dict) -> None:
    tmp = path.with_suffix(path.suffix + ".tmp")
    tmp.write_text(json.dumps(data, indent=2) + "\n")
    tmp.replace(path)  # atomic: never a half-written result


def cmd_walk(args: argparse.Namespace) -> int:
    """Run one walk and print / write its JSON summary."""
    import math

    from emonav_drake.diagrams.walking import run_walk
    from emonav_drake.params import load_config

    if not (math.isfinite(args.seconds) and args.seconds > 0):
        raise ValueError(f"--seconds must be a positive finite number, got {args.seconds}")
    cfg = load_config(args.config) if args.config else load_config()
    meshcat = None
    if args.meshcat or args.record:
        from pydrake.geometry import Meshcat

        meshcat = Meshcat()
        if args.meshcat:
            print(f"Meshcat: {meshcat.web_url()}")
    result = run_walk(
        args.seconds,
        seed=args.seed,
        command=args.command,
        config=cfg,
        meshcat=meshcat,
        record_html=args.record,
        realtime_rate=1.0 if args.meshcat else 0.0,
        speed=args.speed,
    )
    out = result.to_json()
    status = f"fall ({result.fall_reason})" if result.fell else "walked"
    print(
        f"seed {args.seed} [{args.command}]: {status} {result.sim_seconds:.2f} s simulated in "
        f"{result.wall_seconds:.2f} s ({result.real_time_factor:.2f}x real time), "
        f"{len(result.steps)} steps, mean forward speed {result.mean_forward_speed:.3f} m/s, "
        f"tracking RMS x {out['tracking_rms']['x']:.4f} m, y {out['tracking_rms']['y']:.4f} m, "
        f"heading {out['tracking_rms']['heading']:.4f} rad"
    )
    if args.record:
        print(f"replay written to {args.record}")
    if args.json:
        _write_json(args.json, out)
    return 0


def add_walk_parser(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Register `emonav walk` on the CLI's sub-parsers."""
    w = subparsers.add_parser("walk", help="simulate the full-order Digit walking (Drake, 1 kHz)")
    w.add_argument("--seconds", type=float, default=10.0, help="simulated time [s]")
    w.add_argument("--seed", type=int, default=0, help="seed of the random commands")
    w.add_argument(
        "--command",
        default="random",
        choices=["random", "straight", "turn", "stand"],
        help="random: new (u_v, u_dtheta) every step; straight: constant speed; "
        "turn: turning in place; stand: standing still",
    )
    w.add_argument("--speed", type=float, help="u_v for --command straight [m/s]")
    w.add_argument("--config", type=Path, help="YAML configuration overriding the defaults")
    w.add_argument("--meshcat", action="store_true", help="draw live in Meshcat (real time)")
    w.add_argument("--record", type=Path, help="write a self-contained HTML replay")
    w.add_argument("--json", type=Path, help="write the result as JSON")
    w.set_defaults(func=cmd_walk)
    return w
