"""Training configurations: every hyper-parameter of a run in one typed object.

Loadable from YAML with `emonav_drake.params.load_typed_yaml` (no `from __future__
import annotations` here: Drake's typed loader needs real types). `validate()` checks
every field against its allowed range (`_DAGGER_RANGES`, `_SAC_RANGES`,
`_FINETUNE_RANGES`, in the style of `params._RANGES`) and the cross-field rules,
raising `ConfigError` naming the field.
"""

import dataclasses as dc

from emonav_drake.config_yaml import ConfigError, from_plain, validate_ranges
from emonav_drake.configs import SETTINGS
from emonav_drake.core.goal_input import GOAL_INPUTS
from emonav_drake.core.observations import observation_kind, observation_kinds
from emonav_drake.core.sarl_state import VALUE_NETWORKS
from emonav_drake.diagrams.plants import PLANTS
from emonav_drake.learning.teacher import (
    LEGACY_EXPERT_FIELDS,
    expert_for_route,
    expert_from_legacy,
    named_expert_from_legacy,
)
from emonav_drake.param_ranges import SEED_RANGE
from emonav_drake.params import NUM_BEAMS, SCENARIO_FAMILIES, EpisodeParams
from emonav_drake.planners.specs import DwaSpec, ExpertSpec, MpcSpec, describe_spec, is_soft

