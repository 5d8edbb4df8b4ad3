"""The shipped checkpoints and how each was made, read without torch.

`data/policies/catalog.json` holds, for every checkpoint the package ships (keyed by its
path under `data/`), what `describe_checkpoint` reads from the checkpoint's own metadata:
its SHA-256 and size, the network and what it observes, and its provenance in words — the
training route, the teacher it imitated, its stages (DAgger rounds, Digit rounds, value
learning) and the run directory it came from. `emonav planners` lists the planners from it
in well under a second (loading the 16 checkpoints with torch took seconds);
`scripts/write_policy_catalog.py` writes it from the checkpoints, and a test checks that
it matches them byte for byte (hashes) and fact for fact.

Also the paths of the shipped checkpoints that code imports without wanting torch
(`DEFAULT_POLICY`, `LIP_POLICY`). Pure Python: no torch, no numpy.
"""

from __future__ import annotations

import functools
import json
import re
from pathlib import Path

DATA_DIR = Path(__file__).resolve().parent.parent / "data"
POLICY_DIR = DATA_DIR / "policies"
# What `--planner policy` runs without `--checkpoint` (data/README.md: why it is the default)
DEFAULT_POLICY = POLICY_DIR / "emobipednav_distilled_digit.pt"
LIP_POLICY = DATA_DIR / "policy_lgm.pt"  # the paper's policy, trained on the LIP
CATALOG_FILE = POLICY_DIR / "catalog.json"

# A DAgger configuration without an `expert` field predates the field: its expert was DWA.
_OLD_DAGGER_EXPERT = "dwa"
_TEACHERS = {
    "dwa": "DWA",
    "mpc": "the OSQP MPC",
    "shield": "its own LGM shield (soft labels)",
}
_MAPS = {"lgm": "LiDAR grid maps", "ogm": "occupancy grid maps", "scan": "LiDAR scans"}


def catalog_key(path: str | Path) -> str | None:
    """The catalog's key of a checkpoint file (its path under `data/`), or None for a file
    outside the package's data."""
    try:
        return Path(path).resolve().relative_to(DATA_DIR.resolve()).as_posix()
    except ValueError:
        return None


@functools.cache
def load_catalog() -> dict[str, dict]:
    """The catalog: {path under data/: entry} (empty when the file is missing)."""
    if not CATALOG_FILE.is_file():
        return {}
    return json.loads(CATALOG_FILE.read_text())["checkpoints"]


def catalog_entry(path: str | Path) -> dict | None:
    """The catalog's entry of a shipped checkpoint, or None (a file of the user's own)."""
    key = catalog_key(path)
    return None if key is None else load_catalog().get(key)


def _teacher(config: dict, route: str) -> str:
    expert = config.get("expert", _OLD_DAGGER_EXPERT if route.startswith("dagger") else None)
    if isinstance(expert, dict):  # a planner spec written out in full
        expert = expert.get("name") or expert.get("_tag") or str(expert)
    name = _TEACHERS.get(str(expert), str(expert)) if expert is not None else "none"
    shielded = config.get("expert_policy")
    if expert == "shield" and shielded:
        name = f"the LGM shield around {shielded} (soft labels)"
    return name


def _run_directory(provenance: dict) -> str:
    """The run directory a checkpoint came from: its command's --out (or --resume)."""
    command = provenance.get("command") or ""
    found = re.search(r"--(?:out|resume)\s+(\S+)", command)
    if not found:
        return "not recorded in the checkpoint (data/README.md names it)"
    return re.sub(r"^.*?/(runs/)", r"\1", found.group(1))  # as a user reruns it: runs/NAME


def _stages(provenance: dict) -> list[str]:
    route = provenance.get("route", "")
    config = provenance.get("config") or {}
    if route == "sarl":
        return [
            f"imitation of {_teacher(config, route)} ({config.get('il_episodes', '?')} episodes)",
            f"value learning, {config.get('rl_episodes', '?')} episodes; kept: episode "
            f"{provenance.get('episode', '?')}",
        ]
    if route == "dagger+digit":
        return [
            "continues " + re.sub(r"^.*?/(runs/)", r"\1", str(provenance.get("source", "?"))),
            f"DAgger on the full-order Digit ({config.get('rounds', '?')} rounds of "
            f"{config.get('episodes', '?')} episodes); kept: round {provenance.get('round', '?')}",
        ]
    if route.startswith("dagger"):
        rounds = config.get("rounds", "?")
        family = config.get("family")
        where = f" on the {family} family" if family and family != "paper" else ""
        world = " in the Digit-calibrated world" if config.get("response") == "digit" else ""
        init = config.get("init_policy")
        init = "the LIP-trained policy (policy_lgm.pt)" if init == "shipped" else init
        start = [f"starts from {init}"] if init else []
        return [
            *start,
            f"DAgger{world}{where}: {config.get('expert_episodes', '?')} expert episodes, "
            f"{rounds} rounds of {config.get('episodes_per_round', '?')}; kept: round "
            f"{provenance.get('round', '?')}",
        ]
    return [route or "?"]


def describe_checkpoint(blob: dict, sha256: str, size: int) -> dict:
    """A catalog entry from a loaded checkpoint (`blob`: its dictionary, weights aside)."""
    provenance = blob.get("provenance") or {}
    config = provenance.get("config") or {}
    route = str(provenance.get("route", "?"))
    entry: dict = {"sha256": sha256, "bytes": int(size), "format": blob.get("format")}
    observation = blob.get("observation")
    if observation:  # a map policy (emonav-policy/1)
        kind = observation.get("grid_kind", "?")
        frames = observation.get("num_frames", "?")
        entry["reads"] = (
            "scan + pedestrian velocity image (DRL-VO*)"
            if kind == "drlvo"
            else f"{frames} × {_MAPS.get(kind, kind)}"
        )
        entry["privileged"] = (
            "privileged (pedestrian velocities from the simulator)"
            if kind == "drlvo"
            else "deployable (its own LiDAR)"
        )
    else:  # a value network (SARL, RGL): the crowd state
        entry["reads"] = f"crowd state ({blob.get('network', 'sarl')} value network)"
        entry["privileged"] = "privileged (truth); deployable with --state-source lidar"
    entry["route"] = route
    entry["teacher"] = _teacher(config, route)
    entry["stages"] = _stages(provenance)
    entry["run"] = _run_directory(provenance)
    return entry


def made_by(entry: dict) -> str:
    """One line: how a catalogued checkpoint was made (teacher, then its stages)."""
    return f"teacher {entry['teacher']}; " + "; ".join(entry["stages"])
