"""`emonav export`: a policy checkpoint as TorchScript.

emonav export [CHECKPOINT] --out policy.ts
"""

from __future__ import annotations

import argparse
from pathlib import Path


def add_parser(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Register `emonav export` on the CLI's sub-parsers."""
    e = subparsers.add_parser("export", help="export a policy checkpoint to TorchScript")
    e.add_argument("checkpoint", type=Path, nargs="?", help="default: the shipped policy")
    e.add_argument("--out", type=Path, required=True, help="TorchScript file to write")
    e.set_defaults(func=cmd_export)
    return e


def cmd_export(args: argparse.Namespace) -> int:
    """Write the checkpoint (default: the shipped policy) as TorchScript to --out."""
    from emonav_drake.atomic_io import check_distinct, check_output_file
    from emonav_drake.planners.policy import DEFAULT_POLICY
    from emonav_drake.planners.policy_export import export_torchscript

    check_output_file(args.out, "--out")
    check_distinct({"CHECKPOINT": args.checkpoint, "--out": args.out})
    path = export_torchscript(args.checkpoint or DEFAULT_POLICY, args.out)
    print(
        f"TorchScript written to {path} (inputs: uint8 stack (1, N, M, M), vector state "
        "(1, 4) = [d/10, phi/pi, v/0.4, dtheta/0.2])"
    )
    return 0