# The 4-conv encoder (3 x 3, strides 2-1-1-1) needs an input of at least this many cells.
MIN_ENCODER_INPUT = 15


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
    # the DAgger route's episodes end within the evaluation radius (`episode.eval_goal_radius`)
    goal_radius: float = EpisodeParams.eval_goal_radius
    # Observation variant, as in `SacConfig`: "lgm" (paper), "ogm", "scan" (LiDAR-SAC; with
    # encoder "lstm": LNDNL), "drlvo" (DRL-VO*, num_frames 1); num_frames 1 = Single-LGM.
    grid_kind: str = "lgm"
    num_frames: int = 9
    encoder: str = "cnn"
    # What the student reads as its goal (`core/goal_input.py`): "goal" (the paper's) or
    # "guide" (the bearing of a sub-goal on the shortest path around the static discs).
    goal_input: str = "goal"
    # The paper's setting the route trains (and selects) in, by name (`emonav_drake.configs`):
    # "var_dd" (the defaults), "no_emotion" (0.2 m for every emotion), "constant_0.5"
    # (Table III's constant-discomfort-distance rows) or "time_varying".
    setting: str = "var_dd"
    # The scenario family the route trains and selects in (`docs/scenarios.md`): "paper"
    # (the paper's arena) or another family, e.g. "mixed" (the paper's arena half the
    # time, else any family: walls, corridors, standing and grouped pedestrians).
    family: str = "paper"
    mirror_augment: bool = True  # mirror half of every batch left-right (every kind)
    # The robot of the training world and of the expert's predictions: "" = the paper's LIP;
    # "digit" = the shipped Digit step-response model; or the path of a fitted model JSON
    # (`emonav calibrate fit`). See core/step_response.py.
    response: str = ""
    # Start the student from this policy checkpoint ("" = from scratch; "shipped" = the
    # LIP-trained LGM policy, `planners.policy.LIP_POLICY`; a shipped variant's name, e.g.
    # "single_lgm"; or a path); its network must be the one this configuration builds.
    init_policy: str = ""
    # The expert that labels the states, a planner spec (`planners/specs.py`), in YAML by
    # its tag: `!DwaSpec {margin: 0.1, response: digit}` (the default: DWA with a 0.05 m
    # margin on the LIP), `!MpcSpec {clearance: 0.1}` (the OSQP MPC; its continuous commands
    # are labelled as the nearest command of the student's grid), `!ShieldSpec {...}` (a
    # policy behind the LGM shield), `!MpcNearbySpec {...}` (a policy within `cells` grid
    # steps of the MPC's command) or `!PlannerSpec {name: NAME}` (any registered planner, one
    # of `planner_modules` too). A shield or MPC-nearby expert without a checkpoint wraps
    # `init_policy`.
    expert: ExpertSpec = dc.field(default_factory=lambda: DwaSpec(margin=0.05))
    # Soft labels (a `ShieldSpec` or `MpcNearbySpec` expert): the student learns the expert's
    # distribution over the grid (the policy's softmax on the commands the shield admits, or
    # on those next to the MPC's) by cross-entropy, not its argmax alone, so near-ties and
    # the allowed set are both in the label.
    soft_labels: bool = False
    # Planner modules from outside the package (`planners/plugins.py`: .py paths or module
    # names) imported before the expert is built; `emonav train --planner-module` adds to it.
    planner_modules: list[str] = dc.field(default_factory=list)
    heading_noise_prob: float = 0.5  # fraction of training episodes starting off course
    heading_noise: float = 1.5  # their initial heading error, uniform in ± this [rad]
    device: str = "cpu"
    threads: int = 1  # batch-1 acting is fastest on one thread

    # Fields of earlier versions, now parts of `expert` (a YAML file naming one is refused
    # with this hint; a saved run's state is converted, `from_saved`).
    _MOVED = {
        name: "the expert's settings are now one field, e.g. `expert: !DwaSpec {margin: 0.1, "
        "response: digit}` or `expert: !MpcSpec {clearance: 0.1}` (docs/learning.md)"
        for name in LEGACY_EXPERT_FIELDS
    }

    def teacher(self) -> ExpertSpec:
        """The expert spec this route builds: `expert`, a soft one without a checkpoint
        wrapping `init_policy`; `ConfigError` if it cannot be built by name."""
        return expert_for_route(self.expert, self.init_policy, self.planner_modules)

    @classmethod
    def from_saved(cls, plain: dict) -> "DaggerConfig":
        """The configuration a run saved (`to_plain`), earlier versions' flat expert
        fields converted (`expert_from_legacy`)."""
        return from_plain(cls, expert_from_legacy(plain))

    def validate(self) -> "DaggerConfig":
        """Raise `ConfigError` naming the field if a value is out of range."""
        validate_ranges(self, _DAGGER_RANGES)
        _check_observation(self.grid_kind, self.encoder, self.num_frames)
        _choice("goal_input", self.goal_input, GOAL_INPUTS)
        _choice("setting", self.setting, SETTINGS)
        _choice("family", self.family, SCENARIO_FAMILIES)
        self.teacher()  # the expert's own rules
        if self.soft_labels and not is_soft(self.expert):
            raise ConfigError(
                f"soft_labels needs a ShieldSpec or MpcNearbySpec expert (a distribution over "
                f"the grid), not {describe_spec(self.expert)}"
            )
        return self


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
    goal_radius: float = EpisodeParams.goal_radius  # d_goal of training (`episode.goal_radius`)
    # The robot of the training environment: "lip" (`EmoNavLIP-v0`) or "digit" (the
    # full-order Digit diagram, `EmoNavDigit-v0`: ~0.2 s of CPU per environment step).
    plant: str = "lip"
    # Environments stepped together (on Ray actors when > 1; `learning/env_pool.py`).
    num_envs: int = 1
    reuse_features: bool = True  # the actor step reuses the critic pass's conv features
    channels_last: bool = False  # NHWC memory format for the conv stacks

    def validate(self) -> "SacConfig":
        """Raise `ConfigError` naming the field if a value is out of range or inconsistent."""
        validate_ranges(self, _SAC_RANGES)
        _check_observation(self.grid_kind, self.encoder, self.num_frames)
        _choice("plant", self.plant, tuple(PLANTS))
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
class SarlConfig:
    """SARL by CrowdNav's route (`learning/sarl_train.py`): imitation of an expert (value
    regression on discounted returns), then value learning with ε-greedy exploration,
    experience replay and a target network. CrowdNav's settings unless noted."""

    seed: int = 0
    # The value network: "sarl" (CrowdNav's SARL) or "rgl" (its relational graph network,
    # `planners/sarl.py`: RglValue); the same rows, look-ahead and route.
    network: str = "sarl"
    # The expert of the imitation phase, a planner spec as `DaggerConfig.expert`: by default
    # the MPC (our best model planner; CrowdNav imitates ORCA, which our robot cannot
    # follow: its steps are bounded by Eq. 2).
    expert: ExpertSpec = dc.field(default_factory=MpcSpec)
    il_episodes: int = 1000  # CrowdNav: 3 000
    il_epochs: int = 50
    il_lr: float = 0.01
    rl_episodes: int = 3000  # CrowdNav: 10 000 (a CPU budget here: docs/learning.md)
    rl_lr: float = 0.001
    batch_size: int = 100
    train_batches: int = 100  # updates after every RL episode
    target_update: int = 50  # episodes between target-network copies
    capacity: int = 100_000  # replay memory (states)
    epsilon_start: float = 0.5
    epsilon_end: float = 0.1
    epsilon_decay: int = 4000  # episodes of the linear ε decay
    gamma: float = 0.9  # discounted per second of travel at v_pref: γ^(T·v_pref) a step
    eval_every: int = 500  # RL episodes between selections (and after imitation, at the end)
    eval_episodes: int = 200
    eval_seed_offset: int = 600_000  # selection seeds (never evaluation seeds 0–499)
    train_seed_offset: int = 4_000_000  # training scenarios (imitation, then RL)
    goal_radius: float = EpisodeParams.eval_goal_radius
    device: str = "cpu"
    threads: int = 1

    def validate(self) -> "SarlConfig":
        """Raise `ConfigError` naming the field if a value is out of range."""
        validate_ranges(self, _SARL_RANGES)
        expert_for_route(self.expert, "", [])
        _choice("network", self.network, VALUE_NETWORKS)
        return self

    @classmethod
    def from_saved(cls, plain: dict) -> "SarlConfig":
        """The configuration a run saved (`to_plain`; an earlier version's expert name
        converted, `named_expert_from_legacy`)."""
        return from_plain(cls, named_expert_from_legacy(plain))


