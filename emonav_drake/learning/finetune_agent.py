"""The learner of the fine-tuning stage (`learning/finetune.py`): discrete soft actor-critic
(Christodoulou 2019) on the head of a categorical student, its encoder frozen.

* **Input.** A trained `planners.networks.CategoricalPolicy` (a DAgger route's
  `policy.pt`, kind "categorical"): its `encoder` maps the observation stack (LGM: uint8
  (N, M, M), oldest frame first) to F = 50 features and is frozen — acting computes the
  features once per walking step and the replay buffer stores them, never the maps. Its
  `state_embed` + `trunk` (vector state [d/10, φ/π, v_last/ū_v, Δθ_last/ū_Δθ] → logits over
  the student's command grid (u_v [m/s], u_Δθ [rad]), |A| = 99) is the actor, initialised
  from the checkpoint and trained.
* **Critics.** Twin MLPs Q(f, s) → |A| values, each with its own state embedding, and
  Polyak-averaged targets (rate τ, every update).
* **Losses** (per batch; π = softmax(logits), min over the twin critics):
  critic: Huber or MSE of Q(s, a) to r + γ (1 − d) Σ_a' π(a'|s') (min Q̄(s', a') − α log π(a'|s'));
  actor: Σ_a π(a|s) (α log π(a|s) − min Q(s, a)) + `bc_weight` · KL(π_init(·|s) ‖ π(·|s)),
  π_init the frozen initial student, Q the critics' values from their forward pass of the
  same update (before their step); α: fixed, or log α tuned so that the policy's entropy
  tracks `target_entropy` · log |A| (the loss log α · (H(π) − H̄)). One update = one
  critic step, then one actor step and one α step (Adam each).
* **Critic warm-up.** The first `critic_warmup` updates train the critics only; the actor
  and α stay as they are (the critics then estimate the student's own soft values).

Acting: `act` samples softmax(logits / temperature) with the run's numpy generator
(collection) or takes the argmax (evaluation; the same logits, bit for bit, as
`PolicyPlanner` computes from the whole network, so the selection evaluates the saved file).
`load_init` reads and checks the initial policy.
"""

from __future__ import annotations

import copy
import math
from pathlib import Path

import numpy as np
import torch
from torch import nn
from torch.nn import functional as F

from emonav_drake.learning.sac_config import FinetuneConfig
from emonav_drake.navigation.observations import observation_kind, observation_shape
from emonav_drake.params import ConfigError, EmoNavConfig
from emonav_drake.planners.networks import VECTOR_STATE, CategoricalPolicy, mlp
from emonav_drake.planners.policy import (
    PolicyError,
    describe_policy,
    load_policy,
    observation_spec,
)
from emonav_drake.planners.variants import resolve_policy_file as resolve_init


def check_observation(meta: dict, env_cfg: EmoNavConfig, where: str) -> None:
    """`ConfigError` unless the world of `env_cfg` gives the observation the policy of
    `meta` reads (its frame count first: `lidar.num_frames` must equal it) and has its
    command bounds."""
    grid_kind, shape, _ = observation_spec(meta)
    kind = observation_kind(grid_kind)
    frames = meta["observation"]["num_frames"]
    if not kind.single_frame and frames != env_cfg.lidar.num_frames:
        raise ConfigError(
            f"{where} reads {frames} frame(s) of {grid_kind}, the environment stacks "
            f"lidar.num_frames = {env_cfg.lidar.num_frames}: they must be equal"
        )
    world = observation_shape(grid_kind, env_cfg.lidar)
    if tuple(world) != tuple(shape):
        raise ConfigError(
            f"{where} reads {grid_kind} observations of shape {tuple(shape)}, the "
            f"environment gives {tuple(world)} (lidar.grid_size, lidar.num_beams)"
        )
    # its vector state is normalised by its bounds (`PolicyPlanner`), training's by the world's
    bounds = [env_cfg.robot.max_speed, env_cfg.robot.max_heading_change]
    if [float(b) for b in meta["bounds"]] != bounds:
        raise ConfigError(
            f"{where} was trained with the command bounds {meta['bounds']}, the environment's "
            f"are {bounds} (robot.max_speed, robot.max_heading_change)"
        )


def load_init(
    spec: str, env_cfg: EmoNavConfig, device: str = "cpu", label: str = "init policy"
) -> tuple[Path, CategoricalPolicy, dict]:
    """The initial policy (`resolve_init`): its file, network and metadata (without
    weights); `ConfigError` starting with `label` if it is missing or unreadable, not a
    categorical student, or reads another observation than `env_cfg`'s world gives."""
    path = resolve_init(spec, label)
    try:
        model, meta = load_policy(path, device)
    except PolicyError as e:
        raise ConfigError(f"{label}: {e}") from None
    where = f"{label} {path}"
    if meta["kind"] != "categorical" or not isinstance(model, CategoricalPolicy):
        raise ConfigError(
            f"{where} is a {meta['kind']} policy ({describe_policy(meta)}); fine-tuning "
            "needs a categorical student (kind 'categorical': a DAgger route's policy.pt)"
        )
    check_observation(meta, env_cfg, where)
    return path, model, {k: v for k, v in meta.items() if k != "state_dict"}


