"""One typed configuration for the whole project.

Every number of the paper's Table I and of the environment (docs/facts.md) lives
here, in plain dataclasses. Configurations load from YAML (`load_config`) with Drake's
typed loader, which already rejects unknown fields, and are then validated
(`EmoNavConfig.validate`): a value outside its allowed range raises `ConfigError` naming
the dotted field path and the range.

This module is the configuration itself: its fields, defaults and cross-field rules,
and the small helpers that go with them (`pendulum_frequency`, `NUM_BEAMS`, the emotion
codes). The allowed ranges are a table in `param_ranges.py`; the schema-agnostic YAML
machinery (typed loading and dumping, error messages naming the field, the range check,
`ConfigError`) is `config_yaml.py`, shared with the training configurations and the
scenarios. `ConfigError` is importable from here too.

Units are SI throughout (metres, seconds, radians).
"""

# No `from __future__ import annotations`: Drake's typed YAML loader needs real types.
import dataclasses as dc
import math
from pathlib import Path

from emonav_drake.config_yaml import (
    ConfigError,
    dump_typed_yaml,
    load_typed_yaml,
    require,
    validate_ranges,
)
from emonav_drake.param_ranges import RANGES as _RANGES

# Emotion codes used everywhere (crowd, grid maps, metrics).
HAPPY, NEUTRAL, NEGATIVE = 0, 1, 2
EMOTION_NAMES = ("happy", "neutral", "negative")


def pendulum_frequency(height: float, gravity: float) -> float:
    """ω = √(g/H) [1/s] of a (angular-momentum) linear inverted pendulum of CoM height H [m]
    under gravity g [m/s²]: the LIP of the paper's Eq. 1 and Digit's ALIP alike."""
    return math.sqrt(gravity / height)


@dc.dataclass
class RobotParams:
    """The reduced-order (LIP) robot and its command bounds (paper Table I, Eq. 1–2)."""

    step_time: float = 0.4  # T, one walking step [s]
    com_height: float = 1.02  # H, centre-of-mass height of the LIP [m]
    gravity: float = 9.81  # g, gravitational acceleration [m/s^2]
    radius: float = 0.3  # r_robot, collision radius [m]
    max_speed: float = 0.4  # ū_v, sagittal speed bound [m/s]
    max_heading_change: float = 0.2  # ū_Δθ, heading change per step bound [rad]
    start: list[float] = dc.field(default_factory=lambda: [-4.0, 0.0])  # start, world x, y [m]
    goal: list[float] = dc.field(default_factory=lambda: [4.0, 0.0])  # goal, world x, y [m]

    @property
    def omega(self) -> float:
        """LIP natural frequency ω = √(g/H) [1/s] of this robot's H."""
        return pendulum_frequency(self.com_height, self.gravity)


# K, the paper's number of LiDAR beams over 360° (`LidarParams.num_beams`): the default of
# every function and network that takes a beam count.
NUM_BEAMS = 1800


@dc.dataclass
class LidarParams:
    """The 2-D LiDAR and the grid maps built from it (docs/lidar_grid_maps.md)."""

    num_beams: int = NUM_BEAMS  # K, beams over 360°
    max_range: float = 6.0  # L, maximum range [m]
    min_range: float = 0.27  # nearer hits are raised to this range [m]
    grid_size: int = 100  # M (rings × sectors for the LGM, cells per side for the OGM)
    num_frames: int = 9  # N, frames in the stack


