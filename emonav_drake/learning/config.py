"""Training configurations: every hyper-parameter of a run in one typed object.

`DaggerConfig` and `SarlConfig` (the routes that learn from an expert, a planner spec) are
here; `SacConfig` and `FinetuneConfig` (the soft actor-critic routes) are in
`learning/sac_config.py`, and the ranges and rules they all share in
`learning/config_common.py`.
Loadable from YAML with `typed_yaml.load_typed_yaml` (no `from __future__ import
annotations` here: Drake's typed loader needs real types). Each field declares its
default, doc, unit and allowed range (`config_fields.setting`); `validate()` checks the
ranges (`typed_yaml.validate_fields`, the expert's own fields included) and the
cross-field rules, raising `ConfigError` naming the field.
"""

import dataclasses as dc

from emonav_drake.config_fields import setting as _setting  # DaggerConfig has a `setting`
from emonav_drake.configs import SETTINGS
from emonav_drake.learning.config_common import (
    COUNT,
    COUNT_OR_NONE,
    FRACTION,
    GOAL_RADIUS,
    LEARNING_RATE,
    NUM_FRAMES,
    POOL,
    SEED_OFFSET,
    THREADS,
    WIDTH,
    TrainingRunConfig,
    check_choice,
    check_observation,
)
from emonav_drake.learning.teacher import expert_for_route
from emonav_drake.navigation.goal_input import GOAL_INPUTS
from emonav_drake.params import SCENARIO_FAMILIES, EpisodeParams
from emonav_drake.planners.legacy import (
    LEGACY_EXPERT_FIELDS,
    expert_from_legacy,
    named_expert_from_legacy,
)
from emonav_drake.planners.specs import (
    EXPERT_SPECS,
    DwaSpec,
    ExpertSpec,
    MpcSpec,
    describe_spec,
    is_soft,
)
from emonav_drake.planning.sarl_state import VALUE_NETWORKS
from emonav_drake.typed_yaml import ConfigError, from_plain, validate_fields

__all__ = ["DaggerConfig", "SarlConfig"]

_EXPERT_TAGS = ", ".join(f"`!{spec.__name__}`" for spec in EXPERT_SPECS)
# What a YAML file that names its expert by a word is told (`typed_yaml`, `_HINTS`).
EXPERT_BY_NAME = "a registered planner by its name: `expert: !PlannerSpec {name: mpc}`"


