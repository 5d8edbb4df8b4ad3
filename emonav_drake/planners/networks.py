"""The networks of the paper (§III-D, §IV-A) and of the CPU training route.

* `LgmEncoder`: f_ϑ of Eq. 5a. 4 conv layers of 32 filters 3 × 3, strides 2-1-1-1,
  ReLU; 100 → 49 → 47 → 45 → 43; FC(32·43·43 = 59 168 → 50) → LayerNorm → tanh. Input:
  the uint8 grid-map stack (B, N, M, M), scaled by 1/255 inside. With `pool = 2` the
  stack is max-pooled 2 × 2 first (the CPU route's reduced resolution: 50 → 24 → 22 →
  20 → 18); max-pooling keeps every marked cell (255 wins over 127).
* `LgmTracksEncoder`: `LgmEncoder` on the maps of the "lgm_tracks" observation and an
  MLP on its table of the nearest pedestrians (ours: the tracks as a second input).
* `ScanEncoder`: the LiDAR-SAC baseline's encoder over stacked raw scans (B, N, K):
  1-D convs with the same filter counts and strides, then FC → 50 → LayerNorm → tanh.
* `Actor`: f_ψ, an MLP (two hidden layers of 1024) over [features, goal state, last
  command] → mean and log-std of a tanh-squashed Gaussian; log-std ∈ [−10, 2].
* `Critic`: twin Q MLPs f_φ over [features, goal state, last command, action].
* `CategoricalHead`: the CPU route's student head — logits over a fixed grid of commands
  (the expert's candidate set), so imitation keeps multimodal choices (swerve left *or*
  right) instead of averaging them into "straight ahead".

Vector state normalisation (the authors'): [d_goal/10, φ_goal/π, v_last/ū_v, Δθ_last/ū_Δθ].
"""

from __future__ import annotations

import math

import torch
from torch import nn
from torch.nn import functional as F

from emonav_drake.params import NUM_BEAMS
from emonav_drake.sensing.kinematic_maps import TRACK_FIELDS

LOG_STD_MIN, LOG_STD_MAX = -10.0, 2.0


def conv_out(size: int, kernel: int = 3, stride: int = 1) -> int:
    """Spatial size after a valid convolution."""
    return (size - kernel) // stride + 1


class _ConvEncoder(nn.Module):
    """Conv stack → FC → LayerNorm → tanh; subclasses build `convs`, `fc`, `norm` and
    define `conv_features` (the flattened conv output)."""

    convs: nn.ModuleList
    features: int

    def conv_features(self, obs: torch.Tensor) -> torch.Tensor:
        raise NotImplementedError

    def head(self, conv: torch.Tensor) -> torch.Tensor:
        """FC → LayerNorm → tanh on conv features (B, flat) → (B, features)."""
        return torch.tanh(self.norm(self.fc(conv)))

    def forward(self, obs: torch.Tensor) -> torch.Tensor:
        return self.head(self.conv_features(obs))

    def copy_conv_weights_from(self, other: _ConvEncoder) -> None:
        """Tie the conv layers to `other`'s (the actor shares the critic's convs)."""
        for mine, theirs in zip(self.convs, other.convs, strict=True):
            mine.weight = theirs.weight
            mine.bias = theirs.bias