@dc.dataclass
class CrowdParams:
    """Pedestrians (ORCA), static discs and scenario sampling (paper §IV-B)."""

    dt: float = 0.1  # pedestrian dynamics period [s] (10 Hz)
    pedestrian_radius: float = 0.3  # r_ped, pedestrian radius [m]
    preferred_speed: float = 1.0  # pedestrians' preferred (ORCA) speed [m/s]
    min_pedestrians: int = 1  # fewest pedestrians in a sampled scenario
    max_pedestrians: int = 4  # most pedestrians in a sampled scenario
    min_static: int = 1  # fewest static discs in a sampled scenario
    max_static: int = 3  # most static discs in a sampled scenario
    static_radius_min: float = 0.2  # static disc radius: lower bound [m]
    static_radius_max: float = 0.4  # static disc radius: upper bound [m]
    circle_radius_min: float = 3.5  # radius of the pedestrians' start circle: lower bound [m]
    circle_radius_max: float = 4.5  # radius of the pedestrians' start circle: upper bound [m]
    # [low, high] of the static discs' centre x [m]
    static_x_range: list[float] = dc.field(default_factory=lambda: [-3.0, 3.0])
    # [low, high] of the static discs' centre y [m]
    static_y_range: list[float] = dc.field(default_factory=lambda: [-1.5, 1.5])
    goal_tolerance: float = 0.1  # a pedestrian turns round within this of its goal [m]
    # ORCA (RVO2 semantics), the authors' settings.
    neighbor_dist: float = 10.0  # ORCA: neighbours are the pedestrians closer than this [m]
    max_neighbors: int = 10  # ORCA: at most this many nearest neighbours
    time_horizon: float = 5.0  # ORCA horizon of pedestrians' velocity obstacles [s]
    time_horizon_obst: float = 5.0  # ORCA horizon of static discs' velocity obstacles [s]
    safety_space: float = 0.2  # added to every ORCA radius [m]
    # Probabilities of happy, neutral, negative when a pedestrian's emotion is drawn
    emotion_probs: list[float] = dc.field(default_factory=lambda: [1 / 3, 1 / 3, 1 / 3])
    time_varying_emotions: bool = False  # one pedestrian's emotion changes periodically
    emotion_change_period: float = 2.0  # time-varying mode: period of the changes [s]
    # The scenario sampler (core/scenario_families.py): "paper" is §IV-B's arena
    family: str = "paper"


@dc.dataclass
class RewardParams:
    """Rewards, paper Eq. 6–9, and the discomfort distances of §III-C."""

    collision: float = -0.6  # reward of a collision
    discomfort: float = -0.1  # reward inside a discomfort zone, counted once per step
    goal: float = 0.5  # reward of reaching the goal
    progress_gain: float = 0.3  # reward per metre of progress towards the goal [1/m]
    static_discomfort: float = 0.2  # d_static, discomfort distance of static discs [m]
    happy_discomfort: float = 0.2  # discomfort distance of happy pedestrians [m]
    neutral_discomfort: float = 0.35  # discomfort distance of neutral pedestrians [m]
    negative_discomfort: float = 0.5  # discomfort distance of negative pedestrians [m]

    def emotion_distances(self) -> tuple[float, float, float]:
        """Discomfort distance per emotion code (HAPPY, NEUTRAL, NEGATIVE) [m]."""
        return (self.happy_discomfort, self.neutral_discomfort, self.negative_discomfort)


@dc.dataclass
class EpisodeParams:
    """Episode rules (the authors' code): time limit, goal radii, discount."""

    max_steps: int = 125  # time limit in walking steps (50 s of 0.4 s steps)
    goal_radius: float = 0.1  # d_goal, goal reached within this, training [m]
    eval_goal_radius: float = 0.2  # d_goal in evaluation [m]
    discount: float = 0.99  # γ, discount factor


@dc.dataclass
class DwaParams:
    """Dynamic Window Approach on the LIP model (the paper's DWA baseline)."""

    speed_samples: int = 9  # candidate speeds, evenly spread over [0, ū_v]
    heading_samples: int = 11  # candidate heading changes, evenly over [−ū_Δθ, ū_Δθ]
    horizon_steps: int = 5  # walking steps rolled out per candidate
    goal_weight: float = 1.0  # score of progress to the goal (per horizon's full-speed reach)
    clearance_weight: float = 1.0  # score of clearance (per clearance_cap)
    discomfort_weight: float = 3.0  # penalty per metre of discomfort-zone intrusion [1/m]
    speed_weight: float = 0.1  # score of speed (per ū_v)
    clearance_cap: float = 1.0  # clearance beyond this earns nothing more [m]
    safety_margin: float = 0.05  # extra collision margin in the rollout [m]
    hard_steps: int = 2  # predicted pedestrian contact within this many steps: rejected


