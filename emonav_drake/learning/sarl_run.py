"""One SARL training run in memory: the value network and its target, the replay memory,
the optimisers, the run's generator and where it stands (`learning/sarl_train.py` drives
it through imitation, value learning and selection, and saves and restores it).

`SarlRun.act` is the ε-greedy one-step look-ahead of CrowdNav's SARL on the LIP
(`planners/sarl.py`: `action_values`); `episode` walks one scenario and returns its joint
states, rewards and outcome; `train_batches` regresses the network on replayed states.
Joint states are rows of `planning/sarl_state.py`'s features, padded to the arena's most
agents (`ReplayMemory`).
"""

from __future__ import annotations

import copy
import dataclasses as dc
from pathlib import Path

import numpy as np
import torch

from emonav_drake.learning.config import SarlConfig
from emonav_drake.learning.run_state import rng_state, set_rng_state, write_run_state
from emonav_drake.navigation.lip_world import NavigationWorld
from emonav_drake.navigation.metrics import summarize
from emonav_drake.params import EmoNavConfig
from emonav_drake.planners.sarl import action_values, command_grid, value_network
from emonav_drake.planning.sarl_state import NUM_FEATURES, current_rows, step_discount
from emonav_drake.scenarios.scenario import sample_scenario
from emonav_drake.typed_yaml import to_plain

STATE_FILE = "sarl_state.pt"  # in the run directory: what `--resume` reads
SARL_STATE_FORMAT = "emonav-sarl-state/1"


class ReplayMemory:
    """Joint states padded to `max_agents` rows, their masks and value targets (a ring)."""

    def __init__(self, capacity: int, max_agents: int, features: int) -> None:
        self.rows = np.zeros((capacity, max_agents, features), np.float32)
        self.mask = np.zeros((capacity, max_agents), bool)
        self.target = np.zeros(capacity, np.float32)
        self.size = 0
        self.position = 0

    def push(self, rows: np.ndarray, target: float) -> None:
        h = len(rows)
        if h > self.rows.shape[1]:
            raise ValueError(f"{h} agents in a state, the memory holds {self.rows.shape[1]}")
        i = self.position
        self.rows[i] = 0.0
        self.rows[i, :h] = rows
        self.mask[i] = False
        self.mask[i, :h] = True
        self.target[i] = target
        self.position = (i + 1) % len(self.target)
        self.size = min(self.size + 1, len(self.target))

    def batch(self, idx: np.ndarray, device) -> tuple[torch.Tensor, ...]:
        return (
            torch.from_numpy(self.rows[idx]).to(device),
            torch.from_numpy(self.mask[idx]).to(device),
            torch.from_numpy(self.target[idx]).to(device),
        )

    def state(self) -> dict:
        n = self.size
        return {
            "rows": self.rows[:n].copy(),
            "mask": self.mask[:n].copy(),
            "target": self.target[:n].copy(),
            "position": self.position,
        }

    def restore(self, d: dict) -> None:
        n = len(d["target"])
        self.rows[:n], self.mask[:n], self.target[:n] = d["rows"], d["mask"], d["target"]
        self.size, self.position = n, int(d["position"])


@dc.dataclass
class Progress:
    """Where the run is: phase "il_collect" → "il_train" → "rl" → "done"."""

    phase: str = "il_collect"
    il_episode: int = 0
    il_epoch: int = 0
    rl_episode: int = 0
    evaluated_at: int = -1  # the RL episode count of the last selection (-1: none yet)
    best: list | None = None  # the selection key of policy.pt
    history: list = dc.field(default_factory=list)
    il_s: float = 0.0
    rl_s: float = 0.0
    eval_s: float = 0.0


