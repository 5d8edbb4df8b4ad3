"""`emonav planners`: every planner a command can run, what it reads, and what it runs.

emonav planners [--json]

One row per registered planner (`planners/__init__.py`): its name, one line on what it
is, what it reads of the world, whether that is privileged (the simulator's exact crowd:
no robot has it) or deployable (the robot's own LiDAR, or the crowd it tracks with
`--state-source lidar`), the checkpoint it runs by default, and its spec as a route's
YAML writes it (`planners/specs.py`: `expert: !PlannerSpec {name: NAME}` takes any of them
by name). The default learned policy, which `sim` and
`eval` run without `--planner`, is marked.
"""

from __future__ import annotations

import argparse
import json
import sys
from dataclasses import asdict, dataclass
from pathlib import Path

DEFAULT_POLICY_NAME = "policy"  # the learned policy we ship as the default
DEFAULT_PLANNER = DEFAULT_POLICY_NAME  # `sim` / `eval --planner`'s default
STATE = "crowd state"
READS_STATE = "privileged (truth); deployable with --state-source lidar"


@dataclass(frozen=True)
class PlannerRow:
    """What `emonav planners` says of one planner."""

    name: str
    summary: str
    reads: str
    privileged: str
    checkpoint: str  # the default checkpoint (package-relative path), or "-"
    default: str  # "" or why it is marked
    spec: str  # the registry's spec in YAML form (`describe_spec`), e.g. "!MpcSpec {}"


def add_parser(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Register `emonav planners` on the CLI's sub-parsers."""
    p = subparsers.add_parser(
        "planners",
        help="list every planner: what it is, what it reads (privileged or deployable), "
        "its default checkpoint",
    )
    p.add_argument("--json", action="store_true", help="print the rows as JSON")
    p.set_defaults(func=cmd_planners)
    return p


def planner_rows() -> list[PlannerRow]:
    """The rows, in registration order."""
    from emonav_drake.planners import MPC_STEERED, SHIELDED, planner_kind, planner_names
    from emonav_drake.planners.specs import describe_spec

    rows = []
    for name in planner_names():
        kind = planner_kind(name)
        checkpoint, reads, privileged = "-", STATE, READS_STATE
        if kind.learned:
            path = _default_checkpoint(kind)
            checkpoint = "- (give --checkpoint)" if path is None else _shown(path)
            if kind.runs_as == "sarl":
                reads = f"{STATE} (value network)"
            else:
                reads, privileged = _policy_reads(path)
                base = name.removesuffix("_digit")
                if base in SHIELDED:
                    reads += " + the LGM shield"
                elif name in MPC_STEERED:
                    reads += f" + the MPC on the {STATE}"
                    privileged = READS_STATE
        default = ""
        if name == DEFAULT_POLICY_NAME:
            default = "default learned policy; sim/eval default"
        spec = describe_spec(kind.spec)
        rows.append(PlannerRow(name, kind.summary, reads, privileged, checkpoint, default, spec))
    return rows


def _default_checkpoint(kind) -> Path | None:  # noqa: ANN001 - a PlannerKind
    from emonav_drake.params import ConfigError

    if kind.default_checkpoint is None:
        return None
    try:
        return Path(kind.default_checkpoint())
    except ConfigError:  # "sac": none shipped
        return None


def _policy_reads(path: Path | None) -> tuple[str, str]:
    """(what a policy checkpoint reads, privileged or deployable)."""
    from emonav_drake.planners.policy import load_policy

    if path is None or not path.is_file():
        return "its checkpoint's map observation", "deployable unless its maps are DRL-VO*"
    _, meta = load_policy(path)
    kind = meta["observation"]["grid_kind"]
    frames = meta["observation"]["num_frames"]
    what = {"lgm": "LiDAR grid maps", "ogm": "occupancy grid maps", "scan": "LiDAR scans"}
    if kind == "drlvo":
        return (
            "scan + pedestrian velocity image (DRL-VO*)",
            "privileged (pedestrian velocities from the simulator)",
        )
    return f"{frames} × {what.get(kind, kind)}", "deployable (its own LiDAR)"


def _shown(path: Path) -> str:
    """A checkpoint path as a user finds it: relative to the package's parent."""
    root = Path(__file__).resolve().parent.parent.parent
    try:
        return str(path.resolve().relative_to(root))
    except ValueError:
        return str(path)


def cmd_planners(args: argparse.Namespace) -> int:
    """Print the planner table (or JSON)."""
    rows = planner_rows()
    if args.json:
        sys.stdout.write(json.dumps([asdict(r) for r in rows], indent=1) + "\n")
        return 0
    for r in rows:
        mark = f"  [{r.default}]" if r.default else ""
        print(f"{r.name}{mark}")
        print(f"    {r.summary}")
        print(f"    reads: {r.reads} — {r.privileged}")
        if r.checkpoint != "-":
            print(f"    checkpoint: {r.checkpoint}")
        print(f"    spec: {r.spec}")
    return 0