@dc.dataclass
class DaggerConfig(TrainingRunConfig):
    """Every setting of the CPU route."""

    expert_episodes: int = _setting(400, "episodes of the expert round", "", COUNT)
    rounds: int = _setting(6, "DAgger rounds after the expert round", "", COUNT)
    episodes_per_round: int = _setting(150, "episodes of each DAgger round", "", COUNT)
    beta: float = _setting(
        0.5, "expert-acting probability in round 1, halved every round", "", FRACTION
    )
    grad_steps_first: int = _setting(3000, "gradient steps after the expert round", "", COUNT)
    grad_steps_per_round: int = _setting(2000, "gradient steps after each DAgger round", "", COUNT)
    batch_size: int = _setting(64, "labelled states per gradient step", "", COUNT)
    lr: float = _setting(1e-3, "AdamW learning rate", "", LEARNING_RATE)
    weight_decay: float = _setting(1e-5, "AdamW weight decay", "", FRACTION)
    hidden: int = _setting(256, "width of the policy's hidden layer", "", WIDTH)
    pool: int = _setting(2, "max-pool factor before the encoder (1 = paper resolution)", "", POOL)
    eval_episodes: int = _setting(60, "episodes of the per-round evaluation", "", COUNT)
    train_seed_offset: int = _setting(
        1_000_000, "training scenarios: seeds offset + i", "", SEED_OFFSET
    )
    eval_seed_offset: int = _setting(
        500_000, "held-out seeds for the per-round evaluation", "", SEED_OFFSET
    )
    goal_radius: float = _setting(
        EpisodeParams.eval_goal_radius,
        "the DAgger route's episodes end within the evaluation radius (`episode.eval_goal_radius`)",
        "m",
        GOAL_RADIUS,
    )
    grid_kind: str = _setting(
        "lgm",
        'observation variant, as in `SacConfig`: "lgm" (paper), "ogm", "scan" (LiDAR-SAC; '
        'with encoder "lstm": LNDNL), "drlvo" (DRL-VO*, num_frames 1), "lgm_vel" (the LGM '
        'stack + the pedestrians\' velocities now), "lgm_tracks" (the LGM stack + a table of '
        "the nearest pedestrians, read by its own MLP)",
    )
    num_frames: int = _setting(9, "N, frames in the stack; 1 = Single-LGM", "", NUM_FRAMES)
    encoder: str = _setting("cnn", '"cnn"; "lstm" with grid_kind "scan" = LNDNL')
    goal_input: str = _setting(
        "goal",
        'what the student reads as its goal (`navigation/goal_input.py`): "goal" (the paper\'s) or '
        '"guide" (the bearing of a sub-goal on the shortest path around the static discs)',
    )
    setting: str = _setting(
        "var_dd",
        "the paper's setting the route trains (and selects) in, by name "
        '(`emonav_drake.configs`): "var_dd" (the defaults), "no_emotion" (0.2 m for every '
        'emotion), "constant_0.5" (Table III\'s constant-discomfort-distance rows) or '
        '"time_varying"',
    )
    family: str = _setting(
        "paper",
        "the scenario family the route trains and selects in (`docs/scenarios.md`): "
        '"paper" (the paper\'s arena) or another family, e.g. "mixed" (the paper\'s arena '
        "half the time, else any family: walls, corridors, standing and grouped pedestrians)",
    )
    mirror_augment: bool = _setting(True, "mirror half of every batch left-right (every kind)")
    response: str = _setting(
        "",
        "the robot of the training world and of the expert's predictions: \"\" = the paper's "
        'LIP; "digit" = the shipped Digit step-response model; or the path of a fitted model '
        "JSON (`emonav calibrate fit`; robot/step_response.py)",
    )
    init_policy: str = _setting(
        "",
        'start the student from this policy checkpoint ("" = from scratch; "shipped" = the '
        "LIP-trained LGM policy, `planners.policy.LIP_POLICY`; a shipped variant's name, "
        'e.g. "single_lgm"; or a path); its network must be the one this configuration builds',
    )
    # The expert in YAML: `!DwaSpec {margin: 0.1, response: digit}` (the default: DWA with a
    # 0.05 m margin on the LIP), `!MpcSpec {clearance: 0.1}` (the OSQP MPC; its continuous
    # commands are labelled as the nearest command of the student's grid), `!ShieldSpec
    # {...}` (a policy behind the LGM shield), `!MpcNearbySpec {...}` (a policy within
    # `cells` grid steps of the MPC's command) or `!PlannerSpec {name: NAME}` (any
    # registered planner, one of `planner_modules` too).
    expert: ExpertSpec = _setting(
        doc=f"the expert that labels the states, a planner spec (`planners/specs.py`) by its "
        f"YAML tag: {_EXPERT_TAGS}; a shield or MPC-nearby expert without a checkpoint wraps "
        "`init_policy`",
        factory=lambda: DwaSpec(margin=0.05),
    )
    # The policy's softmax on the commands the shield admits, or on those next to the MPC's,
    # learnt by cross-entropy: near-ties and the allowed set are both in the label.
    soft_labels: bool = _setting(
        False,
        "soft labels (a `ShieldSpec` or `MpcNearbySpec` expert): the student learns the "
        "expert's distribution over the grid, not its argmax alone",
    )
    planner_modules: list[str] = _setting(
        [],
        "planner modules from outside the package (`planners/plugins.py`: .py paths or module "
        "names) imported before the expert is built; `emonav train --planner-module` adds to it",
    )
    heading_noise_prob: float = _setting(
        0.5, "fraction of training episodes starting off course", "", FRACTION
    )
    heading_noise: float = _setting(
        1.5, "their initial heading error, uniform in ± this", "rad", (0.0, 3.1416)
    )
    threads: int = _setting(1, "torch threads: batch-1 acting is fastest on one", "", THREADS)

    # Fields of earlier versions, now parts of `expert` (a YAML file naming one is refused
    # with this hint; a saved run's state is converted, `from_saved`). `expert` itself was a
    # word then ("dwa", "mpc", ...): that is refused by the typed check with `_HINTS`.
    _HINTS = {"expert": EXPERT_BY_NAME}
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
        validate_fields(self)
        check_observation(self.grid_kind, self.encoder, self.num_frames)
        check_choice("goal_input", self.goal_input, GOAL_INPUTS)
        check_choice("setting", self.setting, SETTINGS)
        check_choice("family", self.family, SCENARIO_FAMILIES)
        self.check_common()
        self.teacher()  # the expert's own rules
        if self.soft_labels and not is_soft(self.expert):
            raise ConfigError(
                f"soft_labels needs a ShieldSpec or MpcNearbySpec expert (a distribution over "
                f"the grid), not {describe_spec(self.expert)}"
            )
        return self