class LgmEncoder(_ConvEncoder):
    """CNN encoder over the grid-map stack (paper Eq. 5a).

    Args:
        frames: N, stacked frames (input channels).
        size: M, grid size (input height = width).
        features: output features (50 in the paper).
        filters: conv filters per layer (32).
        pool: max-pool factor applied to the input first (1 = paper, 2 = CPU route).
    """

    def __init__(
        self, frames: int = 9, size: int = 100, features: int = 50, filters: int = 32, pool: int = 1
    ) -> None:
        super().__init__()
        self.pool = pool
        self.convs = nn.ModuleList(
            [
                nn.Conv2d(frames, filters, 3, stride=2),
                nn.Conv2d(filters, filters, 3, stride=1),
                nn.Conv2d(filters, filters, 3, stride=1),
                nn.Conv2d(filters, filters, 3, stride=1),
            ]
        )
        s = size // pool
        self.sizes = [s]
        for i in range(4):
            s = conv_out(s, 3, 2 if i == 0 else 1)
            self.sizes.append(s)
        self.flat = filters * s * s
        self.fc = nn.Linear(self.flat, features)
        self.norm = nn.LayerNorm(features)
        self.features = features
        self.channels_last = False

    def use_channels_last(self) -> None:
        """Run the convs in NHWC memory format (often faster on CPU with oneDNN)."""
        self.channels_last = True
        self.convs.to(memory_format=torch.channels_last)

    def conv_features(self, obs: torch.Tensor) -> torch.Tensor:
        """The flattened conv output (B, flat) of a uint8 or float stack.

        A (B, N, C, M, M) stack of multi-channel frames (DRL-VO*) is read as N·C planes.
        """
        if obs.dim() == 5:
            obs = obs.flatten(1, 2)
        x = obs.float() / 255.0
        if self.pool > 1:
            x = F.max_pool2d(x, self.pool)
        if self.channels_last:
            x = x.contiguous(memory_format=torch.channels_last)
        for conv in self.convs:
            x = F.relu(conv(x))
        return x.flatten(1)


class LgmTracksEncoder(LgmEncoder):
    """The LGM CNN on a stack's grid maps, and beside it an MLP on the pedestrians' table
    (the "lgm_tracks" observation: N LGM planes, then a plane whose first row holds
    `tracks` entries of TRACK_FIELDS bytes, `sensing/kinematic_maps.py::track_table_plane`).

    Args:
        frames: input planes, N + 1 (the convolutions read the first N).
        size, features, filters, pool: the LGM CNN's (`LgmEncoder`); `features` map
            features.
        tracks: table entries read.
        track_features: the table's features (two layers, tanh); the encoder's output is
            `features` + `track_features`.
    """

    def __init__(
        self,
        frames: int = 10,
        size: int = 100,
        features: int = 50,
        filters: int = 32,
        pool: int = 1,
        tracks: int = 8,
        track_features: int = 32,
    ) -> None:
        super().__init__(frames - 1, size, features, filters, pool)
        self.tracks = tracks
        self.table = nn.Sequential(
            nn.Linear(TRACK_FIELDS * tracks, track_features),
            nn.ReLU(),
            nn.Linear(track_features, track_features),
            nn.Tanh(),
        )
        self.features = features + track_features

    def conv_features(self, obs: torch.Tensor) -> torch.Tensor:
        """(B, flat + 5·tracks): the flattened conv output of the maps, then the table
        decoded to [−1, 1] ((byte − 128) / 127)."""
        conv = super().conv_features(obs[:, :-1])
        row = obs[:, -1, 0, : TRACK_FIELDS * self.tracks].float()
        return torch.cat([conv, (row - 128.0) / 127.0], dim=1)

    def head(self, conv: torch.Tensor) -> torch.Tensor:
        maps, table = conv[:, : self.flat], conv[:, self.flat :]
        return torch.cat([torch.tanh(self.norm(self.fc(maps))), self.table(table)], dim=1)


