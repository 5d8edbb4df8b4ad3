"""Soft actor-critic with the shared LGM encoder (paper §III-D), readable top to bottom.

* Critic: twin Q networks on [encoder features, vector state, action]; the encoder is
  trained by the critic loss only.
* Actor: its conv layers are the critic's (tied weights); the actor loss detaches the
  conv features, so no actor gradient reaches the shared encoder (paper: "copied to the
  actor network without gradient computations").
* Targets: a target critic (its own encoder copy) updated by Polyak averaging with
  τ_critic = 0.01 for the Q networks and τ_encoder = 0.05 for the encoder, every
  `target_update_freq` updates; the actor is updated every `actor_update_freq` updates.
* Entropy: automatic temperature tuning towards −|A| with its own optimiser.

Actions inside the agent are in [−1, 1]²; `to_command` maps them to (u_v, u_Δθ).
"""

from __future__ import annotations

import copy
import math

import numpy as np
import torch
from torch.nn import functional as F

from emonav_drake.learning.sac_config import SacConfig
from emonav_drake.navigation.observations import observation_kind
from emonav_drake.params import NUM_BEAMS
from emonav_drake.planners.networks import (
    Actor,
    Critic,
    LgmEncoder,
    ScanEncoder,
    ScanLstmEncoder,
)
from emonav_drake.planners.policy import build_encoder, encoder_spec


def make_encoder(cfg: SacConfig, beams: int = NUM_BEAMS, max_range: float = 6.0) -> torch.nn.Module:
    """The encoder for the configured observation variant."""
    kind = observation_kind(cfg.grid_kind)
    if kind.scans and cfg.encoder == "lstm":  # LNDNL
        return ScanLstmEncoder(cfg.num_frames, beams, max_range, cfg.features)
    if kind.scans:
        return ScanEncoder(cfg.num_frames, beams, max_range, cfg.features, cfg.filters)
    # a 2-D CNN on the stack's planes (DRL-VO*: the image's 3 channels; lgm_tracks: and
    # an MLP on its table)
    spec = encoder_spec(
        cfg.grid_kind,
        cfg.encoder,
        cfg.num_frames,
        cfg.grid_size,
        cfg.features,
        cfg.filters,
        cfg.pool,
    )
    return build_encoder(spec)