@dc.dataclass
class MpcParams:
    """MPC on the LIP model solved with OSQP (the model-based baseline, `core/mpc.py`)."""

    horizon_steps: int = 8  # walking steps of T in the horizon
    scp_iterations: int = 3  # QPs per planning step (re-linearisations)
    # Costs (per walking step of the horizon).
    goal_weight: float = 1.0  # on |p_k − p_k^ref|² [1/m²]
    terminal_weight: float = 4.0  # extra weight on |p_N − p_N^ref|²
    reference_lead: float = 1.0  # reference p_k^ref runs this far ahead of full speed [m]
    speed_smoothness_weight: float = 2.0  # on (u_v,k − u_v,k−1)² [(s/m)²]
    turn_smoothness_weight: float = 2.0  # on (u_Δθ,k − u_Δθ,k−1)² [1/rad²]
    turn_weight: float = 0.2  # on u_Δθ,k² [1/rad²]
    discomfort_weight: float = 20.0  # slack penalty per metre inside a discomfort zone
    collision_weight: float = 200.0  # slack penalty per metre of predicted late contact
    slack_quadratic_weight: float = 1.0  # small quadratic term on every slack [1/m²]
    prediction_discount: float = 0.85  # pedestrian penalties weighted by this^k
    # Margins.
    collision_margin: float = 0.05  # added to r_obstacle + r_robot for contact [m]
    discomfort_margin: float = 0.03  # added to the discomfort zones [m]
    hard_pedestrian_steps: int = 2  # pedestrian contact is a hard constraint this far
    # Guide path around the static discs (grid Dijkstra), followed by the reference.
    guide_resolution: float = 0.1  # cell size of the guide grid [m]
    guide_padding: float = 3.0  # grid margin around robot, goal and discs [m]
    guide_zone_cost: float = 3.0  # cost factor of cells inside a disc's discomfort zone
    # SCP and initial guess.
    trust_region: float = 0.12  # |u_Δθ − ū_Δθ| per SCP iteration [rad]
    seed_headings: int = 7  # seed headings: offsets spread over ±seed_max_offset
    seed_max_offset: float = 1.2  # largest offset of the seed headings [rad]
    previous_plan_bonus: float = 0.05  # hysteresis for the previous plan (relative cost)
    # Fallback and solver.
    fallback_speed_scale: float = 0.5  # fallback: u_v = this × current speed, keep heading
    osqp_eps: float = 1e-3  # absolute and relative tolerances (solutions are polished)
    osqp_max_iter: int = 400  # OSQP iteration limit per QP
    # OSQP's wall-clock limit per QP [s]: a safety only (a QP takes ~1 ms; the work is
    # bounded by osqp_max_iter); each time it fires the plan depends on the load, and the
    # planner counts it (time_limit_hits) and warns
    time_limit: float = 1.0  # OSQP wall-clock limit per QP, a safety only [s]


# The named scenario samplers (`CrowdParams.family`, core/scenario_families.py).
SCENARIO_FAMILIES = (
    "paper",
    "circle_crossing",
    "parallel_traffic",
    "perpendicular_traffic",
    "robot_crowding",
    "delayed_crossing",
    "crossing_with_obstacles",
    "corner_traffic",
    "blocker",
    "group_approach",
    "all_dynamic",
    "corridor_head_on",
    "dense_8",
    "dense_12",
    "dense_20",
    "fast_pedestrians",
    "mixed",
)

# Where the model-based planners' crowd state comes from (`PerceptionParams.state_source`).
STATE_SOURCES = ("truth", "lidar")


@dc.dataclass
class PerceptionParams:
    """What the robot knows of the crowd (docs/perception.md, "Perceived state").

    The learned policies read the LiDAR grid maps in either case; `state_source` decides
    what the state-based planners (DWA, MPC, SARL, RGL) read: "truth", the simulator's
    exact crowd (privileged: every pedestrian, also hidden ones), or "lidar", the
    pedestrians and obstacles detected in the 1800-beam scan and tracked at the scan's
    rate (`core/lidar_objects.py`, `core/crowd_tracker.py`): what a robot can run.
    """

    state_source: str = "truth"  # "truth" (the simulator's crowd) or "lidar" (tracked)