class ScanEncoder(_ConvEncoder):
    """1-D CNN over stacked LiDAR scans (B, N, K) for the LiDAR-SAC baseline.

    Args:
        frames: N scans in the stack.
        beams: K beams per scan.
        max_range: ranges are divided by this (inputs in [0, 1]).
        features, filters: as `LgmEncoder`.
    """

    def __init__(
        self,
        frames: int = 9,
        beams: int = NUM_BEAMS,
        max_range: float = 6.0,
        features: int = 50,
        filters: int = 32,
    ) -> None:
        super().__init__()
        self.max_range = max_range
        self.convs = nn.ModuleList(
            [
                nn.Conv1d(frames, filters, 5, stride=4),
                nn.Conv1d(filters, filters, 3, stride=2),
                nn.Conv1d(filters, filters, 3, stride=2),
                nn.Conv1d(filters, filters, 3, stride=1),
            ]
        )
        s = conv_out(beams, 5, 4)
        s = conv_out(conv_out(conv_out(s, 3, 2), 3, 2), 3, 1)
        self.flat = filters * s
        self.fc = nn.Linear(self.flat, features)
        self.norm = nn.LayerNorm(features)
        self.features = features

    def conv_features(self, obs: torch.Tensor) -> torch.Tensor:
        x = obs.float() / self.max_range
        for conv in self.convs:
            x = F.relu(conv(x))
        return x.flatten(1)


