"""The soft actor-critic routes' configurations: SAC on the grid maps (`SacConfig`) and the
discrete SAC fine-tuning of a categorical student (`FinetuneConfig`).

Loadable from YAML with `typed_yaml.load_typed_yaml` (no `from __future__ import
annotations` here: Drake's typed loader needs real types); re-exported by
`learning/config.py`. Each field declares its default, doc, unit and allowed range
(`config_fields.setting`); `validate()` checks the ranges (`typed_yaml.validate_fields`)
and the cross-field rules, raising `ConfigError` naming the field.
"""

import dataclasses as dc

from emonav_drake.config_fields import setting
from emonav_drake.diagrams.plants import PLANTS
from emonav_drake.learning.config_common import (
    COUNT,
    COUNT_OR_NONE,
    EVALUATION_SEEDS,
    FRACTION,
    GOAL_RADIUS,
    GRID_SIZE,
    LEARNING_RATE,
    MIN_ENCODER_INPUT,
    NUM_FRAMES,
    POLYAK,
    POOL,
    SEED_OFFSET,
    TEMPERATURE,
    THREADS,
    WIDTH,
    TrainingRunConfig,
    check_choice,
    check_observation,
)
from emonav_drake.params import NUM_BEAMS, SCENARIO_FAMILIES, EpisodeParams
from emonav_drake.typed_yaml import ConfigError, validate_fields

_ADAM_BETA1 = (0.0, 0.999999)


@dc.dataclass
class SacConfig(TrainingRunConfig):
    """SAC with the shared LGM encoder; defaults are the paper's / authors' (docs/learning.md)."""

    threads: int = setting(2, "torch threads", "", THREADS)
    total_steps: int = setting(6_000_000, "environment steps of the run", "", COUNT)
    random_steps: int = setting(10_000, "uniform random actions first", "", COUNT_OR_NONE)
    replay_size: int = setting(200_000, "transitions the replay buffer holds", "", COUNT)
    batch_size: int = setting(128, "transitions per update", "", COUNT)
    hidden: int = setting(1024, "width of the actor's and critics' hidden layers", "", WIDTH)
    features: int = setting(50, "size of the encoder's feature vector", "", WIDTH)
    filters: int = setting(32, "channels of the encoder's conv layers", "", (1, 4096))
    pool: int = setting(1, "1 = paper resolution; 2 = the 2 x 2 max-pooled CPU scale", "", POOL)
    lr: float = setting(1e-3, "learning rate of actor, critic and encoder", "", LEARNING_RATE)
    beta1: float = setting(0.9, "Adam β1 of actor, critic and encoder", "", _ADAM_BETA1)
    alpha_lr: float = setting(1e-4, "learning rate of the entropy temperature α", "", LEARNING_RATE)
    alpha_beta1: float = setting(0.5, "Adam β1 of the temperature α", "", _ADAM_BETA1)
    init_alpha: float = setting(0.1, "the temperature α at the start", "", TEMPERATURE)
    discount: float = setting(0.99, "γ, discount factor", "", FRACTION)
    critic_tau: float = setting(0.01, "Polyak rate of the target critics' heads", "", POLYAK)
    encoder_tau: float = setting(0.05, "Polyak rate of the target critic's encoder", "", POLYAK)
    actor_update_freq: int = setting(
        2, "the actor and α are updated every this many updates", "", COUNT
    )
    target_update_freq: int = setting(
        2, "the target critic is updated every this many updates", "", COUNT
    )
    updates_per_step: int = setting(1, "updates per environment step", "", (1, 1000))
    eval_every: int = setting(20_000, "environment steps between evaluations", "", COUNT)
    eval_episodes: int = setting(100, "episodes of an evaluation", "", COUNT)
    eval_seed_offset: int = setting(
        10_000_000, "evaluation scenarios: seeds offset + i", "", SEED_OFFSET
    )
    checkpoint_every: int = setting(10_000, "environment steps between checkpoints", "", COUNT)
    grid_kind: str = setting(
        "lgm",
        'observation variant: "lgm" (paper), "ogm" (OGM baseline), "scan" (LiDAR-SAC; with '
        'encoder "lstm": LNDNL), "drlvo" (DRL-VO*), "lgm_vel" (the LGM stack + the '
        'pedestrians\' velocities now), "lgm_tracks" (the LGM stack + a table of the nearest '
        "pedestrians); num_frames 1 = Single-LGM",
    )
    num_frames: int = setting(9, "N, frames in the stack", "", NUM_FRAMES)
    grid_size: int = setting(
        100, "M, the grid maps' size (`lidar.grid_size`; divides the 1800 beams)", "", GRID_SIZE
    )
    encoder: str = setting(
        "cnn", '"cnn"; "lstm" with grid_kind "scan" = LNDNL (LSTM over normalised scans)'
    )
    goal_radius: float = setting(
        EpisodeParams.goal_radius, "d_goal of training (`episode.goal_radius`)", "m", GOAL_RADIUS
    )
    plant: str = setting(
        "lip",
        'the robot of the training environment: "lip" (`EmoNavLIP-v0`) or "digit" (the '
        "full-order Digit diagram, `EmoNavDigit-v0`: ~0.2 s of CPU per environment step)",
    )
    num_envs: int = setting(
        1,
        "environments stepped together (on Ray actors when > 1; `learning/env_pool.py`)",
        "",
        (1, 4096),
    )
    reuse_features: bool = setting(True, "the actor step reuses the critic pass's conv features")
    channels_last: bool = setting(False, "NHWC memory format for the conv stacks")

    def validate(self) -> "SacConfig":
        """Raise `ConfigError` naming the field if a value is out of range or inconsistent."""
        validate_fields(self)
        check_observation(self.grid_kind, self.encoder, self.num_frames)
        check_choice("plant", self.plant, tuple(PLANTS))
        self.check_common()
        if self.grid_kind != "scan":
            if NUM_BEAMS % self.grid_size:
                raise ConfigError(
                    f"grid_size = {self.grid_size} is invalid: must divide the LiDAR's "
                    f"{NUM_BEAMS} beams (e.g. 50, 100, 120, 150)"
                )
            if self.grid_size // self.pool < MIN_ENCODER_INPUT:
                raise ConfigError(
                    f"pool = {self.pool} is invalid with grid_size = {self.grid_size}: the "
                    f"encoder needs grid_size // pool >= {MIN_ENCODER_INPUT}"
                )
        return self