@dc.dataclass
class WalkingParams:
    """Full-order Digit walking: gait, ALIP planner, passivity controller, model options.

    The step time T and gravity g are not here: they belong to `RobotParams`
    (`robot.step_time`, `robot.gravity`), shared by the navigation model, the Digit plant,
    the footstep planner and the controller. Fractions `*_fraction` are of T.

    Gains of the passivity law τ = M̄ q̈_r + C̄ q̇_r + Ḡ − K_D s (docs/walking.md): the task
    error e decays through q̇_r = q̇_d − Λ e (rates `lambda_*` [1/s]) and s = q̇ − q̇_r is
    damped by the joint-space K_D (`kd_leg` [N·m·s/rad]).
    """

    step_width: float = 0.22  # W, lateral distance between the feet [m]
    clearance: float = 0.08  # swing-foot apex above the ground [m]
    touchdown_speed: float = 0.2  # swing foot vertical speed at touchdown [m/s]
    early_touchdown: float = 0.9  # a touchdown is accepted after this fraction of T
    touchdown_tolerance: float = 0.002  # swing sole this close to the ground = touchdown [m]
    torso_height: float = 1.0  # torso origin above the ground [m]
    torso_pitch: float = 0.0  # torso pitch target (+ leans forward) [rad]
    stand_time: float = 0.4  # double support before the first step [s]
    stand_com_lead: float = 0.02  # standing CoM target ahead of the feet's midpoint [m]
    speed_integral_gain: float = 0.3  # per-step integrator on the speed error
    speed_integral_limit: float = 0.15  # bound of that integrator [m/s]
    heading_blend_fraction: float = 0.6  # torso heading reaches its target at this·T
    swing_yaw_blend_fraction: float = 0.8  # swing foot yaw reaches its target at this·T
    swing_finish_fraction: float = 0.85  # swing foot reaches its target (horizontally)
    target_freeze_fraction: float = 0.8  # the swing target is frozen after this·T
    prediction_fraction: float = 0.5  # the logged ALIP end-of-step prediction is made here
    lateral_step_min: float = 0.12  # lateral step clamp from the stance foot: lower [m]
    lateral_step_max: float = 0.45  # lateral step clamp from the stance foot: upper [m]
    max_step_length: float = 0.45  # sagittal step clamp from the stance foot [m]
    lambda_orientation: float = 12.0  # torso orientation [1/s]
    lambda_height: float = 10.0  # torso height [1/s]
    lambda_horizontal: float = 2.0  # CoM horizontal vs the LIP (ankle actuation) [1/s]
    lambda_swing: float = 20.0  # swing foot position and orientation [1/s]
    # K_D per leg joint: hip roll, hip yaw, hip pitch, knee, toe pitch, toe roll. Hip yaw 40
    # (was 20 until December 2026) halves the torso-yaw sway that alternates with the stance
    # foot; 60 and more slows the first turn from standing (docs/walking.md, "Gains").
    kd_leg: list[float] = dc.field(  # K_D: hip roll/yaw/pitch, knee, toe pitch/roll [N·m·s/rad]
        default_factory=lambda: [60.0, 40.0, 60.0, 60.0, 6.0, 6.0]
    )
    kd_arm: float = 20.0  # PD damping of the arms when held [N·m·s/rad]
    kp_arm: float = 200.0  # PD stiffness of the arms when held [N·m/rad]
    ankle_torque_fraction: float = 0.8  # stance toe torque bound, fraction of its limit
    # Rates (docs/rates.md, "Fast Digit"): the plant at 4 ms, the controller at every plant
    # step (250 Hz), the footstep planner at 50 Hz walk as the 1 ms / 1 kHz / 200 Hz stack
    # did (configs/walking_1ms.yaml) at ~3.5x its speed
    planner_period: float = 0.02  # ALIP footstep planner update [s] (50 Hz)
    controller_period: float = 0.004  # passivity controller [s]; = time_step: every step
    time_step: float = 0.004  # plant step [s]
    friction: float = 1.0  # ground friction coefficient
    arms: str = "welded"  # "welded" (fixed at the held pose) or "held" (PD-controlled)
    fall_height: float = 0.6  # torso origin below this is a fall [m]
    fall_check_period: float = 0.008  # the fall monitor's period [s] (125 Hz)