def head_logits(
    policy: CategoricalPolicy, features: torch.Tensor, state: torch.Tensor
) -> torch.Tensor:
    """The student's logits from its encoder's features (B, F) and vector states (B, 4):
    `policy(obs, state)` without the encoder pass."""
    return policy.trunk(torch.cat([features, policy.state_embed(state)], dim=1))


LOG_PROB_FLOOR = -80.0  # `_probs`


class QNet(nn.Module):
    """Q(f, s) → one value per command: an embedding of the vector state (its own) and an
    MLP with two hidden layers over [features, embedding]."""

    def __init__(self, features: int, actions: int, hidden: int, state_features: int) -> None:
        super().__init__()
        self.state_embed = nn.Sequential(nn.Linear(VECTOR_STATE, state_features), nn.ReLU())
        self.q = mlp(features + state_features, hidden, actions)

    def forward(self, features: torch.Tensor, state: torch.Tensor) -> torch.Tensor:
        return self.q(torch.cat([features, self.state_embed(state)], dim=1))


class TwinQ(nn.Module):
    """The twin critics."""

    def __init__(self, features: int, actions: int, hidden: int, state_features: int) -> None:
        super().__init__()
        self.q1 = QNet(features, actions, hidden, state_features)
        self.q2 = QNet(features, actions, hidden, state_features)

    def forward(
        self, features: torch.Tensor, state: torch.Tensor
    ) -> tuple[torch.Tensor, torch.Tensor]:
        return self.q1(features, state), self.q2(features, state)