def _check_observation(grid_kind: str, encoder: str, num_frames: int) -> None:
    """The observation variant's cross-field rules (shared by both trainers)."""
    _choice("grid_kind", grid_kind, observation_kinds())
    _choice("encoder", encoder, ("cnn", "lstm"))
    kind = observation_kind(grid_kind)
    if encoder == "lstm" and not kind.scans:
        raise ConfigError(
            f"encoder = 'lstm' is invalid with grid_kind = {grid_kind!r}: "
            "the LSTM encoder reads scans (grid_kind: scan)"
        )
    if kind.single_frame and num_frames != 1:
        raise ConfigError(
            f"num_frames = {num_frames} is invalid with grid_kind = {grid_kind!r}: "
            f"it observes one {kind.description} (num_frames: 1)"
        )


def _choice(name: str, value: str, allowed: tuple[str, ...]) -> None:
    if value not in allowed:
        raise ConfigError(f"{name} = {value!r} is invalid: must be one of {list(allowed)}")


# Allowed ranges, inclusive, every one bounded: seeds in [0, 2**64 - 1], seed offsets so
# that offset + i stays a seed, counts and sizes up to MAX_COUNT (a run that long would
# never end on any machine; a typo such as 1e12 is refused instead of started).
MAX_COUNT = 10**9
MAX_SEED_OFFSET = 2**63
_DAGGER_RANGES = {
    "seed": SEED_RANGE,
    "expert_episodes": (1, MAX_COUNT),
    "rounds": (1, MAX_COUNT),
    "episodes_per_round": (1, MAX_COUNT),
    "beta": (0.0, 1.0),
    "grad_steps_first": (1, MAX_COUNT),
    "grad_steps_per_round": (1, MAX_COUNT),
    "batch_size": (1, MAX_COUNT),
    "lr": (1e-8, 1.0),
    "weight_decay": (0.0, 1.0),
    "hidden": (1, 65536),
    "pool": (1, 6),
    "eval_episodes": (1, MAX_COUNT),
    "train_seed_offset": (0, MAX_SEED_OFFSET),
    "eval_seed_offset": (0, MAX_SEED_OFFSET),
    "goal_radius": (0.01, 2.0),
    "heading_noise_prob": (0.0, 1.0),
    "heading_noise": (0.0, 3.1416),
    "threads": (1, 1024),
    "num_frames": (1, 64),
    "expert.margin": (0.0, 2.0),
    "expert.clearance": (0.0, 1.0),
    "expert.cells": (0, 10),
}

