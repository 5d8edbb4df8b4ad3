"""Trained navigation policies: checkpoint format, loading with clear errors, the planner.

A policy checkpoint is one `torch.save` file:

    {"format": "emonav-policy/1",
     "kind": "categorical" | "gaussian",       # student over a command grid | SAC actor
     "encoder": {"type": "lgm" | "scan" | "scan_lstm", ...}, # constructor arguments
     "hidden": int, "commands": [[u_v, u_dθ], ...] (categorical only),
     "observation": {"grid_kind": "lgm"|"ogm"|"scan"|"drlvo", "num_frames": N,
                     "grid_size": M, "goal_input": "goal"|"guide" (absent: "goal")},
     "bounds": [ū_v, ū_Δθ], "state_dict": {...}, "provenance": {...}}

`PolicyPlanner` implements the planner interface (`planners.protocol.Planner`:
`plan(PlannerInput)`, `reset`, and the memoryless `initial_memory`/`plan_with_memory`), so a
policy drives the Drake diagram (`emonav sim --planner policy`) or the Gymnasium env
exactly like DWA or MPC. It uses only the map observation of its grid kind (the planner
input's `lgm_stack`: uint8 (N, M, M) LGM/OGM stack, float32 (N, K) scan stack [m], uint8
(1, 3, M, M) DRL-VO* image; `navigation/lip_world.py`), the goal state and the last command —
never the pedestrians' privileged state. A policy trained with `goal_input: guide` reads
the bearing of a sub-goal on the shortest path around the static discs instead of the
goal's (`navigation/goal_input.py`): the discs are then known map obstacles.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import torch

from emonav_drake.atomic_io import atomic_write
from emonav_drake.errors import UserError
from emonav_drake.navigation.goal_input import check_goal_input
from emonav_drake.navigation.lip_world import PlannerInput
from emonav_drake.navigation.observations import observation_kind, observation_kinds
from emonav_drake.params import NUM_BEAMS, LidarParams, RobotParams
from emonav_drake.planners.catalog import DEFAULT_POLICY as _SHIPPED_DEFAULT
from emonav_drake.planners.networks import (
    Actor,
    CategoricalPolicy,
    LgmEncoder,
    LgmTracksEncoder,
    ScanEncoder,
    ScanLstmEncoder,
)
from emonav_drake.torch_device import resolve_device
from emonav_drake.torch_load import CheckpointReadError, load_checked

FORMAT = "emonav-policy/1"
_DATA = Path(__file__).resolve().parent.parent / "data"
# The LIP-trained student (LIP/·; variant `emobipednav`; "shipped" as a route's init_policy).
LIP_POLICY = _DATA / "policy_lgm.pt"
# What `--planner policy` runs without a --checkpoint: the distilled route's Digit round 2
# (the MPC route's student, `emobipednav_digit_mpc`, distilled with its LGM shield in the
# calibrated world and then on Digit; data/README.md says why and with which numbers).
DEFAULT_POLICY = _SHIPPED_DEFAULT


class PolicyError(UserError, ValueError):
    """A policy checkpoint is missing, corrupt, or does not fit the observation."""


def vector_state(
    goal_state: np.ndarray, last_command: np.ndarray, bounds: tuple[float, float]
) -> np.ndarray:
    """The authors' normalised vector state [d/10, φ/π, v_last/ū_v, Δθ_last/ū_Δθ]."""
    return np.array(
        [
            goal_state[0] / 10.0,
            goal_state[1] / np.pi,
            last_command[0] / bounds[0],
            last_command[1] / bounds[1],
        ],
        np.float32,
    )


