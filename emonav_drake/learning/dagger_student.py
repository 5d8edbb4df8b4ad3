"""The student of the DAgger routes: a network over the variant's observation that picks
a command of the expert's grid, its optimiser, greedy acting, and cross-entropy training
on `Demonstrations` (half of every batch mirrored left-right).

Used by the CPU route (`learning/dagger.py`) and the Digit rounds
(`learning/digit_dagger.py`).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import torch
from torch.nn import functional as F

from emonav_drake.learning.config import DaggerConfig
from emonav_drake.learning.demonstrations import Demonstrations, command_index
from emonav_drake.navigation.observations import mirror_observation, observation_kind
from emonav_drake.params import ConfigError, EmoNavConfig
from emonav_drake.planners.networks import CategoricalPolicy
from emonav_drake.planners.policy import build_encoder, encoder_spec, load_policy
from emonav_drake.progress import progress_bar


class Student:
    """The student: network over the variant's observation, optimiser and greedy action.

    The encoder is the one the SAC trainer uses for the same variant (`encoder_spec`):
    the paper's 2-D CNN on grid maps (max-pooled by `cfg.pool`), a 1-D CNN on scans, an
    LSTM on scans (LNDNL).
    """

    def __init__(self, cfg: DaggerConfig, env_cfg: EmoNavConfig, commands: np.ndarray) -> None:
        li = env_cfg.lidar
        self.grid_kind = cfg.grid_kind
        self.encoder_spec = encoder_spec(
            cfg.grid_kind, cfg.encoder, cfg.num_frames, li.grid_size, pool=cfg.pool
        )
        self.model = CategoricalPolicy(
            build_encoder(self.encoder_spec), len(commands), cfg.hidden
        ).to(cfg.device)
        self.optim = torch.optim.AdamW(
            self.model.parameters(), lr=cfg.lr, weight_decay=cfg.weight_decay
        )
        self.commands = commands
        # Every observation is exactly left-right symmetric (`mirror_observation`):
        # mirrored samples double the data and make the student's choices symmetric.
        self.mirror_augment = cfg.mirror_augment
        self.mirrored = np.array([command_index(commands, c * [1.0, -1.0]) for c in commands])
        self.device = cfg.device
        self.bounds = (env_cfg.robot.max_speed, env_cfg.robot.max_heading_change)

    def load_weights(self, policy: str) -> None:
        """Start from a trained policy ("shipped" = the LIP-trained LGM policy, a shipped
        variant's name, or a path: `planners.variants.resolve_policy_file`); `ConfigError`
        if its network or command grid is not this student's."""
        from emonav_drake.planners.variants import resolve_policy_file

        path = resolve_policy_file(policy, "init_policy")
        model, meta = load_policy(path)
        ob = meta["observation"]
        if meta["kind"] != "categorical" or (ob["grid_kind"], ob["num_frames"]) != (
            self.grid_kind,
            observation_kind(self.grid_kind).frames_of(self.encoder_spec["frames"]),
        ):
            raise ConfigError(
                f"init_policy {path}: a {meta['kind']} policy on {ob['grid_kind']} x "
                f"{ob['num_frames']} is not this configuration's student (categorical, "
                f"{self.grid_kind})"
            )
        if not np.allclose(np.asarray(meta["commands"]), self.commands):
            raise ConfigError(f"init_policy {path}: its command grid is not the expert's")
        try:
            self.model.load_state_dict(model.state_dict())
        except RuntimeError as e:  # another network size (hidden, pool, filters)
            raise ConfigError(
                f"init_policy {path}: its network is not this configuration's: "
                f"{str(e).splitlines()[0]}"
            ) from None

    @torch.no_grad()
    def act(self, stack: np.ndarray, state: np.ndarray) -> int:
        self.model.eval()
        obs = torch.from_numpy(stack[None]).to(self.device)
        logits = self.model(obs, torch.from_numpy(state[None]).to(self.device))
        return int(logits.argmax())

    def loss(
        self,
        frames: np.ndarray,
        windows: np.ndarray,
        states: np.ndarray,
        labels: np.ndarray,
        mirror: np.ndarray | None = None,
        targets: np.ndarray | None = None,
    ) -> torch.Tensor:
        """Cross-entropy on a batch — on the hard `labels`, or on the soft labels `targets`
        (B, C) when given; rows where `mirror` is True are mirrored left↔right."""
        stacks = observation_kind(self.grid_kind).from_items(frames[windows])
        return self.loss_on_stacks(stacks, states, labels, mirror, targets)

    def loss_on_stacks(
        self,
        stacks: np.ndarray,
        states: np.ndarray,
        labels: np.ndarray,
        mirror: np.ndarray | None = None,
        targets: np.ndarray | None = None,
    ) -> torch.Tensor:
        """`loss` on gathered observation stacks (B, …)."""
        if mirror is not None and mirror.any():
            stacks, states, labels = stacks.copy(), states.copy(), labels.copy()
            stacks[mirror] = mirror_observation(stacks[mirror], self.grid_kind)
            states[mirror, 1] *= -1.0  # goal bearing
            states[mirror, 3] *= -1.0  # last heading change
            labels[mirror] = self.mirrored[labels[mirror]]
            if targets is not None:  # the mirror of command i is command mirrored[i]
                targets = targets.copy()
                targets[mirror] = targets[mirror][:, self.mirrored]
        obs = torch.from_numpy(np.ascontiguousarray(stacks)).to(self.device)
        logits = self.model(obs, torch.from_numpy(states).to(self.device))
        if targets is not None:
            t = torch.from_numpy(np.ascontiguousarray(targets)).to(self.device)
            return -(t * F.log_softmax(logits, dim=1)).sum(dim=1).mean()
        return F.cross_entropy(logits, torch.from_numpy(labels).to(self.device))

    def train(
        self, demos: Demonstrations, steps: int, batch: int, rng: np.random.Generator, desc: str
    ) -> float:
        """`steps` minibatch updates on the aggregate; returns the mean loss of the last 100."""
        losses: list[float] = []
        self.train_steps(demos, 0, steps, batch, rng, desc, losses)
        return float(np.mean(losses[-100:]))

    def train_steps(
        self,
        demos: Demonstrations,
        done: int,
        steps: int,
        batch: int,
        rng: np.random.Generator,
        desc: str,
        losses: list[float],
        stop: Callable[[], bool] | None = None,
    ) -> int:
        """Updates `done`..`steps` − 1, appending each loss to `losses`; `stop()` is asked
        after every update and ends the loop early. Returns the updates done in all."""
        windows, states, labels = demos.arrays()
        targets = demos.target_array()
        frames = demos.store.frames
        self.model.train()
        bar = progress_bar(
            range(done, steps), desc=desc, unit="upd", leave=False, initial=done, total=steps
        )
        for _ in bar:
            idx = rng.integers(0, len(labels), batch)
            mirror = rng.random(batch) < 0.5 if self.mirror_augment else None
            soft = targets[idx] if targets is not None else None
            loss = self.loss(frames, windows[idx], states[idx], labels[idx], mirror, soft)
            self.optim.zero_grad(set_to_none=True)
            loss.backward()
            self.optim.step()
            losses.append(loss.item())
            done += 1
            if stop is not None and stop():
                break
        return done