_SAC_RANGES = {
    "seed": SEED_RANGE,
    "threads": (1, 1024),
    "total_steps": (1, MAX_COUNT),
    "random_steps": (0, MAX_COUNT),
    "replay_size": (1, MAX_COUNT),
    "batch_size": (1, MAX_COUNT),
    "hidden": (1, 65536),
    "features": (1, 65536),
    "filters": (1, 4096),
    "pool": (1, 6),
    "lr": (1e-8, 1.0),
    "beta1": (0.0, 0.999999),
    "alpha_lr": (1e-8, 1.0),
    "alpha_beta1": (0.0, 0.999999),
    "init_alpha": (1e-8, 1e3),
    "discount": (0.0, 1.0),
    "critic_tau": (1e-6, 1.0),
    "encoder_tau": (1e-6, 1.0),
    "actor_update_freq": (1, MAX_COUNT),
    "target_update_freq": (1, MAX_COUNT),
    "updates_per_step": (1, 1000),
    "eval_every": (1, MAX_COUNT),
    "eval_episodes": (1, MAX_COUNT),
    "eval_seed_offset": (0, MAX_SEED_OFFSET),
    "checkpoint_every": (1, MAX_COUNT),
    "num_envs": (1, 4096),
    "num_frames": (1, 64),
    "grid_size": (2, 1000),
    "goal_radius": (0.01, 2.0),
}


# `emonav benchmark`'s evaluation seeds are 0 … EVALUATION_SEEDS − 1 (docs/results.md): a
# training or selection seed range must stay clear of them.
EVALUATION_SEEDS = 500