def encoder_spec(
    grid_kind: str,
    encoder: str,
    num_frames: int,
    grid_size: int,
    features: int = 50,
    filters: int = 32,
    pool: int = 1,
) -> dict[str, Any]:
    """The checkpoint's encoder description for an observation variant (`build_encoder`).

    "scan" with encoder "lstm" → LSTM over scans (LNDNL); "scan" → 1-D CNN (LiDAR-SAC);
    every grid kind → the paper's 2-D CNN on N (DRL-VO*: 3 N; "lgm_vel": N + 2) planes of
    M × M cells; "lgm_tracks" → that CNN on its N maps and an MLP on its pedestrians'
    table (`LgmTracksEncoder`).
    """
    kind = observation_kind(grid_kind)
    if kind.scans and encoder == "lstm":
        return {"type": "scan_lstm", "frames": num_frames, "features": features}
    if kind.scans:
        return {"type": "scan", "frames": num_frames, "features": features, "filters": filters}
    return {
        "type": kind.encoder,
        "frames": kind.planes(num_frames),
        "size": grid_size,
        "features": features,
        "filters": filters,
        "pool": pool,
        **kind.encoder_args,
    }


def build_encoder(spec: dict[str, Any]) -> torch.nn.Module:
    args = {k: v for k, v in spec.items() if k != "type"}
    if spec["type"] == "lgm":
        return LgmEncoder(**args)
    if spec["type"] == "lgm_tracks":
        return LgmTracksEncoder(**args)
    if spec["type"] == "scan":
        return ScanEncoder(**args)
    if spec["type"] == "scan_lstm":
        return ScanLstmEncoder(**args)
    raise PolicyError(f"unknown encoder type {spec['type']!r}")


def build_model(meta: dict[str, Any]) -> torch.nn.Module:
    """The network described by a checkpoint's metadata (weights not loaded)."""
    encoder = build_encoder(meta["encoder"])
    if meta["kind"] == "categorical":
        return CategoricalPolicy(encoder, len(meta["commands"]), meta["hidden"])
    if meta["kind"] == "gaussian":
        return Actor(encoder, meta["hidden"])
    raise PolicyError(f"unknown policy kind {meta['kind']!r}")