class DiscreteSac:
    """Discrete SAC on a student's head (module docstring).

    Args:
        cfg: the stage's settings.
        policy: the student (its weights are the actor's start; fine-tuned in place).
        device: where the networks run.
    """

    def __init__(self, cfg: FinetuneConfig, policy: CategoricalPolicy, device: torch.device):
        self.cfg, self.device = cfg, device
        self.policy = policy.to(device).eval()  # no dropout or batch norm: eval = train
        self.policy.encoder.requires_grad_(False)  # frozen
        self.init_policy = copy.deepcopy(self.policy).requires_grad_(False)  # π_init
        self.features = int(policy.encoder.features)
        self.num_actions = int(policy.trunk[-1].out_features)
        self.critic = TwinQ(self.features, self.num_actions, cfg.hidden, cfg.state_features)
        self.critic = self.critic.to(device)
        self.critic_target = copy.deepcopy(self.critic).requires_grad_(False)
        # optimised only with `alpha_tuning`
        self.log_alpha = torch.tensor(math.log(cfg.init_alpha), device=device, requires_grad=True)
        self.target_entropy = cfg.target_entropy * math.log(self.num_actions)  # [nats]
        head = [*self.policy.state_embed.parameters(), *self.policy.trunk.parameters()]
        self.actor_optim = torch.optim.Adam(head, lr=cfg.actor_lr, fused=True)
        self.critic_optim = torch.optim.Adam(self.critic.parameters(), lr=cfg.critic_lr, fused=True)
        self.alpha_optim = torch.optim.Adam([self.log_alpha], lr=cfg.alpha_lr, fused=True)
        self.updates = 0  # updates made (the critic warm-up counts them)

    @property
    def alpha(self) -> float:
        return float(self.log_alpha.detach().exp())

    @torch.no_grad()
    def encode(self, stack: np.ndarray) -> np.ndarray:
        """The frozen encoder's features (F,) float32 of one observation stack."""
        obs = torch.from_numpy(stack[None]).to(self.device)
        return self.policy.encoder(obs)[0].cpu().numpy()

    @torch.no_grad()
    def act(
        self,
        features: np.ndarray,
        state: np.ndarray,
        rng: np.random.Generator | None = None,
        temperature: float = 1.0,
    ) -> int:
        """A command index: the argmax (`rng` None) or a sample of softmax(logits /
        temperature), drawn with one `rng.random()` by inverting the CDF (float64)."""
        f = torch.from_numpy(features[None]).to(self.device)
        s = torch.from_numpy(state[None]).to(self.device)
        logits = head_logits(self.policy, f, s)[0]
        if rng is None:
            return int(logits.argmax())
        z = logits.cpu().double().numpy() / temperature
        cdf = np.cumsum(np.exp(z - z.max()))
        return min(int(np.searchsorted(cdf, rng.random() * cdf[-1], side="right")), len(z) - 1)

    def update(self, batch: dict[str, torch.Tensor]) -> dict[str, float]:
        """One update on a replay batch (`FrameReplayBuffer.sample` of 1-frame feature
        windows; the action index in `action[:, 0]`); returns the losses and statistics.

        Subnormal floats are flushed to zero during the update (on CPUs that can): the
        gradients of near-zero probabilities are subnormal and made the matrix products of
        the backward pass three times slower. Acting and evaluation are not affected.
        """
        flush = self.device.type == "cpu" and torch.set_flush_denormal(True)
        try:
            return self._update(batch)
        finally:
            if flush:
                torch.set_flush_denormal(False)  # torch's default

    def _update(self, batch: dict[str, torch.Tensor]) -> dict[str, float]:
        cfg = self.cfg
        f, s = batch["obs"][:, 0], batch["state"]
        f2, s2 = batch["next_obs"][:, 0], batch["next_state"]
        a = batch["action"][:, :1].long()
        alpha = self.log_alpha.detach().exp()
        with torch.no_grad():
            logp2 = F.log_softmax(head_logits(self.policy, f2, s2), dim=1)
            q_next = torch.min(*self.critic_target(f2, s2))
            v_next = (_probs(logp2) * (q_next - alpha * logp2)).sum(1, keepdim=True)
            target = batch["reward"] + cfg.discount * batch["not_done"] * v_next
        q1, q2 = self.critic(f, s)
        loss = F.smooth_l1_loss if cfg.critic_loss == "huber" else F.mse_loss
        critic_loss = loss(q1.gather(1, a), target) + loss(q2.gather(1, a), target)
        self.critic_optim.zero_grad(set_to_none=True)
        critic_loss.backward()
        self.critic_optim.step()
        info = {"critic_loss": critic_loss.item()}
        if self.updates >= cfg.critic_warmup:
            # the critics' values of the batch from their forward pass above (before their
            # step): two forward passes fewer per update
            info |= self._actor_step(f, s, torch.min(q1, q2).detach(), alpha)
        else:
            with torch.no_grad():
                logp = F.log_softmax(head_logits(self.policy, f, s), dim=1)
                info["entropy"] = float(-(_probs(logp) * logp).sum(1).mean())
        with torch.no_grad():
            pairs = zip(self.critic.parameters(), self.critic_target.parameters(), strict=True)
            for p, t in pairs:
                t.lerp_(p, cfg.tau)
        self.updates += 1
        return info

    def _actor_step(
        self, f: torch.Tensor, s: torch.Tensor, q: torch.Tensor, alpha: torch.Tensor
    ) -> dict:
        """The actor's (and α's) step on the batch's features and min Q values."""
        cfg = self.cfg
        logp = F.log_softmax(head_logits(self.policy, f, s), dim=1)
        p = _probs(logp)
        actor_loss = (p * (alpha * logp - q)).sum(1).mean()
        loss, info = actor_loss, {"actor_loss": actor_loss.item()}
        if cfg.bc_weight > 0:
            with torch.no_grad():
                logp0 = F.log_softmax(head_logits(self.init_policy, f, s), dim=1)
            kl = (_probs(logp0) * (logp0 - logp)).sum(1).mean()  # KL(π_init ‖ π)
            loss = loss + cfg.bc_weight * kl
            info["kl"] = kl.item()
        self.actor_optim.zero_grad(set_to_none=True)
        loss.backward()
        self.actor_optim.step()
        entropy = float(-(p.detach() * logp.detach()).sum(1).mean())
        if cfg.alpha_tuning:
            alpha_loss = self.log_alpha * (entropy - self.target_entropy)
            self.alpha_optim.zero_grad(set_to_none=True)
            alpha_loss.backward()
            self.alpha_optim.step()
        return info | {"entropy": entropy}

    def state_dict(self) -> dict:
        """Every tensor of the learner (networks, targets, α, optimisers), torch-native."""
        return {
            "policy": self.policy.state_dict(),
            "init_policy": _head(self.init_policy.state_dict()),  # its encoder is the policy's
            "critic": self.critic.state_dict(),
            "critic_target": self.critic_target.state_dict(),
            "log_alpha": self.log_alpha.detach().clone(),
            "actor_optim": self.actor_optim.state_dict(),
            "critic_optim": self.critic_optim.state_dict(),
            "alpha_optim": self.alpha_optim.state_dict(),
        }

    def load_state_dict(self, st: dict, updates: int) -> None:
        """Inverse of `state_dict` (and the update count); `RuntimeError`/`KeyError` if it
        does not fit these networks."""
        self.policy.load_state_dict(st["policy"])
        encoder = {k: v for k, v in st["policy"].items() if k not in _head(st["policy"])}
        self.init_policy.load_state_dict(encoder | st["init_policy"])
        self.critic.load_state_dict(st["critic"])
        self.critic_target.load_state_dict(st["critic_target"])
        with torch.no_grad():
            self.log_alpha.copy_(st["log_alpha"])
        self.actor_optim.load_state_dict(st["actor_optim"])
        self.critic_optim.load_state_dict(st["critic_optim"])
        self.alpha_optim.load_state_dict(st["alpha_optim"])
        self.updates = int(updates)


def _probs(log_probs: torch.Tensor) -> torch.Tensor:
    """exp(log π), with log π below `LOG_PROB_FLOOR` raised to it first: the exponential of
    a float32 below −87 is subnormal and ~40 times slower to compute on a CPU, and a student's
    logits often spread that far. Such a probability (< 2e-35) weighs nothing in any sum."""
    return log_probs.clamp(min=LOG_PROB_FLOOR).exp()


def _head(state_dict: dict) -> dict:
    """The entries of a student's state dict but its (frozen) encoder's."""
    return {k: v for k, v in state_dict.items() if not k.startswith("encoder.")}