@dc.dataclass
class FinetuneConfig:
    """Discrete soft actor-critic fine-tuning of a categorical student
    (`learning/finetune.py`; docs/learning.md, "Fine-tuning a student by SAC")."""

    seed: int = 0
    device: str = "cpu"
    threads: int = 1  # batch-1 acting and small MLP updates are fastest on one thread
    # The training and selection world, as `DaggerConfig.response`: "" = the paper's LIP;
    # "digit" = the shipped Digit step-response model; or a fitted model JSON.
    response: str = ""
    # Episodes end within this goal radius (the DAgger route's, `episode.eval_goal_radius`).
    goal_radius: float = EpisodeParams.eval_goal_radius
    total_steps: int = 100_000  # environment (walking) steps; the episode reaching it ends
    replay_size: int = 100_000  # transitions kept (features, not maps: ≈ 270 B each)
    learning_starts: int = 5_000  # environment steps collected before the first update
    # Gradient updates per environment step, made after each training episode (every
    # episode is collected by a fixed actor; Ctrl-C undoes a partial one).
    updates_per_step: float = 1.0
    batch_size: int = 128  # as the paper's SAC
    hidden: int = 256  # the twin critics: two hidden layers of this width (the actor's)
    state_features: int = 64  # the critics' own vector-state embedding (the actor's: 64)
    critic_lr: float = 3e-4
    actor_lr: float = 1e-4  # the student's head moves slowly
    alpha_lr: float = 3e-4
    discount: float = 0.99  # γ (the paper's `episode.discount`)
    tau: float = 0.005  # Polyak rate of the target critics, every update
    critic_loss: str = "huber"  # "huber" (smooth L1, δ = 1) or "mse" on the soft TD target
    # The first updates train the critics only (actor and α fixed): a random critic must
    # not wreck a good actor.
    critic_warmup: int = 10_000
    alpha_tuning: bool = True  # tune α to `target_entropy`; False: α = init_alpha, fixed
    init_alpha: float = 0.01
    # Target entropy as a fraction of log |A| (log 99 = 4.60 nats): 0.15 → 0.69 nats, about
    # the DAgger students' own mean entropy (0.61 shipped/LIP, 0.76 Digit/Digit in the
    # calibrated world; greedy on training seeds 2000000-2000009).
    target_entropy: float = 0.15
    # + bc_weight · KL(π_init ‖ π): keeps the actor near the student where the critic is
    # unsure (0 = plain SAC).
    bc_weight: float = 0.1
    temperature: float = 1.0  # acting during collection samples softmax(logits / this)
    eval_every: int = 10_000  # environment steps between selection evaluations
    eval_episodes: int = 200
    eval_seed_offset: int = 600_000  # selection seeds offset + i (the DAgger routes')
    train_seed_offset: int = 2_000_000  # training scenarios: seeds offset + i

    def validate(self) -> "FinetuneConfig":
        """Raise `ConfigError` naming the field if a value is out of range, or if the
        training, selection and evaluation seed ranges overlap."""
        validate_ranges(self, _FINETUNE_RANGES)
        _choice("critic_loss", self.critic_loss, ("huber", "mse"))
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


_FINETUNE_RANGES = {
    "seed": SEED_RANGE,
    "threads": (1, 1024),
    "goal_radius": (0.01, 2.0),
    "total_steps": (1, MAX_COUNT),
    "replay_size": (1, MAX_COUNT),
    "learning_starts": (0, MAX_COUNT),
    "updates_per_step": (0.0, 1000.0),
    "batch_size": (1, MAX_COUNT),
    "hidden": (1, 65536),
    "state_features": (1, 65536),
    "critic_lr": (1e-8, 1.0),
    "actor_lr": (0.0, 1.0),
    "alpha_lr": (1e-8, 1.0),
    "discount": (0.0, 1.0),
    "tau": (1e-6, 1.0),
    "critic_warmup": (0, MAX_COUNT),
    "init_alpha": (1e-8, 1e3),
    "target_entropy": (0.0, 1.0),
    "bc_weight": (0.0, 1e3),
    "temperature": (1e-3, 1e3),
    "eval_every": (1, MAX_COUNT),
    "eval_episodes": (1, MAX_COUNT),
    "eval_seed_offset": (0, MAX_SEED_OFFSET),
    "train_seed_offset": (0, MAX_SEED_OFFSET),
}

_SARL_RANGES = {
    "seed": SEED_RANGE,
    "il_episodes": (0, MAX_COUNT),
    "il_epochs": (0, MAX_COUNT),
    "il_lr": (1e-8, 1.0),
    "rl_episodes": (0, MAX_COUNT),
    "rl_lr": (1e-8, 1.0),
    "batch_size": (1, MAX_COUNT),
    "train_batches": (0, MAX_COUNT),
    "target_update": (1, MAX_COUNT),
    "capacity": (1, MAX_COUNT),
    "epsilon_start": (0.0, 1.0),
    "epsilon_end": (0.0, 1.0),
    "epsilon_decay": (1, MAX_COUNT),
    "gamma": (0.0, 1.0),
    "eval_every": (1, MAX_COUNT),
    "eval_episodes": (1, MAX_COUNT),
    "eval_seed_offset": (0, MAX_SEED_OFFSET),
    "train_seed_offset": (0, MAX_SEED_OFFSET),
    "goal_radius": (0.01, 2.0),
    "threads": (1, 1024),
}
