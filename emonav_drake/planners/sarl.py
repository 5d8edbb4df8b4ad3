"""SARL: CrowdNav's value network over the joint state, acting by one-step look-ahead.

The paper (§IV-A) names SARL (Chen et al., ICRA 2019) among the planners that fail on the
biped. This is SARL on our task, to test that claim: the crowd state is privileged (every
pedestrian's position, velocity and emotion zone, every static disc), as in CrowdNav;
`planning/sarl_state.py` builds the joint state and the look-ahead on the LIP.

**Network** (`SarlValue`, CrowdNav's sizes): each row (robot ⊕ one agent, 15 features)
→ mlp1 (150, 100) → e_i; the mean of the e_i is the global state; attention
mlp([e_i, mean], 100, 100, 1) → softmax weights α_i; mlp2 (100, 50) of e_i → h_i; the
crowd feature Σ α_i h_i, concatenated with the robot's six self features → mlp3
(150, 100, 100, 1) → V. ReLU between layers (CrowdNav's). Rows may be padded: `mask`
(B, H) marks the real ones.

**Acting** (`SarlPlanner`): for every command of the grid (the DWA candidates: 9 speeds ×
11 heading changes) the look-ahead's reward plus γ^(T·v_pref)·V(next state), argmax;
terminal steps (collision or goal) add no value. Deterministic (no exploration) when
planning; training explores with ε-greedy (`learning/sarl_train.py`).

**RGL** (`RglValue`, Chen et al., IROS 2020): the same rows, the same look-ahead and the
same training route, with a relational graph network as the value (`network: rgl`).

Checkpoint (`torch.save`, loaded with `weights_only=True`):
    {"format": "emonav-sarl/1", "network": "sarl" | "rgl" (absent: "sarl"), "gamma": γ,
     "commands": [[u_v, u_Δθ], …], "state_dict": {...}, "provenance": {...}}
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import torch
from torch import nn

from emonav_drake.navigation.lip_world import PlannerInput
from emonav_drake.params import ConfigError, EmoNavConfig
from emonav_drake.planning.sarl_state import (
    NUM_FEATURES,
    SELF_FEATURES,
    VALUE_NETWORKS,
    lookahead,
    step_discount,
)
from emonav_drake.torch_load import CheckpointReadError, load_checked

SARL_FORMAT = "emonav-sarl/1"


def _mlp(sizes: list[int], last_relu: bool) -> nn.Sequential:
    layers: list[nn.Module] = []
    for i in range(len(sizes) - 1):
        layers.append(nn.Linear(sizes[i], sizes[i + 1]))
        if i < len(sizes) - 2 or last_relu:
            layers.append(nn.ReLU())
    return nn.Sequential(*layers)


class SarlValue(nn.Module):
    """V(joint state): rows (B, H, NUM_FEATURES), mask (B, H) bool → (B,)."""

    def __init__(self) -> None:
        super().__init__()
        self.mlp1 = _mlp([NUM_FEATURES, 150, 100], last_relu=True)
        self.mlp2 = _mlp([100, 100, 50], last_relu=False)
        self.attention = _mlp([200, 100, 100, 1], last_relu=False)
        self.mlp3 = _mlp([50 + SELF_FEATURES, 150, 100, 100, 1], last_relu=False)

    def forward(self, rows: torch.Tensor, mask: torch.Tensor) -> torch.Tensor:
        e = self.mlp1(rows)  # (B, H, 100)
        m = mask.unsqueeze(-1).to(e.dtype)
        count = m.sum(dim=1).clamp(min=1.0)
        mean = (e * m).sum(dim=1) / count  # (B, 100): the global state
        score = self.attention(torch.cat([e, mean.unsqueeze(1).expand_as(e)], dim=-1))
        score = score.squeeze(-1).masked_fill(~mask, float("-inf"))
        alpha = torch.softmax(score, dim=1).unsqueeze(-1)  # (B, H, 1)
        crowd = (alpha * self.mlp2(e)).sum(dim=1)  # (B, 50)
        return self.mlp3(torch.cat([rows[:, 0, :SELF_FEATURES], crowd], dim=-1)).squeeze(-1)


class RglValue(nn.Module):
    """RGL's value (Chen et al., "Relational Graph Learning for Crowd Navigation", IROS
    2020; CrowdNav's `RGL`, sizes of its configuration): V(joint state) from the same rows
    as `SarlValue` — rows (B, H, NUM_FEATURES), mask (B, H) bool → (B,).

    The robot (its six self features, taken from the first row) and every agent (the
    row's agent columns) are the nodes of a graph. Each kind is embedded by its own MLP
    (w_r, w_h: 64, 32, ReLU) into X (B, 1 + H, 32); the relation matrix is the embedded
    Gaussian A = softmax_j(X W_a X^T) (padded agents masked out as neighbours); two graph
    convolutions with skip connections, H_{l+1} = ReLU(A H_l W_l) + H_l; the robot node's
    final feature → value MLP (100, 100, 1). Our rows hold no prediction of the agents
    beyond one step, so RGL's multi-step tree search is not used: it acts, like SARL, by
    the one-step look-ahead (RGL with a depth-1 search and a constant-velocity model)."""

    def __init__(self, dim: int = 32, layers: int = 2) -> None:
        super().__init__()
        agent = NUM_FEATURES - SELF_FEATURES
        self.w_r = _mlp([SELF_FEATURES, 64, dim], last_relu=True)
        self.w_h = _mlp([agent, 64, dim], last_relu=True)
        self.w_a = nn.Parameter(torch.eye(dim))
        self.gcn = nn.ModuleList(nn.Linear(dim, dim, bias=False) for _ in range(layers))
        self.value = _mlp([dim, 100, 100, 1], last_relu=False)

    def forward(self, rows: torch.Tensor, mask: torch.Tensor) -> torch.Tensor:
        robot = self.w_r(rows[:, :1, :SELF_FEATURES])  # (B, 1, d)
        x = torch.cat([robot, self.w_h(rows[:, :, SELF_FEATURES:])], dim=1)  # (B, 1 + H, d)
        valid = torch.cat([torch.ones_like(mask[:, :1]), mask], dim=1)  # (B, 1 + H)
        score = x @ self.w_a @ x.transpose(1, 2)  # (B, 1 + H, 1 + H)
        adjacency = torch.softmax(score.masked_fill(~valid[:, None, :], float("-inf")), dim=2)
        h = x
        for layer in self.gcn:
            h = torch.relu(adjacency @ layer(h)) + h
        return self.value(h[:, 0]).squeeze(-1)


# The value networks a SARL checkpoint may hold (its "network"; absent = "sarl"), under the
# names of `planning.sarl_state.VALUE_NETWORKS`.
_NETWORK_CLASSES: dict[str, type[nn.Module]] = {"sarl": SarlValue, "rgl": RglValue}


def value_network(name: str) -> nn.Module:
    """A fresh value network of kind `name` ("sarl" or "rgl"); `ConfigError` otherwise."""
    if name not in _NETWORK_CLASSES:
        raise ConfigError(f"network = {name!r} is invalid: must be one of {list(VALUE_NETWORKS)}")
    return _NETWORK_CLASSES[name]()


def command_grid(config: EmoNavConfig) -> np.ndarray:
    """The commands SARL chooses from (A, 2): the DWA candidates of `config`."""
    from emonav_drake.planners.dwa import DwaPlanner

    return DwaPlanner(config).candidates.copy()


def action_values(
    model: nn.Module,
    obs: PlannerInput,
    commands: np.ndarray,
    config: EmoNavConfig,
    gamma: float,
    goal_radius: float,
    device: torch.device | str = "cpu",
) -> np.ndarray:
    """R(s, a) + γ^(T·v_pref)·V(s'_a) of every command (A,) (terminal: R alone)."""
    rows, rewards, done = lookahead(
        obs.robot,
        obs.goal_xy,
        obs.goal_state()[0],
        obs.crowd,
        commands,
        config,
        goal_radius,
    )
    with torch.no_grad():
        x = torch.from_numpy(rows).to(device)
        v = model(x, torch.ones(x.shape[:2], dtype=torch.bool, device=device)).cpu().numpy()
    return rewards + step_discount(gamma, config) * np.where(done, 0.0, v)


class SarlPlanner:
    """SARL as a planner (module docstring); memoryless; reads the privileged crowd.

    Args:
        path: a SARL checkpoint (`save_sarl`).
        config: the robot (LIP constants, radius, bounds), the reward and `episode.
            eval_goal_radius` (the look-ahead's goal radius).
        device: torch device of the value network.
    """

    name = "sarl"

    def __init__(self, path: str | Path, config: EmoNavConfig, device: str = "cpu") -> None:
        from emonav_drake.torch_device import resolve_device

        self.path = Path(path)
        self.config = config
        self.device = resolve_device(device)
        self.model, self.meta = load_sarl(self.path, self.device)
        self.commands = np.asarray(self.meta["commands"], float)
        self.gamma = float(self.meta["gamma"])
        self.goal_radius = config.episode.eval_goal_radius

    def describe(self) -> str:
        prov = self.meta.get("provenance") or {}
        at = f" (episode {prov['episode']})" if "episode" in prov else ""
        kind = self.meta.get("network", "sarl").upper()
        return f"{kind} value network{at}, one-step look-ahead on the LIP ({self.path})"

    def initial_memory(self) -> None:
        return None

    def reset(self) -> None:
        """Memoryless."""

    def plan_with_memory(self, obs: PlannerInput, memory: None) -> tuple[np.ndarray, None]:
        return self.plan(obs), None

    def plan(self, obs: PlannerInput) -> np.ndarray:
        """The command (u_v [m/s], u_Δθ [rad]) of the best look-ahead value."""
        q = action_values(
            self.model, obs, self.commands, self.config, self.gamma, self.goal_radius, self.device
        )
        return self.commands[int(np.argmax(q))].copy()


def save_sarl(
    path: str | Path,
    model: nn.Module,
    commands: np.ndarray,
    gamma: float,
    provenance: dict,
    network: str = "sarl",
) -> None:
    """Write a SARL checkpoint (value network `network`: "sarl" or "rgl") atomically."""
    from emonav_drake.atomic_io import atomic_write

    blob = {
        "format": SARL_FORMAT,
        "network": network,
        "gamma": float(gamma),
        "commands": np.asarray(commands, float).tolist(),
        "state_dict": {k: v.detach().cpu() for k, v in model.state_dict().items()},
        "provenance": provenance,
    }
    atomic_write(path, lambda f: torch.save(blob, f))


def load_sarl(path: str | Path, device: torch.device | str = "cpu") -> tuple[nn.Module, dict]:
    """The value network (SARL's or RGL's, as the checkpoint's "network" says) and the
    checkpoint's metadata; `ConfigError` naming the file if it is missing, damaged or not a
    SARL checkpoint."""
    path = Path(path)
    if not path.is_file():
        raise ConfigError(f"SARL checkpoint {path} does not exist")
    try:
        blob: Any = load_checked(path)
    except CheckpointReadError as e:
        raise ConfigError(f"SARL checkpoint {path}: {e}") from None
    if not isinstance(blob, dict) or blob.get("format") != SARL_FORMAT:
        found = blob.get("format") if isinstance(blob, dict) else type(blob).__name__
        raise ConfigError(f"{path} is not a SARL checkpoint (format {found!r})")
    try:
        model = value_network(blob.get("network", "sarl"))
    except ConfigError as e:
        raise ConfigError(f"{path}: {e}") from None
    model.load_state_dict(blob["state_dict"])
    model.to(device).eval()
    return model, {k: v for k, v in blob.items() if k != "state_dict"}
