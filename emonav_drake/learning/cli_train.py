"""`emonav train`: the SAC trainer (paper-scale, `--algo sac`) or the CPU route (`--algo dagger`).

emonav train --algo dagger --out runs/dagger --seed 0 [--device cpu] [--resume runs/dagger]
emonav train --algo sac [--config FILE] [--steps N] [--device cpu|cuda] [--out DIR]
             [--resume DIR]
"""

from __future__ import annotations

import argparse
from pathlib import Path


def add_train_parser(sub: argparse._SubParsersAction) -> None:
    t = sub.add_parser("train", help="train a navigation policy (SAC, or the CPU DAgger route)")
    t.add_argument("--algo", choices=["sac", "dagger"], default="sac")
    t.add_argument(
        "--config",
        type=Path,
        help="YAML training configuration (SacConfig or "
        "DaggerConfig fields; env settings under `env:` for SAC)",
    )
    t.add_argument("--steps", type=int, help="SAC environment steps (default from the config)")
    t.add_argument("--seed", type=int, default=0)
    t.add_argument("--device", default="cpu", help="cpu or cuda")
    t.add_argument("--out", type=Path, default=Path("runs/train"))
    t.add_argument("--resume", type=Path, help="continue the run in this directory")
    t.set_defaults(func=cmd_train)


def cmd_train(args: argparse.Namespace) -> int:
    from emonav_drake.params import load_typed_yaml

    out = args.resume or args.out
    if args.algo == "dagger":
        from emonav_drake.learning.dagger import DaggerConfig, train_dagger

        cfg = load_typed_yaml(DaggerConfig, path=args.config) if args.config else DaggerConfig()
        cfg.seed, cfg.device = args.seed, args.device
        path = train_dagger(out, cfg, resume=args.resume is not None)
        print(f"policy written to {path}")
        return 0
    from emonav_drake.learning.sac_trainer import SacConfig, train_sac

    cfg = load_typed_yaml(SacConfig, path=args.config) if args.config else SacConfig()
    cfg.seed, cfg.device = args.seed, args.device
    if args.steps is not None:
        cfg.total_steps = args.steps
    train_sac(out, cfg, resume=args.resume is not None)
    return 0


def add_export_parser(sub: argparse._SubParsersAction) -> None:
    e = sub.add_parser("export", help="export a policy checkpoint to TorchScript")
    e.add_argument("checkpoint", type=Path, nargs="?", help="default: the shipped policy")
    e.add_argument("--out", type=Path, required=True, help="TorchScript file to write")
    e.set_defaults(func=cmd_export)


def cmd_export(args: argparse.Namespace) -> int:
    from emonav_drake.learning.policy import DEFAULT_POLICY, export_torchscript

    path = export_torchscript(args.checkpoint or DEFAULT_POLICY, args.out)
    print(
        f"TorchScript written to {path} (inputs: uint8 stack (1, N, M, M), vector state "
        "(1, 4) = [d/10, phi/pi, v/0.4, dtheta/0.2])"
    )
    return 0
