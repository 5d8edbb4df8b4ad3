"""One typed configuration for the whole project.

Every number of the paper's Table I and of the environment (docs/facts.md) lives
here, in plain dataclasses. Configurations load from YAML with Drake's typed loader
(`pydrake.common.yaml.yaml_load_typed`, which already rejects unknown fields) and are
then validated: a value outside its allowed range raises `ConfigError` naming the
dotted field path and the range.

Units are SI throughout (metres, seconds, radians).
"""

# No `from __future__ import annotations`: Drake's typed YAML loader needs real types.
import dataclasses as dc
import math
import typing
from pathlib import Path
from typing import Any

# Emotion codes used everywhere (crowd, grid maps, metrics).
HAPPY, NEUTRAL, NEGATIVE = 0, 1, 2
EMOTION_NAMES = ("happy", "neutral", "negative")


class ConfigError(ValueError):
    """A configuration or scenario value is invalid; the message names the field."""


def pendulum_frequency(height: float, gravity: float) -> float:
    """ω = √(g/H) [1/s] of a (angular-momentum) linear inverted pendulum of CoM height H [m]
    under gravity g [m/s²]: the LIP of the paper's Eq. 1 and Digit's ALIP alike."""
    return math.sqrt(gravity / height)


@dc.dataclass
class RobotParams:
    """The reduced-order (LIP) robot and its command bounds (paper Table I, Eq. 1–2)."""

    step_time: float = 0.4  # T, one walking step [s]
    com_height: float = 1.02  # H [m]
    gravity: float = 9.81  # g [m/s^2]
    radius: float = 0.3  # r_robot [m]
    max_speed: float = 0.4  # ū_v, sagittal speed bound [m/s]
    max_heading_change: float = 0.2  # ū_Δθ, heading change per step bound [rad]
    start: list[float] = dc.field(default_factory=lambda: [-4.0, 0.0])  # world [m]
    goal: list[float] = dc.field(default_factory=lambda: [4.0, 0.0])  # world [m]

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

    num_beams: int = NUM_BEAMS  # K, over 360°
    max_range: float = 6.0  # L [m]
    min_range: float = 0.27  # nearer hits are raised to this range [m]
    grid_size: int = 100  # M (rings × sectors for the LGM, cells per side for the OGM)
    num_frames: int = 9  # N, frames in the stack


@dc.dataclass
class CrowdParams:
    """Pedestrians (ORCA), static discs and scenario sampling (paper §IV-B)."""

    dt: float = 0.1  # pedestrian dynamics period [s] (10 Hz)
    pedestrian_radius: float = 0.3  # r_ped [m]
    preferred_speed: float = 1.0  # [m/s]
    min_pedestrians: int = 1
    max_pedestrians: int = 4
    min_static: int = 1
    max_static: int = 3
    static_radius_min: float = 0.2  # [m]
    static_radius_max: float = 0.4  # [m]
    circle_radius_min: float = 3.5  # pedestrians start on this circle [m]
    circle_radius_max: float = 4.5
    static_x_range: list[float] = dc.field(default_factory=lambda: [-3.0, 3.0])
    static_y_range: list[float] = dc.field(default_factory=lambda: [-1.5, 1.5])
    goal_tolerance: float = 0.1  # a pedestrian turns round within this of its goal [m]
    # ORCA (RVO2 semantics), the authors' settings.
    neighbor_dist: float = 10.0
    max_neighbors: int = 10
    time_horizon: float = 5.0
    time_horizon_obst: float = 5.0
    safety_space: float = 0.2  # added to every ORCA radius [m]
    # Emotions: probabilities of happy, neutral, negative at sampling time.
    emotion_probs: list[float] = dc.field(default_factory=lambda: [1 / 3, 1 / 3, 1 / 3])
    time_varying_emotions: bool = False  # one pedestrian's emotion changes periodically
    emotion_change_period: float = 2.0  # [s]


