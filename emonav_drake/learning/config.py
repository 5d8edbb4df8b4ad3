"""Training configurations: every hyper-parameter of a run in one typed object.

Loadable from YAML with `emonav_drake.params.load_typed_yaml` (no `from __future__
import annotations` here: Drake's typed loader needs real types).
"""

import dataclasses as dc


@dc.dataclass
class DaggerConfig:
    """Every setting of the CPU route."""

    seed: int = 0
    expert_episodes: int = 400
    rounds: int = 6  # DAgger rounds after the expert round
    episodes_per_round: int = 150
    beta: float = 0.5  # expert-acting probability in round 1, halved every round
    grad_steps_first: int = 3000
    grad_steps_per_round: int = 2000
    batch_size: int = 64
    lr: float = 1e-3
    weight_decay: float = 1e-5
    hidden: int = 256
    pool: int = 2  # max-pool factor before the encoder (1 = paper resolution)
    eval_episodes: int = 60
    train_seed_offset: int = 1_000_000  # training scenarios: seeds offset + i
    eval_seed_offset: int = 500_000  # held-out seeds for the per-round evaluation
    goal_radius: float = 0.2
    grid_kind: str = "lgm"
    mirror_augment: bool = True  # mirror half of every batch left-right (LGM only)
    heading_noise_prob: float = 0.5  # fraction of training episodes starting off course
    heading_noise: float = 1.5  # their initial heading error, uniform in ± this [rad]
    device: str = "cpu"
    threads: int = 1  # batch-1 acting is fastest on one thread


@dc.dataclass
class SacConfig:
    """SAC with the shared LGM encoder; defaults are the paper's / authors' (docs/learning.md)."""

    seed: int = 0
    device: str = "cpu"
    threads: int = 2
    total_steps: int = 6_000_000
    random_steps: int = 10_000  # uniform random actions first
    replay_size: int = 200_000
    batch_size: int = 128
    hidden: int = 1024
    features: int = 50
    filters: int = 32
    pool: int = 1  # 1 = paper resolution; 2 = the 2 x 2 max-pooled CPU scale
    lr: float = 1e-3  # actor, critic and encoder
    beta1: float = 0.9
    alpha_lr: float = 1e-4
    alpha_beta1: float = 0.5
    init_alpha: float = 0.1
    discount: float = 0.99
    critic_tau: float = 0.01
    encoder_tau: float = 0.05
    actor_update_freq: int = 2
    target_update_freq: int = 2
    updates_per_step: int = 1
    eval_every: int = 20_000
    eval_episodes: int = 100
    eval_seed_offset: int = 10_000_000
    checkpoint_every: int = 10_000
    # Observation variant: "lgm" (paper), "ogm" (OGM baseline), "scan" (LiDAR-SAC; with
    # encoder "lstm": LNDNL), "drlvo" (DRL-VO*); num_frames 1 = Single-LGM.
    grid_kind: str = "lgm"
    num_frames: int = 9
    grid_size: int = 100
    encoder: str = "cnn"  # "lstm" with grid_kind "scan" = LNDNL (LSTM over normalised scans)
    goal_radius: float = 0.1
    reuse_features: bool = True  # the actor step reuses the critic pass's conv features
    channels_last: bool = False  # NHWC memory format for the conv stacks