@dc.dataclass
class SarlConfig(TrainingRunConfig):
    """SARL by CrowdNav's route (`learning/sarl_train.py`): imitation of an expert (value
    regression on discounted returns), then value learning with ε-greedy exploration,
    experience replay and a target network. CrowdNav's settings unless noted."""

    network: str = _setting(
        "sarl",
        'the value network: "sarl" (CrowdNav\'s SARL) or "rgl" (its relational graph '
        "network, `planners/sarl.py`: RglValue); the same rows, look-ahead and route",
    )
    expert: ExpertSpec = _setting(
        doc="the expert of the imitation phase, a planner spec as `DaggerConfig.expert`: by "
        "default the MPC (our best model planner; CrowdNav imitates ORCA, which our robot "
        "cannot follow: its steps are bounded by Eq. 2)",
        factory=MpcSpec,
    )
    planner_modules: list[str] = _setting(
        [],
        "planner modules from outside the package imported before the expert is built (as "
        "`DaggerConfig.planner_modules`); `emonav train --planner-module` adds to it",
    )
    il_episodes: int = _setting(1000, "imitation episodes (CrowdNav: 3 000)", "", COUNT_OR_NONE)
    il_epochs: int = _setting(50, "imitation epochs over their states", "", COUNT_OR_NONE)
    il_lr: float = _setting(0.01, "SGD learning rate of the imitation", "", LEARNING_RATE)
    rl_episodes: int = _setting(
        3000,
        "value-learning episodes (CrowdNav: 10 000; a CPU budget here: docs/learning.md)",
        "",
        COUNT_OR_NONE,
    )
    rl_lr: float = _setting(0.001, "SGD learning rate of the value learning", "", LEARNING_RATE)
    batch_size: int = _setting(100, "states per update", "", COUNT)
    train_batches: int = _setting(100, "updates after every RL episode", "", COUNT_OR_NONE)
    target_update: int = _setting(50, "episodes between target-network copies", "", COUNT)
    capacity: int = _setting(100_000, "replay memory (states)", "", COUNT)
    epsilon_start: float = _setting(0.5, "ε of the first RL episode", "", FRACTION)
    epsilon_end: float = _setting(0.1, "ε once the decay is over", "", FRACTION)
    epsilon_decay: int = _setting(4000, "episodes of the linear ε decay", "", COUNT)
    gamma: float = _setting(
        0.9,
        "discounted per second of travel at v_pref: γ^(T·v_pref) a step",
        "",
        FRACTION,
    )
    eval_every: int = _setting(
        500,
        "RL episodes between selections (and after imitation, at the end)",
        "",
        COUNT,
    )
    eval_episodes: int = _setting(200, "episodes of a selection", "", COUNT)
    eval_seed_offset: int = _setting(
        600_000, "selection seeds (never evaluation seeds 0–499)", "", SEED_OFFSET
    )
    train_seed_offset: int = _setting(
        4_000_000, "training scenarios (imitation, then RL)", "", SEED_OFFSET
    )
    goal_radius: float = _setting(
        EpisodeParams.eval_goal_radius,
        "episodes end within this goal radius (`episode.eval_goal_radius`)",
        "m",
        GOAL_RADIUS,
    )
    threads: int = _setting(1, "torch threads", "", THREADS)

    _HINTS = {"expert": EXPERT_BY_NAME}

    def validate(self) -> "SarlConfig":
        """Raise `ConfigError` naming the field if a value is out of range."""
        validate_fields(self)
        expert_for_route(self.expert, "", self.planner_modules)
        check_choice("network", self.network, VALUE_NETWORKS)
        self.check_common()
        return self

    @classmethod
    def from_saved(cls, plain: dict) -> "SarlConfig":
        """The configuration a run saved (`to_plain`; an earlier version's expert name
        converted, `named_expert_from_legacy`)."""
        return from_plain(cls, named_expert_from_legacy(plain))