def atomic_torch_save(obj: Any, path: str | Path) -> None:
    """`torch.save` of `obj`, durable and atomic (`atomic_io.atomic_write`)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write(path, lambda f: torch.save(obj, f))


def save_policy(path: str | Path, model: torch.nn.Module, meta: dict[str, Any]) -> None:
    """Save a policy checkpoint (atomically) with its metadata."""
    state = {k: v.detach().cpu().clone() for k, v in model.state_dict().items()}
    atomic_torch_save({"format": FORMAT, **meta, "state_dict": state}, path)


def _check_meta(path: Path, blob: dict) -> None:
    """Every metadata field the planner and the exporter read, present and well-formed."""

    def bad(field: str, why: str) -> PolicyError:
        return PolicyError(f"{path}: checkpoint field {field} {why}")

    for key in ("kind", "encoder", "hidden", "observation", "bounds", "state_dict"):
        if key not in blob:
            raise bad(key, "is missing (not a complete emonav policy; re-export it)")
    if blob["kind"] not in ("categorical", "gaussian"):
        raise bad("kind", f"= {blob['kind']!r} is invalid: must be categorical or gaussian")
    enc = blob["encoder"]
    if not isinstance(enc, dict) or "type" not in enc:
        raise bad("encoder", f"= {enc!r} is invalid: must be a mapping with a 'type'")
    ob = blob["observation"]
    if not isinstance(ob, dict):
        raise bad("observation", f"= {ob!r} is invalid: must be a mapping")
    for key in ("grid_kind", "num_frames", "grid_size"):
        if key not in ob:
            raise bad(f"observation.{key}", "is missing")
    for key in ("num_frames", "grid_size"):
        if not (isinstance(ob[key], int) and ob[key] >= 1):
            raise bad(f"observation.{key}", f"= {ob[key]!r} is invalid: must be an integer >= 1")
    if ob["grid_kind"] not in observation_kinds():
        raise bad("observation.grid_kind", f"= {ob['grid_kind']!r} is invalid")
    b = blob["bounds"]
    if not (
        isinstance(b, (list, tuple))
        and len(b) == 2
        and all(isinstance(v, (int, float)) and math.isfinite(v) and v > 0 for v in b)
    ):
        raise bad("bounds", f"= {b!r} is invalid: must be [max_speed, max_heading_change] > 0")
    if enc["type"] in ("lgm", "lgm_tracks"):
        planes = observation_kind(ob["grid_kind"]).planes(ob["num_frames"])
        if "size" in enc and enc["size"] != ob["grid_size"]:
            raise bad(
                "observation.grid_size",
                f"= {ob['grid_size']} does not fit the encoder (size {enc['size']})",
            )
        if "frames" in enc and enc["frames"] != planes:
            raise bad(
                "observation.num_frames",
                f"= {ob['num_frames']} does not fit the encoder ({enc['frames']} input planes)",
            )
    if blob["kind"] == "categorical":
        c = np.asarray(blob.get("commands", []), dtype=float)
        if c.ndim != 2 or c.shape[1:] != (2,) or len(c) == 0 or not np.isfinite(c).all():
            raise bad("commands", "is missing or not a non-empty list of [u_v, u_dtheta]")


def policy_kind(meta: dict[str, Any]) -> str:
    """How a checkpoint's policy was trained: "sac" for a SAC actor (Gaussian over the
    continuous command), "dagger" for an imitation student (categorical over a command
    grid), from its provenance when recorded, else from its head."""
    route = (meta.get("provenance") or {}).get("route")
    if route in ("sac", "dagger"):
        return route
    return "sac" if meta.get("kind") == "gaussian" else "dagger"


def describe_policy(meta: dict[str, Any]) -> str:
    """One line for a user: route (and round, variant), observation."""
    prov = meta.get("provenance") or {}
    ob = meta["observation"]
    kinds = observation_kinds()
    what = (
        observation_kind(ob["grid_kind"]).description
        if ob["grid_kind"] in kinds
        else ob["grid_kind"]
    )
    if policy_kind(meta) == "sac":
        route = "SAC actor"
    elif prov.get("route") == "finetune":
        route = "DAgger student fine-tuned by SAC"
    else:
        route = "DAgger student"
        if "round" in prov:
            route += f" (round {prov['round']})"
    if prov.get("variant"):
        route += f", variant {prov['variant']}"
    guide = ", goal input: guide sub-goal" if goal_input_of(meta) == "guide" else ""
    return f"{route}, {ob['num_frames']} × {what}{guide}"


def goal_input_of(meta: dict[str, Any]) -> str:
    """The goal input a checkpoint's policy reads ("goal" or "guide"; `navigation/goal_input.py`);
    checkpoints from before the key existed read "goal"."""
    return check_goal_input(meta["observation"].get("goal_input", "goal"))


def observation_spec(meta: dict[str, Any]) -> tuple[str, tuple[int, ...], np.dtype]:
    """(grid kind, shape, dtype) of the map observation a checkpoint's policy reads.

    The shapes of `navigation.observations.observation_shape` with the checkpoint's N, M and, for
    scans, K = the encoder's beams: uint8 (N, M, M) for "lgm"/"ogm", float32 (N, K) for
    "scan", uint8 (N, 3, M, M) for "drlvo" (the env and the diagram give N = 1).
    """
    ob = meta["observation"]
    kind = observation_kind(ob["grid_kind"])
    beams = int(meta["encoder"].get("beams", NUM_BEAMS))
    lidar = LidarParams(num_frames=ob["num_frames"], grid_size=ob["grid_size"], num_beams=beams)
    shape = kind.shape(lidar)
    if kind.single_frame:  # as declared: `configure_for` refuses N > 1
        shape = (ob["num_frames"], *shape[1:])
    return kind.name, shape, kind.dtype


def probe_input(meta: dict[str, Any]) -> tuple[torch.Tensor, torch.Tensor]:
    """A zero observation of the shape the checkpoint declares (uint8 stack, vector state)."""
    ob = meta["observation"]
    kind = observation_kind(ob["grid_kind"])
    frames, size = kind.planes(ob["num_frames"]), ob["grid_size"]
    if kind.scans:
        beams = meta["encoder"].get("beams", NUM_BEAMS)
        return torch.zeros(1, frames, beams), torch.zeros(1, 4)
    return torch.zeros(1, frames, size, size, dtype=torch.uint8), torch.zeros(1, 4)


# A trained network's weights are of order 1 (the shipped policies' largest is 6.2); a
# weight this large is a damaged or tampered file, whose policy would saturate.
MAX_WEIGHT = 1e6


def _check_weight_magnitude(path: Path, state_dict: dict[str, torch.Tensor]) -> None:
    """`PolicyError` if a weight's magnitude reaches `MAX_WEIGHT`."""
    for name, w in state_dict.items():
        if w.is_floating_point() and w.numel() and float(w.abs().max()) >= MAX_WEIGHT:
            raise PolicyError(
                f"policy checkpoint {path}: weight {name} reaches {float(w.abs().max()):.3g} "
                f"(a trained policy's are of order 1; >= {MAX_WEIGHT:g} is refused): a damaged "
                "or altered file"
            )