class SacAgent:
    """The SAC learner.

    Args:
        cfg: hyper-parameters (one `SacConfig`).
        bounds: (ū_v, ū_Δθ) to map actions in [−1, 1]² to commands.
    """

    def __init__(self, cfg: SacConfig, bounds: tuple[float, float]) -> None:
        self.cfg = cfg
        self.bounds = bounds
        self.device = torch.device(cfg.device)
        self.critic = Critic(make_encoder(cfg), cfg.hidden).to(self.device)
        self.critic_target = copy.deepcopy(self.critic)
        self.actor = Actor(make_encoder(cfg), cfg.hidden).to(self.device)
        if cfg.channels_last and isinstance(self.critic.encoder, LgmEncoder):
            for enc in (self.critic.encoder, self.critic_target.encoder, self.actor.encoder):
                enc.use_channels_last()
        self.actor.encoder.copy_conv_weights_from(self.critic.encoder)  # tied convs
        self.log_alpha = torch.tensor(
            math.log(cfg.init_alpha), device=self.device, requires_grad=True
        )
        self.target_entropy = -2.0
        # The actor optimiser skips the tied conv weights: only the critic trains them.
        conv_ids = {id(p) for p in self.critic.encoder.convs.parameters()}
        actor_params = [p for p in self.actor.parameters() if id(p) not in conv_ids]
        self.actor_optim = torch.optim.Adam(actor_params, lr=cfg.lr, betas=(cfg.beta1, 0.999))
        self.critic_optim = torch.optim.Adam(
            self.critic.parameters(), lr=cfg.lr, betas=(cfg.beta1, 0.999)
        )
        self.alpha_optim = torch.optim.Adam(
            [self.log_alpha], lr=cfg.alpha_lr, betas=(cfg.alpha_beta1, 0.999)
        )
        self.updates = 0

    @property
    def alpha(self) -> torch.Tensor:
        return self.log_alpha.exp()

    def to_command(self, action: np.ndarray) -> np.ndarray:
        """[−1, 1]² → (u_v ∈ [0, ū_v], u_Δθ ∈ [−ū_Δθ, ū_Δθ])."""
        a = np.clip(action, -1.0, 1.0)
        return np.array([(a[0] + 1.0) / 2.0 * self.bounds[0], a[1] * self.bounds[1]])

    @torch.no_grad()
    def act(self, obs: np.ndarray, state: np.ndarray, deterministic: bool) -> np.ndarray:
        """An action in [−1, 1]² for one observation (sampled, or the mean)."""
        o = torch.as_tensor(obs[None], device=self.device)
        s = torch.as_tensor(state[None], device=self.device)
        action, _, mean = self.actor.sample(o, s)
        return (mean if deterministic else action)[0].cpu().numpy()

    def update(self, batch: dict[str, torch.Tensor]) -> dict[str, float]:
        """One SAC update on a batch (obs, state, action, reward, next_obs, next_state,
        not_done); returns the losses."""
        cfg = self.cfg
        obs, state, action = batch["obs"], batch["state"], batch["action"]
        reward, not_done = batch["reward"], batch["not_done"]
        next_obs, next_state = batch["next_obs"], batch["next_state"]

        # Critic: soft Bellman target with the target critic and the current policy.
        # Each conv stack runs once per batch: the online convs on obs (with gradient, for
        # the critic) and on next_obs (for the policy's next action), the target convs on
        # next_obs. With `reuse_features` the actor step reuses the obs features, detached
        # (they predate this update's critic step by one Adam step); without it the actor
        # re-encodes obs with the freshly updated convs, as SAC-AE does.
        conv = self.critic.encoder.conv_features(obs)
        with torch.no_grad():
            next_conv = self.critic.encoder.conv_features(next_obs)  # = the actor's convs
            next_action, next_logp, _ = self.actor.sample_from_conv(next_conv, next_state)
            target_conv = self.critic_target.encoder.conv_features(next_obs)
            tq1, tq2 = self.critic_target.from_conv(target_conv, next_state, next_action)
            target_v = torch.min(tq1, tq2) - self.alpha.detach() * next_logp
            target_q = reward + not_done * cfg.discount * target_v
        q1, q2 = self.critic.from_conv(conv, state, action)
        critic_loss = F.mse_loss(q1, target_q) + F.mse_loss(q2, target_q)
        self.critic_optim.zero_grad(set_to_none=True)
        critic_loss.backward()
        self.critic_optim.step()
        info = {"critic_loss": critic_loss.item()}

        # Actor and temperature, every `actor_update_freq` updates; encoder detached.
        if self.updates % cfg.actor_update_freq == 0:
            if cfg.reuse_features:
                actor_conv = conv.detach()
            else:
                with torch.no_grad():
                    actor_conv = self.critic.encoder.conv_features(obs)
            pi, logp, _ = self.actor.sample_from_conv(actor_conv, state)
            aq1, aq2 = self.critic.from_conv(actor_conv, state, pi)
            actor_loss = (self.alpha.detach() * logp - torch.min(aq1, aq2)).mean()
            self.actor_optim.zero_grad(set_to_none=True)
            actor_loss.backward()
            self.actor_optim.step()
            alpha_loss = (self.alpha * (-logp - self.target_entropy).detach()).mean()
            self.alpha_optim.zero_grad(set_to_none=True)
            alpha_loss.backward()
            self.alpha_optim.step()
            info |= {
                "actor_loss": actor_loss.item(),
                "alpha": self.alpha.item(),
                "entropy": -logp.mean().item(),
            }

        # Targets: separate Polyak rates for the Q heads and the encoder.
        if self.updates % cfg.target_update_freq == 0:
            soft_update(self.critic.q1, self.critic_target.q1, cfg.critic_tau)
            soft_update(self.critic.q2, self.critic_target.q2, cfg.critic_tau)
            soft_update(self.critic.encoder, self.critic_target.encoder, cfg.encoder_tau)
        self.updates += 1
        return info

    def state_dict(self) -> dict:
        """Networks, optimisers, temperature and the update counter: tensors and torch
        optimiser state dicts only, so `torch.load(weights_only=True)` reads it back."""
        return {
            "critic": self.critic.state_dict(),
            "critic_target": self.critic_target.state_dict(),
            "actor": self.actor.state_dict(),
            "log_alpha": self.log_alpha.detach().clone(),
            "actor_optim": self.actor_optim.state_dict(),
            "critic_optim": self.critic_optim.state_dict(),
            "alpha_optim": self.alpha_optim.state_dict(),
            "updates": self.updates,
        }

    def load_state_dict(self, st: dict) -> None:
        """Restore `state_dict()` (the actor's conv weights are re-tied to the critic's)."""
        self.critic.load_state_dict(st["critic"])
        self.critic_target.load_state_dict(st["critic_target"])
        self.actor.load_state_dict(st["actor"])
        self.actor.encoder.copy_conv_weights_from(self.critic.encoder)
        with torch.no_grad():
            self.log_alpha.copy_(st["log_alpha"])
        self.actor_optim.load_state_dict(st["actor_optim"])
        self.critic_optim.load_state_dict(st["critic_optim"])
        self.alpha_optim.load_state_dict(st["alpha_optim"])
        self.updates = st["updates"]


@torch.no_grad()
def soft_update(net: torch.nn.Module, target: torch.nn.Module, tau: float) -> None:
    """target ← τ·net + (1 − τ)·target."""
    for p, tp in zip(net.parameters(), target.parameters(), strict=True):
        tp.lerp_(p, tau)