@dc.dataclass
class EmoNavConfig:
    """Everything configurable, grouped as in the paper."""

    robot: RobotParams = dc.field(default_factory=RobotParams)
    lidar: LidarParams = dc.field(default_factory=LidarParams)
    crowd: CrowdParams = dc.field(default_factory=CrowdParams)
    reward: RewardParams = dc.field(default_factory=RewardParams)
    episode: EpisodeParams = dc.field(default_factory=EpisodeParams)
    dwa: DwaParams = dc.field(default_factory=DwaParams)
    mpc: MpcParams = dc.field(default_factory=MpcParams)
    walking: WalkingParams = dc.field(default_factory=WalkingParams)
    perception: PerceptionParams = dc.field(default_factory=PerceptionParams)

    def validate(self) -> "EmoNavConfig":
        """Check every field against `_RANGES`; raise `ConfigError` naming the field."""
        validate_ranges(self, _RANGES)
        c = self.crowd
        require(
            c.min_pedestrians <= c.max_pedestrians,
            "crowd.min_pedestrians",
            c.min_pedestrians,
            f"<= crowd.max_pedestrians ({c.max_pedestrians})",
        )
        require(
            c.min_static <= c.max_static,
            "crowd.min_static",
            c.min_static,
            f"<= crowd.max_static ({c.max_static})",
        )
        require(
            c.static_radius_min <= c.static_radius_max,
            "crowd.static_radius_min",
            c.static_radius_min,
            "<= crowd.static_radius_max",
        )
        require(
            c.circle_radius_min <= c.circle_radius_max,
            "crowd.circle_radius_min",
            c.circle_radius_min,
            "<= crowd.circle_radius_max",
        )
        for name in ("static_x_range", "static_y_range"):
            lo, hi = getattr(c, name)
            require(lo <= hi, f"crowd.{name}", [lo, hi], "[low, high] with low <= high")
        require(
            abs(sum(c.emotion_probs) - 1.0) < 1e-6 and min(c.emotion_probs) >= 0,
            "crowd.emotion_probs",
            c.emotion_probs,
            "three non-negative values summing to 1",
        )
        li = self.lidar
        require(
            li.num_beams % li.grid_size == 0,
            "lidar.num_beams",
            li.num_beams,
            f"a multiple of lidar.grid_size ({li.grid_size})",
        )
        require(
            li.min_range < li.max_range,
            "lidar.min_range",
            li.min_range,
            f"< lidar.max_range ({li.max_range})",
        )
        family = self.crowd.family
        require(family in SCENARIO_FAMILIES, "crowd.family", family, f"one of {SCENARIO_FAMILIES}")
        source = self.perception.state_source
        require(source in STATE_SOURCES, "perception.state_source", source, '"truth" or "lidar"')
        w = self.walking
        require(w.arms in ("welded", "held"), "walking.arms", w.arms, '"welded" or "held"')
        require(
            w.lateral_step_min < w.lateral_step_max,
            "walking.lateral_step_min",
            w.lateral_step_min,
            "< walking.lateral_step_max",
        )
        steps_per_walk = self.robot.step_time / self.crowd.dt
        require(
            abs(steps_per_walk - round(steps_per_walk)) < 1e-9,
            "crowd.dt",
            c.dt,
            f"a divisor of robot.step_time ({self.robot.step_time})",
        )
        self._validate_walking()
        return self

    def _validate_walking(self) -> None:
        """Cross-field rules of the Digit walking stack (its rates are multiples)."""
        w = self.walking
        require(
            w.lateral_step_min < w.lateral_step_max,
            "walking.lateral_step_min",
            w.lateral_step_min,
            f"< walking.lateral_step_max ({w.lateral_step_max})",
        )
        for name in ("planner_period", "controller_period", "fall_check_period"):
            period = getattr(w, name)
            ratio = period / w.time_step
            require(
                ratio >= 1.0 - 1e-9 and abs(ratio - round(ratio)) < 1e-9,
                f"walking.{name}",
                period,
                f"a whole multiple of walking.time_step ({w.time_step})",
            )


def load_config(path: str | Path | None = None, data: str | None = None) -> EmoNavConfig:
    """The default configuration, overridden by a YAML file or string, validated."""
    if path is None and data is None:
        return EmoNavConfig().validate()
    cfg = load_typed_yaml(EmoNavConfig, path=path, data=data)
    try:
        return cfg.validate()
    except ConfigError as e:
        raise ConfigError(f"{path if path is not None else '<yaml>'}: {e}") from None


def dump_config(config: EmoNavConfig) -> str:
    """The configuration as YAML text (loadable by `load_config`)."""
    return dump_typed_yaml(config)