@dc.dataclass
class RewardParams:
    """Rewards, paper Eq. 6–9, and the discomfort distances of §III-C."""

    collision: float = -0.6
    discomfort: float = -0.1  # counted once per step
    goal: float = 0.5
    progress_gain: float = 0.3
    static_discomfort: float = 0.2  # d_static [m]
    happy_discomfort: float = 0.2  # [m]
    neutral_discomfort: float = 0.35  # [m]
    negative_discomfort: float = 0.5  # [m]

    def emotion_distances(self) -> tuple[float, float, float]:
        """Discomfort distance per emotion code (HAPPY, NEUTRAL, NEGATIVE) [m]."""
        return (self.happy_discomfort, self.neutral_discomfort, self.negative_discomfort)


@dc.dataclass
class EpisodeParams:
    """Episode rules (the authors' code): time limit, goal radii, discount."""

    max_steps: int = 125  # 50 s of 0.4 s steps
    goal_radius: float = 0.1  # d_goal, training [m]
    eval_goal_radius: float = 0.2  # evaluation [m]
    discount: float = 0.99  # γ


@dc.dataclass
class DwaParams:
    """Dynamic Window Approach on the LIP model (the paper's DWA baseline)."""

    speed_samples: int = 9
    heading_samples: int = 11
    horizon_steps: int = 5  # walking steps rolled out per candidate
    goal_weight: float = 1.0
    clearance_weight: float = 1.0
    discomfort_weight: float = 3.0
    speed_weight: float = 0.1
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
    guide_resolution: float = 0.1  # [m]
    guide_padding: float = 3.0  # grid margin around robot, goal and discs [m]
    guide_zone_cost: float = 3.0  # cost factor of cells inside a disc's discomfort zone
    # SCP and initial guess.
    trust_region: float = 0.12  # |u_Δθ − ū_Δθ| per SCP iteration [rad]
    seed_headings: int = 7  # seed headings: offsets spread over ±seed_max_offset
    seed_max_offset: float = 1.2  # [rad]
    previous_plan_bonus: float = 0.05  # hysteresis for the previous plan (relative cost)
    # Fallback and solver.
    fallback_speed_scale: float = 0.5  # fallback: u_v = this × current speed, keep heading
    osqp_eps: float = 1e-3  # absolute and relative tolerances (solutions are polished)
    osqp_max_iter: int = 400
    # OSQP's wall-clock limit per QP [s]: a safety only (a QP takes ~1 ms; the work is
    # bounded by osqp_max_iter); each time it fires the plan depends on the load, and the
    # planner counts it (time_limit_hits) and warns
    time_limit: float = 1.0


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
    lateral_step_min: float = 0.12  # lateral step clamp from the stance foot [m]
    lateral_step_max: float = 0.45
    max_step_length: float = 0.45  # sagittal step clamp from the stance foot [m]
    lambda_orientation: float = 12.0  # torso orientation [1/s]
    lambda_height: float = 10.0  # torso height [1/s]
    lambda_horizontal: float = 2.0  # CoM horizontal vs the LIP (ankle actuation) [1/s]
    lambda_swing: float = 20.0  # swing foot position and orientation [1/s]
    # K_D per leg joint: hip roll, hip yaw, hip pitch, knee, toe pitch, toe roll. Hip yaw 40
    # (was 20 until December 2026) halves the torso-yaw sway that alternates with the stance
    # foot; 60 and more slows the first turn from standing (docs/walking.md, "Gains").
    kd_leg: list[float] = dc.field(default_factory=lambda: [60.0, 40.0, 60.0, 60.0, 6.0, 6.0])
    kd_arm: float = 20.0  # arms held by PD when not welded [N·m·s/rad]
    kp_arm: float = 200.0  # [N·m/rad]
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

    def validate(self) -> "EmoNavConfig":
        """Check every field against `_RANGES`; raise `ConfigError` naming the field."""
        _validate_ranges(self, "", _RANGES)
        c = self.crowd
        _require(
            c.min_pedestrians <= c.max_pedestrians,
            "crowd.min_pedestrians",
            c.min_pedestrians,
            f"<= crowd.max_pedestrians ({c.max_pedestrians})",
        )
        _require(
            c.min_static <= c.max_static,
            "crowd.min_static",
            c.min_static,
            f"<= crowd.max_static ({c.max_static})",
        )
        _require(
            c.static_radius_min <= c.static_radius_max,
            "crowd.static_radius_min",
            c.static_radius_min,
            "<= crowd.static_radius_max",
        )
        _require(
            c.circle_radius_min <= c.circle_radius_max,
            "crowd.circle_radius_min",
            c.circle_radius_min,
            "<= crowd.circle_radius_max",
        )
        for name in ("static_x_range", "static_y_range"):
            lo, hi = getattr(c, name)
            _require(lo <= hi, f"crowd.{name}", [lo, hi], "[low, high] with low <= high")
        _require(
            abs(sum(c.emotion_probs) - 1.0) < 1e-6 and min(c.emotion_probs) >= 0,
            "crowd.emotion_probs",
            c.emotion_probs,
            "three non-negative values summing to 1",
        )
        li = self.lidar
        _require(
            li.num_beams % li.grid_size == 0,
            "lidar.num_beams",
            li.num_beams,
            f"a multiple of lidar.grid_size ({li.grid_size})",
        )
        _require(
            li.min_range < li.max_range,
            "lidar.min_range",
            li.min_range,
            f"< lidar.max_range ({li.max_range})",
        )
        w = self.walking
        _require(w.arms in ("welded", "held"), "walking.arms", w.arms, '"welded" or "held"')
        _require(
            w.lateral_step_min < w.lateral_step_max,
            "walking.lateral_step_min",
            w.lateral_step_min,
            "< walking.lateral_step_max",
        )
        steps_per_walk = self.robot.step_time / self.crowd.dt
        _require(
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
        _require(
            w.lateral_step_min < w.lateral_step_max,
            "walking.lateral_step_min",
            w.lateral_step_min,
            f"< walking.lateral_step_max ({w.lateral_step_max})",
        )
        for name in ("planner_period", "controller_period", "fall_check_period"):
            period = getattr(w, name)
            ratio = period / w.time_step
            _require(
                ratio >= 1.0 - 1e-9 and abs(ratio - round(ratio)) < 1e-9,
                f"walking.{name}",
                period,
                f"a whole multiple of walking.time_step ({w.time_step})",
            )


# Allowed ranges: (low, high) inclusive; list fields: (length, low, high) for each element.
_RANGES: dict[str, Any] = {
    "robot.step_time": (0.05, 2.0),
    "robot.com_height": (0.3, 2.0),
    "robot.gravity": (1.0, 20.0),
    "robot.radius": (0.05, 1.0),
    "robot.max_speed": (0.01, 2.0),
    "robot.max_heading_change": (0.01, math.pi / 2),
    "robot.start": (2, -50.0, 50.0),
    "robot.goal": (2, -50.0, 50.0),
    "lidar.num_beams": (4, 36000),
    "lidar.max_range": (0.5, 50.0),
    "lidar.min_range": (0.0, 5.0),
    "lidar.grid_size": (2, 1000),
    "lidar.num_frames": (1, 64),
    "crowd.dt": (0.01, 1.0),
    "crowd.pedestrian_radius": (0.05, 1.0),
    "crowd.preferred_speed": (0.0, 3.0),
    "crowd.min_pedestrians": (0, 20),
    "crowd.max_pedestrians": (0, 20),
    "crowd.min_static": (0, 20),
    "crowd.max_static": (0, 20),
    "crowd.static_radius_min": (0.05, 2.0),
    "crowd.static_radius_max": (0.05, 2.0),
    "crowd.circle_radius_min": (0.5, 20.0),
    "crowd.circle_radius_max": (0.5, 20.0),
    "crowd.static_x_range": (2, -20.0, 20.0),
    "crowd.static_y_range": (2, -20.0, 20.0),
    "crowd.goal_tolerance": (0.01, 2.0),
    "crowd.neighbor_dist": (0.1, 100.0),
    "crowd.max_neighbors": (0, 100),
    "crowd.time_horizon": (0.1, 30.0),
    "crowd.time_horizon_obst": (0.1, 30.0),
    "crowd.safety_space": (0.0, 1.0),
    "crowd.emotion_probs": (3, 0.0, 1.0),
    "crowd.emotion_change_period": (0.1, 100.0),
    "reward.static_discomfort": (0.0, 3.0),
    "reward.happy_discomfort": (0.0, 3.0),
    "reward.neutral_discomfort": (0.0, 3.0),
    "reward.negative_discomfort": (0.0, 3.0),
    "episode.max_steps": (1, 100000),
    "episode.goal_radius": (0.01, 2.0),
    "episode.eval_goal_radius": (0.01, 2.0),
    "episode.discount": (0.0, 1.0),
    "dwa.speed_samples": (2, 101),
    "dwa.heading_samples": (2, 101),
    "dwa.horizon_steps": (1, 50),
    "dwa.clearance_cap": (0.01, 10.0),
    "dwa.safety_margin": (0.0, 2.0),
    "dwa.hard_steps": (1, 50),
    "walking.step_width": (0.1, 0.5),
    "walking.clearance": (0.01, 0.3),
    "walking.touchdown_speed": (0.0, 1.0),
    "walking.early_touchdown": (0.5, 1.0),
    "walking.touchdown_tolerance": (0.0, 0.05),
    "walking.stand_com_lead": (-0.1, 0.1),
    "walking.speed_integral_limit": (0.0, 0.5),
    "walking.heading_blend_fraction": (0.1, 1.0),
    "walking.swing_yaw_blend_fraction": (0.1, 1.0),
    "walking.swing_finish_fraction": (0.3, 1.0),
    "walking.target_freeze_fraction": (0.1, 1.0),
    "walking.prediction_fraction": (0.0, 1.0),
    "walking.torso_height": (0.7, 1.1),
    "walking.torso_pitch": (-0.5, 0.5),
    "walking.stand_time": (0.0, 1.0e6),
    "walking.speed_integral_gain": (0.0, 1.0),
    "walking.lateral_step_min": (0.0, 0.5),
    "walking.lateral_step_max": (0.1, 1.0),
    "walking.max_step_length": (0.05, 1.0),
    "walking.lambda_orientation": (0.0, 200.0),
    "walking.lambda_height": (0.0, 200.0),
    "walking.lambda_horizontal": (0.0, 200.0),
    "walking.lambda_swing": (0.0, 200.0),
    "walking.kd_leg": (6, 0.0, 1000.0),
    "walking.kd_arm": (0.0, 1000.0),
    "walking.kp_arm": (0.0, 10000.0),
    "walking.ankle_torque_fraction": (0.0, 1.0),
    "walking.planner_period": (0.001, 0.1),
    "walking.controller_period": (0.0002, 0.02),
    "walking.time_step": (0.0002, 0.005),
    "walking.friction": (0.1, 2.0),
    "walking.fall_height": (0.2, 1.0),
    "walking.fall_check_period": (0.0002, 0.01),
    "mpc.horizon_steps": (2, 40),
    "mpc.scp_iterations": (1, 20),
    "mpc.goal_weight": (0.0, 1e4),
    "mpc.terminal_weight": (0.0, 1e4),
    "mpc.reference_lead": (0.0, 100.0),
    "mpc.guide_resolution": (0.01, 1.0),
    "mpc.guide_padding": (0.5, 50.0),
    "mpc.guide_zone_cost": (1.0, 100.0),
    "mpc.speed_smoothness_weight": (0.0, 1e4),
    "mpc.turn_smoothness_weight": (0.0, 1e4),
    "mpc.turn_weight": (0.0, 1e4),
    "mpc.discomfort_weight": (0.0, 1e6),
    "mpc.collision_weight": (0.0, 1e6),
    "mpc.slack_quadratic_weight": (1e-6, 1e4),
    "mpc.prediction_discount": (0.01, 1.0),
    "mpc.collision_margin": (0.0, 1.0),
    "mpc.discomfort_margin": (0.0, 1.0),
    "mpc.hard_pedestrian_steps": (0, 40),
    "mpc.trust_region": (0.01, math.pi),
    "mpc.seed_headings": (1, 41),
    "mpc.seed_max_offset": (0.0, math.pi),
    "mpc.previous_plan_bonus": (0.0, 1.0),
    "mpc.fallback_speed_scale": (0.0, 1.0),
    "mpc.osqp_eps": (1e-8, 1e-1),
    "mpc.osqp_max_iter": (10, 100000),
    "mpc.time_limit": (1e-4, 10.0),
}


def _require(ok: bool, field: str, value: Any, allowed: str) -> None:
    if not ok:
        raise ConfigError(f"{field} = {value!r} is invalid: must be {allowed}")


def _describe_range(lo: Any, hi: Any) -> str:
    if hi is None:
        return f">= {lo}"
    if lo is None:
        return f"<= {hi}"
    return f"in [{lo}, {hi}]"


def _validate_ranges(obj: Any, prefix: str, ranges: dict[str, Any]) -> None:
    """Check `obj`'s fields (recursively) against `ranges`.

    `ranges` maps a dotted field name to (low, high) inclusive — either bound may be None
    for "no bound" — or, for a list field, (length, low, high) for each element.
    """
    for f in dc.fields(obj):
        name = f"{prefix}{f.name}"
        value = getattr(obj, f.name)
        if dc.is_dataclass(value):
            _validate_ranges(value, name + ".", ranges)
            continue
        if isinstance(value, float) and not math.isfinite(value):
            raise ConfigError(f"{name} = {value!r} is invalid: must be a finite number")
        spec = ranges.get(name)
        if spec is None:
            continue
        if len(spec) == 3:
            length, lo, hi = spec
            if len(value) != length:
                raise ConfigError(f"{name} = {value!r} is invalid: must have {length} elements")
            for v in value:
                if not (math.isfinite(v) and lo <= v <= hi):
                    raise ConfigError(
                        f"{name} = {value!r} is out of range: each element in [{lo}, {hi}]"
                    )
        else:
            lo, hi = spec
            if (lo is not None and not lo <= value) or (hi is not None and not value <= hi):
                raise ConfigError(
                    f"{name} = {value!r} is out of range: allowed {_describe_range(lo, hi)}"
                )


def validate_ranges(obj: Any, ranges: dict[str, Any], prefix: str = "") -> None:
    """Public form of the range check (used by the training configurations)."""
    _validate_ranges(obj, prefix, ranges)


def required_fields(schema: type) -> tuple[str, ...]:
    """Fields a YAML mapping for `schema` must give (class attribute `_REQUIRED`)."""
    return tuple(getattr(schema, "_REQUIRED", ()))


_TYPE_NAMES = {float: "a number", int: "an integer", bool: "true or false", str: "a string"}


def _check_scalar(name: str, value: Any, kind: type) -> None:
    """Mirror Drake's primitive conversions; raise `ConfigError` naming the field."""
    ok = False
    if kind is bool:
        ok = isinstance(value, bool) or value in ("true", "false")
    elif kind is str:
        ok = isinstance(value, str)
    elif kind in (int, float) and not isinstance(value, bool):
        if isinstance(value, int):
            ok = True
        elif isinstance(value, float):
            ok = kind is float or value.is_integer()
        elif isinstance(value, str):
            try:
                kind(value)
                ok = True
            except ValueError:
                ok = False
    if not ok:
        raise ConfigError(f"{name} = {value!r} is invalid: expected {_TYPE_NAMES[kind]}")


def _check_yaml_value(name: str, value: Any, kind: Any) -> None:
    origin = typing.get_origin(kind)
    if dc.is_dataclass(kind):
        _check_yaml_mapping(kind, value, name)
    elif origin is list:
        (item,) = typing.get_args(kind)
        if not isinstance(value, list):
            raise ConfigError(f"{name} = {value!r} is invalid: expected a list")
        for i, v in enumerate(value):
            _check_yaml_value(f"{name}[{i}]", v, item)
    elif kind in _TYPE_NAMES:
        _check_scalar(name, value, kind)


def _check_yaml_mapping(schema: type, data: Any, prefix: str) -> None:
    """Types, unknown fields and required fields of raw YAML data against a dataclass."""
    what = prefix or schema.__name__
    if not isinstance(data, dict):
        raise ConfigError(
            f"{what} = {data!r} is invalid: expected a mapping of {schema.__name__} fields"
        )
    fields = {f.name: f for f in dc.fields(schema)}
    dot = f"{prefix}." if prefix else ""
    for key, value in data.items():
        if key not in fields:
            raise ConfigError(
                f"{dot}{key}: unknown field; {schema.__name__} has {', '.join(fields)}"
            )
        _check_yaml_value(f"{dot}{key}", value, fields[key].type)
    missing = [k for k in required_fields(schema) if k not in data]
    if missing:
        raise ConfigError(
            f"{dot}{missing[0]}: required field missing ({schema.__name__} needs "
            f"{', '.join(required_fields(schema))})"
        )


def _yaml_error_line(e: Exception) -> str:
    mark = getattr(e, "problem_mark", None)
    problem = getattr(e, "problem", None) or str(e).splitlines()[0]
    if mark is not None:
        return f"invalid YAML at line {mark.line + 1}, column {mark.column + 1}: {problem}"
    return f"invalid YAML: {problem}"


def load_typed_yaml_raw(
    schema: type, path: str | Path | None = None, data: str | None = None, defaults: Any = None
) -> tuple[Any, dict]:
    """`load_typed_yaml` that also returns the raw mapping (to see which fields were given)."""
    from pydrake.common.yaml import yaml_load_data, yaml_load_typed

    if (path is None) == (data is None):
        raise ValueError("give exactly one of path or data")
    if path is not None:
        path = Path(path)
        if path.is_dir():
            raise ConfigError(f"{path}: is a directory, expected a YAML file")
        if not path.is_file():
            raise ConfigError(f"{path}: no such file")
        try:
            data = path.read_text()
        except UnicodeDecodeError:
            raise ConfigError(f"{path}: not a text (YAML) file") from None
    where = str(path) if path is not None else "<yaml>"
    try:
        raw = yaml_load_data(data)
    except Exception as e:  # yaml syntax errors come from the yaml parser
        raise ConfigError(f"{where}: {_yaml_error_line(e)}") from None
    if raw is None:
        raise ConfigError(
            f"{where}: the file is empty; expected a YAML mapping of {schema.__name__} fields"
        )
    try:
        _check_yaml_mapping(schema, raw, "")
    except ConfigError as e:
        raise ConfigError(f"{where}: {e}") from None
    try:
        obj = yaml_load_typed(
            schema=schema, data=data, defaults=defaults if defaults is not None else schema()
        )
    except (RuntimeError, TypeError, ValueError) as e:
        raise ConfigError(f"{where}: {e}") from None
    except Exception as e:
        raise ConfigError(f"{where}: not valid YAML for {schema.__name__}: {e}") from None
    return obj, raw


def load_typed_yaml(
    schema: type, path: str | Path | None = None, data: str | None = None, defaults: Any = None
) -> Any:
    """Load a dataclass from YAML with Drake's typed loader, re-raising as `ConfigError`.

    Exactly one of `path` or `data` is given. Fields absent from the YAML keep `defaults`,
    except the schema's required fields (`_REQUIRED`). Before Drake's loader runs, the raw
    data is checked against the schema so that an empty file, an unknown field, a wrong
    type or a missing required field is reported with the dotted field name.
    """
    return load_typed_yaml_raw(schema, path=path, data=data, defaults=defaults)[0]


def load_config(path: str | Path | None = None, data: str | None = None) -> EmoNavConfig:
    """The default configuration, overridden by a YAML file or string, validated."""
    if path is None and data is None:
        return EmoNavConfig().validate()
    cfg = load_typed_yaml(EmoNavConfig, path=path, data=data)
    try:
        return cfg.validate()
    except ConfigError as e:
        raise ConfigError(f"{path if path is not None else '<yaml>'}: {e}") from None


def dump_typed_yaml(obj: Any) -> str:
    """A dataclass as YAML text (loadable by `load_typed_yaml`)."""
    from pydrake.common.yaml import yaml_dump_typed

    return yaml_dump_typed(obj)


def dump_config(config: EmoNavConfig) -> str:
    """The configuration as YAML text (loadable by `load_config`)."""
    return dump_typed_yaml(config)