@dc.dataclass
class FinetuneConfig(TrainingRunConfig):
    """Discrete soft actor-critic fine-tuning of a categorical student
    (`learning/finetune.py`; docs/learning.md, "Fine-tuning a student by SAC")."""

    threads: int = setting(
        1, "torch threads: batch-1 acting and small MLP updates are fastest on one", "", THREADS
    )
    family: str = setting(
        "paper",
        "the scenario family it trains and selects in, as `DaggerConfig.family` "
        '("paper": the paper\'s arena; e.g. "mixed_buildings")',
    )
    response: str = setting(
        "",
        'the training and selection world, as `DaggerConfig.response`: "" = the paper\'s LIP; '
        '"digit" = the shipped Digit step-response model; or a fitted model JSON',
    )
    goal_radius: float = setting(
        EpisodeParams.eval_goal_radius,
        "episodes end within this goal radius (the DAgger route's, `episode.eval_goal_radius`)",
        "m",
        GOAL_RADIUS,
    )
    total_steps: int = setting(
        100_000, "environment (walking) steps; the episode reaching it ends", "", COUNT
    )
    replay_size: int = setting(
        100_000, "transitions kept (features, not maps: ≈ 270 B each)", "", COUNT
    )
    learning_starts: int = setting(
        5_000, "environment steps collected before the first update", "", COUNT_OR_NONE
    )
    updates_per_step: float = setting(
        1.0,
        "gradient updates per environment step, made after each training episode (every "
        "episode is collected by a fixed actor; Ctrl-C undoes a partial one)",
        "",
        (0.0, 1000.0),
    )
    batch_size: int = setting(128, "transitions per update (as the paper's SAC)", "", COUNT)
    hidden: int = setting(
        256, "the twin critics: two hidden layers of this width (the actor's)", "", WIDTH
    )
    state_features: int = setting(
        64, "the critics' own vector-state embedding (the actor's: 64)", "", WIDTH
    )
    critic_lr: float = setting(3e-4, "learning rate of the critics", "", LEARNING_RATE)
    actor_lr: float = setting(
        1e-4, "learning rate of the actor: the student's head moves slowly", "", (0.0, 1.0)
    )
    alpha_lr: float = setting(3e-4, "learning rate of the temperature α", "", LEARNING_RATE)
    discount: float = setting(0.99, "γ (the paper's `episode.discount`)", "", FRACTION)
    tau: float = setting(0.005, "Polyak rate of the target critics, every update", "", POLYAK)
    critic_loss: str = setting("huber", '"huber" (smooth L1, δ = 1) or "mse" on the soft TD target')
    critic_warmup: int = setting(
        10_000,
        "the first updates train the critics only (actor and α fixed): a random critic must "
        "not wreck a good actor",
        "",
        COUNT_OR_NONE,
    )
    alpha_tuning: bool = setting(True, "tune α to `target_entropy`; False: α = init_alpha, fixed")
    init_alpha: float = setting(0.01, "the temperature α at the start", "", TEMPERATURE)
    target_entropy: float = setting(
        0.15,
        "target entropy as a fraction of log |A| (log 99 = 4.60 nats): 0.15 → 0.69 nats, about "
        "the DAgger students' own mean entropy (0.61 shipped/LIP, 0.76 Digit/Digit in the "
        "calibrated world; greedy on training seeds 2000000-2000009)",
        "",
        FRACTION,
    )
    bc_weight: float = setting(
        0.1,
        "+ bc_weight · KL(π_init ‖ π): keeps the actor near the student where the critic is "
        "unsure (0 = plain SAC)",
        "",
        (0.0, 1e3),
    )
    temperature: float = setting(
        1.0, "acting during collection samples softmax(logits / this)", "", (1e-3, 1e3)
    )
    eval_every: int = setting(10_000, "environment steps between selection evaluations", "", COUNT)
    eval_episodes: int = setting(200, "episodes of a selection evaluation", "", COUNT)
    eval_seed_offset: int = setting(
        600_000, "selection seeds offset + i (the DAgger routes')", "", SEED_OFFSET
    )
    train_seed_offset: int = setting(
        2_000_000, "training scenarios: seeds offset + i", "", SEED_OFFSET
    )

    def validate(self) -> "FinetuneConfig":
        """Raise `ConfigError` naming the field if a value is out of range, or if the
        training, selection and evaluation seed ranges overlap."""
        validate_fields(self)
        check_choice("family", self.family, SCENARIO_FAMILIES)
        check_choice("critic_loss", self.critic_loss, ("huber", "mse"))
        self.check_common()
        # at most one episode per environment step: seeds offset … offset + total_steps − 1
        ranges = {
            "train_seed_offset": (self.train_seed_offset, self.total_steps),
            "eval_seed_offset": (self.eval_seed_offset, self.eval_episodes),
        }
        for name, (first, _) in ranges.items():
            if first < EVALUATION_SEEDS:
                raise ConfigError(
                    f"{name} = {first} is invalid: must be >= {EVALUATION_SEEDS} (seeds "
                    f"0-{EVALUATION_SEEDS - 1} are the evaluation seeds)"
                )
        (a, na), (b, nb) = ranges.values()
        if a < b + nb and b < a + na:
            raise ConfigError(
                f"train_seed_offset = {a} is invalid: the training seeds {a}-{a + na - 1} "
                f"overlap the selection seeds {b}-{b + nb - 1} (eval_seed_offset)"
            )
        return self
