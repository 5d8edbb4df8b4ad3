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
import textwrap
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
    made_by: str = ""  # a learned planner's route, teacher, stages (`planners/catalog.py`)
    run: str = ""  # the run directory its default checkpoint came from
    group: str = ""  # `GROUPS`: where the listing puts it


# The listing's groups, in order; without --all the last one is summarised in a line.
GROUPS = (
    "the default",
    "model-based",
    "learned baselines of the paper",
    "route stages, ablations and shields",
)


def add_parser(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Register `emonav planners` on the CLI's sub-parsers."""
    p = subparsers.add_parser(
        "planners",
        help="list every planner: what it is, what it reads (privileged or deployable), "
        "its default checkpoint",
    )
    p.add_argument("--json", action="store_true", help="print the rows as JSON")
    p.add_argument(
        "--all",
        action="store_true",
        help="also list the route stages, ablations and shielded planners one by one",
    )
    p.set_defaults(func=cmd_planners)
    return p


def planner_rows() -> list[PlannerRow]:
    """The rows, in registration order."""
    from emonav_drake.planners import MPC_STEERED, SHIELDED, planner_kind, planner_names
    from emonav_drake.planners.catalog import catalog_entry, made_by
    from emonav_drake.planners.specs import describe_spec

    composite = set(MPC_STEERED) | set(SHIELDED) | {f"{n}_digit" for n in SHIELDED}
    rows = []
    for name in planner_names():
        kind = planner_kind(name)
        checkpoint, reads, privileged, how, run = "-", STATE, READS_STATE, "", ""
        if kind.learned:
            path = _default_checkpoint(kind)
            checkpoint = "- (give --checkpoint)" if path is None else _shown(path)
            entry = None if path is None else catalog_entry(path)
            if entry is not None:
                how, run = made_by(entry), entry["run"]
            if getattr(kind.spec, "value_network", False):
                reads = f"{STATE} (value network)"
            else:
                reads, privileged = _policy_reads(path, entry)
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
        rows.append(
            PlannerRow(
                name,
                kind.summary,
                reads,
                privileged,
                checkpoint,
                default,
                spec,
                how,
                run,
                _group(name, kind.learned or name in composite),
            )
        )
    return rows


def _group(name: str, learned: bool) -> str:
    """Where the listing puts a planner (`GROUPS`); `learned`: it runs a network (a shielded
    or MPC-steered policy included)."""
    if name == DEFAULT_POLICY_NAME:
        return GROUPS[0]
    if not learned:
        return GROUPS[1]
    from emonav_drake.planners import PAPER_BASELINES

    if name in PAPER_BASELINES:
        return GROUPS[2]
    return GROUPS[3]


def _default_checkpoint(kind) -> Path | None:  # noqa: ANN001 - a PlannerKind
    from emonav_drake.params import ConfigError

    if kind.default_checkpoint is None:
        return None
    try:
        return Path(kind.default_checkpoint())
    except ConfigError:  # a variant with none shipped in this version
        return None


def _policy_reads(path: Path | None, entry: dict | None = None) -> tuple[str, str]:
    """(what a policy checkpoint reads, privileged or deployable): from its catalog `entry`
    for a shipped one (no torch), else from the file."""
    if entry is not None:
        return entry["reads"], entry["privileged"]
    if path is None or not path.is_file():
        return "its checkpoint's map observation", "deployable unless its maps are DRL-VO*"
    from emonav_drake.planners.policy import load_policy

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
    for group in GROUPS:
        members = [r for r in rows if r.group == group]
        if group == GROUPS[-1] and not args.all:
            names = ", ".join(r.name for r in members)
            print(f"\n{group} ({len(members)}; `emonav planners --all` describes them):")
            print(textwrap.fill(names, 88, initial_indent="  ", subsequent_indent="  "))
            continue
        print(f"\n{group}:" if group != GROUPS[0] else f"{group}:")
        for r in members:
            _print_row(r)
    return 0


def _print_row(r: PlannerRow) -> None:
    mark = f"  [{r.default}]" if r.default else ""
    print(f"{r.name}{mark}")
    print(f"    {r.summary}")
    print(f"    reads: {r.reads} — {r.privileged}")
    if r.made_by:
        print(f"    made by: {r.made_by}")
        print(f"    run: {r.run}")
    if r.checkpoint != "-":
        print(f"    checkpoint: {r.checkpoint}")
    print(f"    spec: {r.spec}")