def load_policy(path: str | Path, device: str = "cpu") -> tuple[torch.nn.Module, dict]:
    """Load a checkpoint; `PolicyError` names what is wrong (file, format, fields, shapes).

    Besides the weights, the metadata is checked (every field the planner reads) and one
    forward pass on a zero observation of the declared shape proves that the observation
    fits the encoder — a wrong `observation.grid_size` fails here, not at the first step.
    """
    path = Path(path)
    dev = resolve_device(device)
    if path.is_dir():
        raise PolicyError(f"policy checkpoint {path} is a directory, not a file")
    if not path.is_file():
        raise PolicyError(f"policy checkpoint {path} does not exist")
    try:
        blob = load_checked(path, map_location=dev)
    except CheckpointReadError as e:
        if e.kind == "code":
            raise PolicyError(f"{path} is not an emonav policy checkpoint: {e}") from None
        if e.kind == "damaged":
            raise PolicyError(f"{path} is not a readable policy checkpoint ({e})") from None
        raise PolicyError(f"policy checkpoint {path}: {e}") from None
    if not isinstance(blob, dict) or blob.get("format") != FORMAT:
        raise PolicyError(f"{path} is not an {FORMAT} checkpoint")
    _check_meta(path, blob)
    try:
        model = build_model(blob)
        model.load_state_dict(blob["state_dict"])
    except PolicyError as e:
        raise PolicyError(f"{path}: {e}") from None
    except (KeyError, RuntimeError, TypeError, ValueError) as e:
        raise PolicyError(f"{path}: weights do not match the described network: {e}") from None
    _check_weight_magnitude(path, blob["state_dict"])
    model.to(dev).eval()
    obs, state = probe_input(blob)
    try:
        with torch.no_grad():
            model(obs.to(dev), state.to(dev))
    except (RuntimeError, ValueError) as e:
        ob = blob["observation"]
        raise PolicyError(
            f"{path}: observation (grid_kind {ob['grid_kind']}, num_frames {ob['num_frames']}, "
            f"grid_size {ob['grid_size']}) does not fit the encoder {blob['encoder']}: "
            f"{str(e).splitlines()[0]}"
        ) from None
    return model, blob


