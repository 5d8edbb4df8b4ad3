"""Trained navigation policies: checkpoint format, loading with clear errors, the planner.

A policy checkpoint is one `torch.save` file:

    {"format": "emonav-policy/1",
     "kind": "categorical" | "gaussian",       # student over a command grid | SAC actor
     "encoder": {"type": "lgm" | "scan", ...}, # constructor arguments
     "hidden": int, "commands": [[u_v, u_dθ], ...] (categorical only),
     "observation": {"grid_kind": "lgm"|"ogm"|"scan", "num_frames": N, "grid_size": M},
     "bounds": [ū_v, ū_Δθ], "state_dict": {...}, "provenance": {...}}

`PolicyPlanner` implements the planner interface (`systems.navigation_planner.Planner`:
`plan(PlannerInput)`, `reset`, and the memoryless `initial_memory`/`plan_with_memory`), so a
policy drives the Drake diagram (`emonav sim --planner sac`) or the Gymnasium env
exactly like DWA or MPC. It uses only the grid-map stack, the goal state and the last
command — never the privileged crowd state.
"""

from __future__ import annotations

import io
import os
import tempfile
from pathlib import Path
from typing import Any

import numpy as np
import torch

from emonav_drake.core.navigation import PlannerInput
from emonav_drake.learning.networks import (
    Actor,
    CategoricalPolicy,
    LgmEncoder,
    ScanEncoder,
    ScanLstmEncoder,
)

FORMAT = "emonav-policy/1"
DEFAULT_POLICY = Path(__file__).resolve().parent.parent / "data" / "policy_lgm.pt"


class PolicyError(ValueError):
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


def build_encoder(spec: dict[str, Any]) -> torch.nn.Module:
    args = {k: v for k, v in spec.items() if k != "type"}
    if spec["type"] == "lgm":
        return LgmEncoder(**args)
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
    """Write `obj` with torch.save to a temporary file, then rename: never half-written."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=path.name, suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as f:
            torch.save(obj, f)
        os.chmod(tmp, 0o644)  # mkstemp creates 0600
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def save_policy(path: str | Path, model: torch.nn.Module, meta: dict[str, Any]) -> None:
    """Save a policy checkpoint (atomically) with its metadata."""
    state = {k: v.detach().cpu().clone() for k, v in model.state_dict().items()}
    atomic_torch_save({"format": FORMAT, **meta, "state_dict": state}, path)


def load_policy(path: str | Path, device: str = "cpu") -> tuple[torch.nn.Module, dict]:
    """Load a checkpoint; `PolicyError` names what is wrong (file, format, shapes)."""
    path = Path(path)
    if not path.is_file():
        raise PolicyError(f"policy checkpoint {path} does not exist")
    try:
        blob = torch.load(io.BytesIO(path.read_bytes()), map_location=device, weights_only=True)
    except Exception as e:
        raise PolicyError(f"{path} is not a readable policy checkpoint ({e})") from None
    if not isinstance(blob, dict) or blob.get("format") != FORMAT:
        raise PolicyError(f"{path} is not an {FORMAT} checkpoint")
    try:
        model = build_model(blob)
        model.load_state_dict(blob["state_dict"])
    except (KeyError, RuntimeError, TypeError) as e:
        raise PolicyError(f"{path}: weights do not match the described network: {e}") from None
    model.to(device).eval()
    return model, blob


class PolicyPlanner:
    """A trained policy as a planner (deterministic: the mode of the action distribution).

    Args:
        path: checkpoint file (default: the policy shipped with the package).
        device: "cpu" or "cuda".
    """

    name = "sac"

    def __init__(self, path: str | Path | None = None, device: str = "cpu") -> None:
        self.path = Path(path) if path is not None else DEFAULT_POLICY
        self.device = torch.device(device)
        self.model, self.meta = load_policy(self.path, device)
        self.bounds = tuple(self.meta["bounds"])
        ob = self.meta["observation"]
        self.grid_kind = ob["grid_kind"]
        self.expected_shape = (ob["num_frames"], ob["grid_size"], ob["grid_size"])
        if self.meta["kind"] == "categorical":
            self.commands = np.asarray(self.meta["commands"], dtype=float)

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
        if lgm_stack is None or not isinstance(lgm_stack, np.ndarray):
            raise PolicyError(f"policy {self.path.name} needs a grid-map stack, got none")
        if lgm_stack.shape != self.expected_shape or lgm_stack.dtype != np.uint8:
            raise PolicyError(
                f"policy {self.path.name} expects a uint8 {self.grid_kind} stack of shape "
                f"{self.expected_shape}, got {lgm_stack.dtype} {lgm_stack.shape}"
            )
        return lgm_stack

    @torch.no_grad()
    def act(
        self, lgm_stack: np.ndarray, goal_state: np.ndarray, last_command: np.ndarray
    ) -> np.ndarray:
        """The command (u_v [m/s], u_Δθ [rad]) for one observation."""
        obs = torch.from_numpy(self.check_observation(lgm_stack)[None]).to(self.device)
        state = torch.from_numpy(vector_state(goal_state, last_command, self.bounds)[None])
        state = state.to(self.device)
        if self.meta["kind"] == "categorical":
            return self.commands[int(self.model(obs, state).argmax())].copy()
        _, _, mean = self.model.sample(obs, state)
        a = mean[0].cpu().numpy().astype(float)
        return np.array([(a[0] + 1) / 2 * self.bounds[0], a[1] * self.bounds[1]])

    def plan(self, obs: PlannerInput) -> np.ndarray:
        """The command (u_v [m/s], u_Δθ [rad]) for this walking step."""
        return self.act(obs.lgm_stack, obs.goal_state(), obs.last_command)


def export_torchscript(path: str | Path, out: str | Path) -> Path:
    """Export a checkpoint's network to TorchScript (inputs: uint8 stack, vector state)."""
    model, meta = load_policy(path)
    frames, size = meta["observation"]["num_frames"], meta["observation"]["grid_size"]
    example = (torch.zeros(1, frames, size, size, dtype=torch.uint8), torch.zeros(1, 4))
    scripted = torch.jit.trace(
        model if meta["kind"] == "categorical" else _ActorMean(model), example
    )
    out = Path(out)
    scripted.save(str(out))
    return out


class _ActorMean(torch.nn.Module):
    def __init__(self, actor: Actor) -> None:
        super().__init__()
        self.actor = actor

    def forward(self, obs: torch.Tensor, state: torch.Tensor) -> torch.Tensor:
        mu, _ = self.actor(obs, state)
        return torch.tanh(mu)