class SarlRun:
    """One training run's state: networks, optimiser, memory, random state, progress."""

    def __init__(self, cfg: SarlConfig, env_cfg: EmoNavConfig) -> None:
        self.cfg, self.env_cfg = cfg, env_cfg
        self.device = torch.device(cfg.device)
        torch.manual_seed(cfg.seed)
        self.rng = np.random.default_rng(cfg.seed)
        self.model = value_network(cfg.network).to(self.device)
        self.target = copy.deepcopy(self.model)
        self.optim = torch.optim.SGD(self.model.parameters(), lr=cfg.il_lr, momentum=0.9)
        self.commands = command_grid(env_cfg)
        c = env_cfg.crowd
        self.memory = ReplayMemory(
            cfg.capacity, max(1, c.max_pedestrians + c.max_static), NUM_FEATURES
        )
        self.prog = Progress()
        self.gamma_bar = step_discount(cfg.gamma, env_cfg)

    # ------------------------------------------------------------------ state file
    def save(self, out: Path) -> None:
        plain, tensors = rng_state(self.rng)
        state = {
            "config": to_plain(self.cfg),
            "env_config": dc.asdict(self.env_cfg),
            "progress": dc.asdict(self.prog),
            "memory": self.memory.state(),
            "rng": plain,
        }
        tensors |= {
            "model": self.model.state_dict(),
            "target": self.target.state_dict(),
            "optim": self.optim.state_dict(),
        }
        write_run_state(out / STATE_FILE, SARL_STATE_FORMAT, state, tensors)

    def restore(self, state: dict, tensors: dict) -> None:
        self.prog = Progress(**state["progress"])
        self.memory.restore(state["memory"])
        self.model.load_state_dict(tensors["model"])
        self.target.load_state_dict(tensors["target"])
        if self.prog.phase == "rl":
            self._rl_optimiser()
        self.optim.load_state_dict(tensors["optim"])
        set_rng_state(self.rng, state["rng"], tensors)

    def _rl_optimiser(self) -> None:
        self.optim = torch.optim.SGD(self.model.parameters(), lr=self.cfg.rl_lr, momentum=0.9)

    # ------------------------------------------------------------------ episodes
    def world(self, seed: int) -> NavigationWorld:
        sc = sample_scenario(seed, self.env_cfg)
        return NavigationWorld(sc, self.env_cfg, goal_radius=self.cfg.goal_radius)

    def act(self, world: NavigationWorld, epsilon: float) -> np.ndarray:
        """ε-greedy on the look-ahead values (greedy with ε = 0: no random draw)."""
        if epsilon > 0 and self.rng.random() < epsilon:
            return self.commands[int(self.rng.integers(len(self.commands)))].copy()
        q = action_values(
            self.model,
            world.planner_input(),
            self.commands,
            self.env_cfg,
            self.cfg.gamma,
            self.cfg.goal_radius,
            self.device,
        )
        return self.commands[int(np.argmax(q))].copy()

    def rows_now(self, world: NavigationWorld) -> np.ndarray:
        """The joint state of `world` now (H, NUM_FEATURES)."""
        obs = world.planner_input()
        return current_rows(obs.robot, obs.goal_xy, obs.crowd, self.env_cfg)

    def episode(self, world: NavigationWorld, choose) -> tuple[list, list, str, bool]:
        """Run one episode with `choose(world)`: joint states, rewards, outcome, and
        whether the last step ended it by collision or goal (terminal)."""
        states, rewards = [], []
        while True:
            states.append(self.rows_now(world))
            ev, outcome = world.step(choose(world))
            rewards.append(ev.reward)
            if outcome is not None:
                return states, rewards, outcome, bool(ev.collision or ev.reached_goal)

    def train_batches(self, n: int) -> float:
        if self.memory.size == 0 or n == 0:
            return float("nan")
        total = 0.0
        self.model.train()
        for _ in range(n):
            idx = self.rng.integers(self.memory.size, size=self.cfg.batch_size)
            rows, mask, target = self.memory.batch(idx, self.device)
            loss = torch.nn.functional.mse_loss(self.model(rows, mask), target)
            self.optim.zero_grad()
            loss.backward()
            self.optim.step()
            total += loss.item()
        self.model.eval()
        return total / n

    def value(self, rows: np.ndarray) -> float:
        with torch.no_grad():
            x = torch.from_numpy(rows[None]).to(self.device)
            m = torch.ones(x.shape[:2], dtype=torch.bool, device=self.device)
            return float(self.target(x, m)[0])

    def epsilon(self) -> float:
        c = self.cfg
        frac = min(1.0, self.prog.rl_episode / c.epsilon_decay)
        return c.epsilon_start + frac * (c.epsilon_end - c.epsilon_start)

    def evaluate(self) -> dict:
        records = []
        for i in range(self.cfg.eval_episodes):
            w = self.world(self.cfg.eval_seed_offset + i)
            self.episode(w, lambda world: self.act(world, 0.0))
            records.append(w.record)
        return summarize(records)