class PolicyPlanner:
    """A trained policy as a planner (deterministic: the mode of the action distribution).

    Args:
        path: checkpoint file (default: the policy shipped with the package).
        device: "cpu" or "cuda".
    """

    name = "policy"

    def __init__(
        self,
        path: str | Path | None = None,
        device: str = "cpu",
        robot_radius: float | None = None,
    ) -> None:
        self.path = Path(path) if path is not None else DEFAULT_POLICY
        self.device = resolve_device(device)
        self.model, self.meta = load_policy(self.path, device)
        self.bounds = tuple(self.meta["bounds"])
        self.grid_kind, self.expected_shape, self.expected_dtype = observation_spec(self.meta)
        self.goal_input = goal_input_of(self.meta)
        # r_robot [m]: the clearance of a "guide" goal input (default: `RobotParams`)
        self.robot_radius = RobotParams().radius if robot_radius is None else robot_radius
        if self.meta["kind"] == "categorical":
            self.commands = np.asarray(self.meta["commands"], dtype=float)

    def describe(self) -> str:
        """What this policy is, for a user: how it was trained, what it reads, its file."""
        return f"{describe_policy(self.meta)} ({self.path})"

    def initial_memory(self) -> None:
        """The policy is memoryless: the frame stack and the last command (the planner
        input's `last_command`; in the diagram the planner system's stored command) carry
        the history."""
        return None

    def reset(self) -> None:
        """The policy is memoryless (see `initial_memory`)."""

    def plan_with_memory(self, obs: PlannerInput, memory: None) -> tuple[np.ndarray, None]:
        """`plan(obs)` and the (empty) memory: the planner interface of the diagram."""
        return self.plan(obs), None

    def check_observation(self, lgm_stack: np.ndarray | None) -> np.ndarray:
        """`lgm_stack` if it is the observation this policy reads, else `PolicyError`."""
        if lgm_stack is None or not isinstance(lgm_stack, np.ndarray):
            raise PolicyError(
                f"policy {self.path.name} needs a {self.grid_kind} observation, got none"
            )
        if lgm_stack.shape != self.expected_shape or lgm_stack.dtype != self.expected_dtype:
            raise PolicyError(
                f"policy {self.path.name} expects a {self.expected_dtype} {self.grid_kind} "
                f"observation of shape {self.expected_shape}, got {lgm_stack.dtype} "
                f"{lgm_stack.shape}"
            )
        return lgm_stack

    @torch.no_grad()
    def act(
        self, lgm_stack: np.ndarray, goal_state: np.ndarray, last_command: np.ndarray
    ) -> np.ndarray:
        """The command (u_v [m/s], u_Δθ [rad]) for one observation (`lgm_stack`: the map
        observation of `grid_kind`, of shape `expected_shape` and dtype `expected_dtype`)."""
        if self.meta["kind"] == "categorical":
            scores = self.command_scores(lgm_stack, goal_state, last_command)
            return self.commands[int(scores.argmax())].copy()
        obs, state = self._inputs(lgm_stack, goal_state, last_command)
        _, _, mean = self.model.sample(obs, state)
        a = mean[0].cpu().numpy().astype(float)
        return np.array([(a[0] + 1) / 2 * self.bounds[0], a[1] * self.bounds[1]])

    def _inputs(
        self, lgm_stack: np.ndarray, goal_state: np.ndarray, last_command: np.ndarray
    ) -> tuple[torch.Tensor, torch.Tensor]:
        obs = torch.from_numpy(self.check_observation(lgm_stack)[None]).to(self.device)
        state = torch.from_numpy(vector_state(goal_state, last_command, self.bounds)[None])
        return obs, state.to(self.device)

    @torch.no_grad()
    def command_scores(
        self, lgm_stack: np.ndarray, goal_state: np.ndarray, last_command: np.ndarray
    ) -> np.ndarray:
        """A categorical policy's logits (C,) over its commands `self.commands` (C, 2):
        `act` walks the argmax. `PolicyError` for a Gaussian (SAC) actor."""
        if self.meta["kind"] != "categorical":
            raise PolicyError(
                f"policy {self.path.name} is a {describe_policy(self.meta)}: only a categorical "
                "policy scores a grid of commands"
            )
        obs, state = self._inputs(lgm_stack, goal_state, last_command)
        return self.model(obs, state)[0].cpu().numpy().astype(float)

    def goal_state(self, obs: PlannerInput) -> np.ndarray:
        """(distance [m], bearing [rad]) this policy reads as its goal (its `goal_input`)."""
        return obs.policy_goal_state(self.goal_input, self.robot_radius)

    def plan(self, obs: PlannerInput) -> np.ndarray:
        """The command (u_v [m/s], u_Δθ [rad]) for this walking step."""
        return self.act(obs.lgm_stack, self.goal_state(obs), obs.last_command)


class WrappedPolicy:
    """A planner around a `PolicyPlanner` (`self.policy`) that reads the policy's
    observation: the diagram's map builder produces what these properties say."""

    policy: PolicyPlanner

    @property
    def grid_kind(self) -> str:
        return self.policy.grid_kind

    @property
    def expected_shape(self) -> tuple[int, ...]:
        return self.policy.expected_shape

    @property
    def expected_dtype(self) -> np.dtype:
        return self.policy.expected_dtype

    @property
    def path(self) -> Path:
        return self.policy.path