class ScanLstmEncoder(_ConvEncoder):
    """LNDNL's encoder: an LSTM over the normalised scans of the stack (B, N, K).

    Each scan is min-pooled over `pool` neighbouring beams (the nearest return wins),
    divided by the range limit, embedded by a linear layer, and the N embeddings run
    through an LSTM; its last hidden state goes through FC → 50 → LayerNorm → tanh. The
    embedding and the LSTM play the role of the conv layers (shared with the actor).
    """

    def __init__(
        self,
        frames: int = 9,
        beams: int = NUM_BEAMS,
        max_range: float = 6.0,
        features: int = 50,
        hidden: int = 64,
        pool: int = 10,
    ) -> None:
        super().__init__()
        self.max_range, self.pool = max_range, pool
        self.embed = nn.Linear(beams // pool, 128)
        self.lstm = nn.LSTM(128, hidden, batch_first=True)
        self.convs = nn.ModuleList([self.embed, self.lstm])
        self.flat = hidden
        self.fc = nn.Linear(hidden, features)
        self.norm = nn.LayerNorm(features)
        self.features = features

    def conv_features(self, obs: torch.Tensor) -> torch.Tensor:
        x = obs.float() / self.max_range  # (B, N, K)
        x = -F.max_pool1d(-x, self.pool)  # min-pool over beams
        _, (h, _) = self.lstm(F.relu(self.embed(x)))
        return h[-1]

    def copy_conv_weights_from(self, other: _ConvEncoder) -> None:
        """Share the embedding and LSTM modules with `other`."""
        self.embed, self.lstm = other.embed, other.lstm
        self.convs = nn.ModuleList([self.embed, self.lstm])


def mlp(inputs: int, hidden: int, outputs: int, layers: int = 2) -> nn.Sequential:
    """`layers` hidden layers of `hidden` units with ReLU."""
    mods: list[nn.Module] = []
    size = inputs
    for _ in range(layers):
        mods += [nn.Linear(size, hidden), nn.ReLU()]
        size = hidden
    mods.append(nn.Linear(size, outputs))
    return nn.Sequential(*mods)


VECTOR_STATE = 4  # goal distance, goal bearing, last speed, last heading change


class Actor(nn.Module):
    """Tanh-squashed Gaussian policy over (features, vector state) (paper Eq. 5c).

    Actions are returned in [−1, 1]²; `scale_action` maps them to the command bounds.
    """

    def __init__(self, encoder: nn.Module, hidden: int = 1024, action_dim: int = 2) -> None:
        super().__init__()
        self.encoder = encoder
        self.trunk = mlp(encoder.features + VECTOR_STATE, hidden, 2 * action_dim)

    def forward(
        self, obs: torch.Tensor, state: torch.Tensor, detach_encoder: bool = False
    ) -> tuple[torch.Tensor, torch.Tensor]:
        """Mean and log-std (each (B, 2)).

        `detach_encoder`: the conv features are detached, so the actor loss trains the
        actor's own FC/LayerNorm and MLP but never the conv layers it shares with the critic.
        """
        conv = self.encoder.conv_features(obs)
        return self.from_conv(conv.detach() if detach_encoder else conv, state)

    def from_conv(
        self, conv: torch.Tensor, state: torch.Tensor
    ) -> tuple[torch.Tensor, torch.Tensor]:
        """Mean and log-std from precomputed conv features (B, flat)."""
        mu, log_std = self.trunk(torch.cat([self.encoder.head(conv), state], dim=1)).chunk(2, 1)
        # Smoothly bound log-std to [LOG_STD_MIN, LOG_STD_MAX] (SAC-AE style).
        log_std = torch.tanh(log_std)
        log_std = LOG_STD_MIN + 0.5 * (LOG_STD_MAX - LOG_STD_MIN) * (log_std + 1)
        return mu, log_std

    def sample(
        self, obs: torch.Tensor, state: torch.Tensor, detach_encoder: bool = False
    ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        """A reparameterised sample, its log-probability (B, 1) and the squashed mean."""
        return self._squashed_sample(*self(obs, state, detach_encoder))

    def sample_from_conv(
        self, conv: torch.Tensor, state: torch.Tensor
    ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        """`sample` from precomputed conv features."""
        return self._squashed_sample(*self.from_conv(conv, state))

    @staticmethod
    def _squashed_sample(
        mu: torch.Tensor, log_std: torch.Tensor
    ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        std = log_std.exp()
        noise = torch.randn_like(mu)
        pre = mu + noise * std
        action = torch.tanh(pre)
        log_prob = (-0.5 * noise.pow(2) - log_std - 0.5 * math.log(2 * math.pi)).sum(1, True)
        log_prob = log_prob - torch.log(F.relu(1 - action.pow(2)) + 1e-6).sum(1, True)
        return action, log_prob, torch.tanh(mu)


class Critic(nn.Module):
    """Twin Q networks sharing one encoder (paper Eq. 5b); the encoder learns here."""

    def __init__(self, encoder: nn.Module, hidden: int = 1024, action_dim: int = 2) -> None:
        super().__init__()
        self.encoder = encoder
        size = encoder.features + VECTOR_STATE + action_dim
        self.q1 = mlp(size, hidden, 1)
        self.q2 = mlp(size, hidden, 1)

    def forward(
        self,
        obs: torch.Tensor,
        state: torch.Tensor,
        action: torch.Tensor,
        detach_encoder: bool = False,
    ) -> tuple[torch.Tensor, torch.Tensor]:
        conv = self.encoder.conv_features(obs)
        return self.from_conv(conv.detach() if detach_encoder else conv, state, action)

    def from_conv(
        self, conv: torch.Tensor, state: torch.Tensor, action: torch.Tensor
    ) -> tuple[torch.Tensor, torch.Tensor]:
        """Both Q values from precomputed conv features (B, flat)."""
        x = torch.cat([self.encoder.head(conv), state, action], dim=1)
        return self.q1(x), self.q2(x)


class CategoricalPolicy(nn.Module):
    """Encoder + MLP → logits over a fixed grid of commands (the CPU route's student).

    Args:
        encoder: `LgmEncoder` (or `ScanEncoder`).
        num_commands: size of the command grid.
        hidden: MLP width.
    """

    def __init__(
        self, encoder: nn.Module, num_commands: int, hidden: int = 256, state_features: int = 64
    ) -> None:
        super().__init__()
        self.encoder = encoder
        # The 4-D vector state gets its own embedding so that goal-seeking is not drowned
        # by the 50 map features (a plain concatenation learned to ignore the goal).
        self.state_embed = nn.Sequential(nn.Linear(VECTOR_STATE, state_features), nn.ReLU())
        self.trunk = mlp(encoder.features + state_features, hidden, num_commands)

    def forward(self, obs: torch.Tensor, state: torch.Tensor) -> torch.Tensor:
        return self.trunk(torch.cat([self.encoder(obs), self.state_embed(state)], dim=1))
