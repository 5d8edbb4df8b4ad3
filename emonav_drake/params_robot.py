"""The robot's sections of the configuration: the LIP robot, its LiDAR and the LiDAR's
sensor model, what it perceives of the crowd, and the full-order Digit walking stack.

Part of `EmoNavConfig` (`params.py`, which re-exports every name here). Each field gives
its default, doc, unit and allowed range (`config_fields.setting`). Units are SI
throughout (metres, seconds, radians), but the sensor model's angles, in degrees as
datasheets give them (`*_deg`).
"""

# No `from __future__ import annotations`: Drake's typed YAML loader needs real types.
import dataclasses as dc
import math

from emonav_drake.config_fields import SEED_RANGE, WORLD_POINT, setting

# Digit's leg joints, hip to ankle: the order of `walking.kd_leg` and of each leg's indices
LEG_JOINT_NAMES = ("hip_roll", "hip_yaw", "hip_pitch", "knee", "toe_pitch", "toe_roll")


def pendulum_frequency(height: float, gravity: float) -> float:
    """ω = √(g/H) [1/s] of a (angular-momentum) linear inverted pendulum of CoM height H [m]
    under gravity g [m/s²]: the LIP of the paper's Eq. 1 and Digit's ALIP alike."""
    return math.sqrt(gravity / height)


@dc.dataclass
class RobotParams:
    """The reduced-order (LIP) robot and its command bounds (paper Table I, Eq. 1–2)."""

    step_time: float = setting(0.4, "T, one walking step", "s", (0.05, 2.0))
    com_height: float = setting(1.02, "H, centre-of-mass height of the LIP", "m", (0.3, 2.0))
    gravity: float = setting(9.81, "g, gravitational acceleration", "m/s^2", (1.0, 20.0))
    radius: float = setting(0.3, "r_robot, collision radius", "m", (0.05, 1.0))
    max_speed: float = setting(0.4, "ū_v, sagittal speed bound", "m/s", (0.01, 2.0))
    max_heading_change: float = setting(
        0.2, "ū_Δθ, heading change per step bound", "rad", (0.01, math.pi / 2)
    )
    start: list[float] = setting([-4.0, 0.0], "start, world x, y", "m", WORLD_POINT)
    goal: list[float] = setting([4.0, 0.0], "goal, world x, y", "m", WORLD_POINT)

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

    num_beams: int = setting(NUM_BEAMS, "K, beams over 360°", "", (4, 36000))
    max_range: float = setting(6.0, "L, maximum range", "m", (0.5, 50.0))
    min_range: float = setting(0.27, "nearer hits are raised to this range", "m", (0.0, 5.0))
    grid_size: int = setting(
        100, "M (rings × sectors for the LGM, cells per side for the OGM)", "", (2, 1000)
    )
    num_frames: int = setting(9, "N, frames in the stack", "", (1, 64))


# Where the model-based planners' crowd state comes from (`PerceptionParams.state_source`).
STATE_SOURCES = ("truth", "lidar")
# Whom the grid maps' discomfort rings go round (`PerceptionParams.map_rings`).
MAP_RINGS = ("truth", "tracks")


@dc.dataclass
class PerceptionParams:
    """What the robot knows of the crowd (docs/perception.md, "Perceived state").

    The learned policies read the LiDAR grid maps in either case; `state_source` decides
    what the state-based planners (DWA, MPC, SARL, RGL) read: "truth", the simulator's
    exact crowd (privileged: every pedestrian, also hidden ones), or "lidar", the
    pedestrians and obstacles detected in the 1800-beam scan and tracked at the scan's
    rate (`sensing/lidar_objects.py`, `sensing/crowd_tracker.py`): what a robot can run.
    """

    state_source: str = setting("truth", '"truth" (the simulator\'s crowd) or "lidar" (tracked)')
    still_duration: float = setting(
        2.0,
        'with "lidar": a track slower than 0.1 m/s for this long is reported as a static '
        "obstacle (before that, as a pedestrian at rest: a static disc too, in its first "
        "seconds; docs/perception.md)",
        "s",
        (0.1, 60.0),
    )
    map_rings: str = setting(
        "truth",
        'whom the grid maps\' discomfort rings (their inflated layer) go round: "truth", the '
        'simulator\'s pedestrians with their emotions, or "tracks", the pedestrians the LiDAR '
        'tracker finds with the emotions associated with them (needs state_source "lidar"; '
        "the camera's emotions per track always ring the tracks). The real scan is the "
        "world's either way",
    )


# How the LiDAR sees a pedestrian (`SensorParams.people_as`).
PEOPLE_AS = ("disc", "legs")


@dc.dataclass
class SensorParams:
    """The LiDAR as a real sensor: resolution, field of view and faults (docs/perception.md).

    A named `preset` gives every field but the seed; a configuration file may override
    single fields (`sensor: {preset: vlp16, range_noise_std: 0.05}`: the preset, then the
    fields given). The default, "ideal", is the exact scan of the paper's simulator: with
    its values the scan and the maps are computed by the exact code path, bit for bit.
    The faults act on the real scan (the maps' 255 layer, the `scan` port the tracker
    reads, the "scan" observation), never on the inflated (discomfort) scan.
    """

    preset: str = setting(
        "ideal",
        "the sensor the other fields start from: ideal (the exact scan), vlp16 (Velodyne "
        "VLP-16 at 10 Hz, Digit's head LiDAR) or ust10lx (a Hokuyo UST-10LX-class planar "
        "scanner)",
    )
    seed: int = setting(
        0,
        "seed of the sensor's noise; each scan draws from (seed, the scenario's seed, the "
        "scan's time in ms)",
        "",
        SEED_RANGE,
    )
    people_as: str = setting(
        "disc",
        '"disc" (a pedestrian is one disc of crowd.pedestrian_radius) or "legs" (two leg '
        "discs that swing with the gait, crowd/pedestrian_legs.py); only the real scan",
    )
    angular_resolution_deg: float = setting(
        0.0,
        "angle between the sensor's beams (0: the grid's own lidar.num_beams beams); each "
        "grid beam reads the nearest sensor beam",
        "deg",
        (0.0, 10.0),
    )
    field_of_view_deg: float = setting(
        360.0, "horizontal field of view, centred on the heading", "deg", (1.0, 360.0)
    )
    rated_range: float = setting(
        100.0,
        "the datasheet's maximum range; far_dropout is the dropout probability there",
        "m",
        (0.5, 1000.0),
    )
    range_noise_std: float = setting(
        0.0, "σ of the Gaussian range noise of a return", "m", (0.0, 1.0)
    )
    range_bias: float = setting(
        0.0, "mean range error of a return (+: reads long)", "m", (-0.5, 0.5)
    )
    range_resolution: float = setting(
        0.0, "ranges are rounded to multiples of this (0: not quantised)", "m", (0.0, 0.5)
    )
    dropout_rate: float = setting(
        0.0, "probability a return is lost at normal incidence, near the sensor", "", (0.0, 1.0)
    )
    grazing_dropout: float = setting(
        0.0,
        "extra loss probability at grazing incidence; at incidence angle a it is this·(1 − cos a)²",
        "",
        (0.0, 1.0),
    )
    far_dropout: float = setting(
        0.0,
        "extra loss probability at the rated range; at range r it is this·(r / rated_range)²",
        "",
        (0.0, 1.0),
    )
    mixed_pixel_rate: float = setting(
        0.0,
        "probability a beam at a range jump (an object's edge) returns a range between the "
        "two surfaces",
        "",
        (0.0, 1.0),
    )
    spurious_rate: float = setting(
        0.0,
        "probability a beam returns a random short range (dust, crosstalk), uniform between "
        "lidar.min_range and its true range",
        "",
        (0.0, 1.0),
    )

    def is_exact(self) -> bool:
        """True when nothing differs from the exact scan: full circle at the grid's beams,
        pedestrians as discs, no fault. The scan is then computed by the exact code path."""
        return (
            self.people_as == "disc"
            and self.angular_resolution_deg == 0.0
            and self.field_of_view_deg == 360.0
            and all(getattr(self, name) == 0.0 for name in SENSOR_FAULTS)
        )


# The fields that a preset gives and that make a scan differ from the exact one.
SENSOR_FAULTS = (
    "range_noise_std",
    "range_bias",
    "range_resolution",
    "dropout_rate",
    "grazing_dropout",
    "far_dropout",
    "mixed_pixel_rate",
    "spurious_rate",
)

# The named sensors: every field of `SensorParams` but `preset` and `seed`. The datasheet
# figures and the reasons of the modelling choices: docs/perception.md, "The LiDAR as a
# sensor". Range error: the datasheet's accuracy ±a is read as |bias| + 2σ = a, split as
# bias a/4 and σ 3a/8.
SENSOR_PRESETS: dict[str, dict[str, object]] = {
    "ideal": {
        "people_as": "disc",
        "angular_resolution_deg": 0.0,
        "field_of_view_deg": 360.0,
        "rated_range": 100.0,
        "range_noise_std": 0.0,
        "range_bias": 0.0,
        "range_resolution": 0.0,
        "dropout_rate": 0.0,
        "grazing_dropout": 0.0,
        "far_dropout": 0.0,
        "mixed_pixel_rate": 0.0,
        "spurious_rate": 0.0,
    },
    "vlp16": {  # Velodyne VLP-16 at 10 Hz: ±3 cm, 0.2°, 360°, 100 m, 2 mm packets
        "people_as": "legs",
        "angular_resolution_deg": 0.2,
        "field_of_view_deg": 360.0,
        "rated_range": 100.0,
        "range_noise_std": 0.01125,
        "range_bias": 0.0075,
        "range_resolution": 0.002,
        "dropout_rate": 0.01,
        "grazing_dropout": 0.5,
        "far_dropout": 0.1,
        "mixed_pixel_rate": 0.3,
        "spurious_rate": 0.001,
    },
    "ust10lx": {  # Hokuyo UST-10LX class: ±40 mm, 0.25°, 270°, 10 m, 1 mm
        "people_as": "legs",
        "angular_resolution_deg": 0.25,
        "field_of_view_deg": 270.0,
        "rated_range": 10.0,
        "range_noise_std": 0.015,
        "range_bias": 0.01,
        "range_resolution": 0.001,
        "dropout_rate": 0.005,
        "grazing_dropout": 0.5,
        "far_dropout": 0.1,
        "mixed_pixel_rate": 0.3,
        "spurious_rate": 0.0005,
    },
}
SENSOR_NAMES = tuple(SENSOR_PRESETS)


def sensor_preset(name: str, seed: int = 0) -> SensorParams:
    """The `SensorParams` of the preset `name` (`KeyError` if unknown), with `seed`."""
    return SensorParams(preset=name, seed=seed, **SENSOR_PRESETS[name])


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

    step_width: float = setting(0.22, "W, lateral distance between the feet", "m", (0.1, 0.5))
    clearance: float = setting(0.08, "swing-foot apex above the ground", "m", (0.01, 0.3))
    touchdown_speed: float = setting(
        0.2, "swing foot vertical speed at touchdown", "m/s", (0.0, 1.0)
    )
    early_touchdown: float = setting(
        0.9, "a touchdown is accepted after this fraction of T", "", (0.5, 1.0)
    )
    touchdown_tolerance: float = setting(
        0.002, "swing sole this close to the ground = touchdown", "m", (0.0, 0.05)
    )
    torso_height: float = setting(1.0, "torso origin above the ground", "m", (0.7, 1.1))
    torso_pitch: float = setting(0.0, "torso pitch target (+ leans forward)", "rad", (-0.5, 0.5))
    stand_time: float = setting(0.4, "double support before the first step", "s", (0.0, 1.0e6))
    stand_com_lead: float = setting(
        0.02, "standing CoM target ahead of the feet's midpoint", "m", (-0.1, 0.1)
    )
    speed_integral_gain: float = setting(
        0.3, "per-step integrator on the speed error", "", (0.0, 1.0)
    )
    speed_integral_limit: float = setting(0.15, "bound of that integrator", "m/s", (0.0, 0.5))
    heading_blend_fraction: float = setting(
        0.6, "torso heading reaches its target at this·T", "", (0.1, 1.0)
    )
    swing_yaw_blend_fraction: float = setting(
        0.8, "swing foot yaw reaches its target at this·T", "", (0.1, 1.0)
    )
    swing_finish_fraction: float = setting(
        0.85, "swing foot reaches its target (horizontally) at this·T", "", (0.3, 1.0)
    )
    target_freeze_fraction: float = setting(
        0.8, "the swing target is frozen after this·T", "", (0.1, 1.0)
    )
    prediction_fraction: float = setting(
        0.5, "the logged ALIP end-of-step prediction is made at this·T", "", (0.0, 1.0)
    )
    lateral_step_min: float = setting(
        0.12, "lateral step clamp from the stance foot: lower", "m", (0.0, 0.5)
    )
    lateral_step_max: float = setting(
        0.45, "lateral step clamp from the stance foot: upper", "m", (0.1, 1.0)
    )
    max_step_length: float = setting(
        0.45, "sagittal step clamp from the stance foot", "m", (0.05, 1.0)
    )
    lambda_orientation: float = setting(
        12.0, "Λ, error decay rate of the torso orientation", "1/s", (0.0, 200.0)
    )
    lambda_height: float = setting(
        10.0, "Λ, error decay rate of the torso height", "1/s", (0.0, 200.0)
    )
    lambda_horizontal: float = setting(
        2.0,
        "Λ, error decay rate of the CoM horizontal vs the LIP (ankle actuation)",
        "1/s",
        (0.0, 200.0),
    )
    lambda_swing: float = setting(
        20.0, "Λ, error decay rate of the swing foot position and orientation", "1/s", (0.0, 200.0)
    )
    # Hip yaw 40 (was 20 until December 2026) halves the torso-yaw sway that alternates with
    # the stance foot; 60 and more slows the first turn from standing (docs/walking.md, "Gains").
    kd_leg: list[float] = setting(
        [60.0, 40.0, 60.0, 60.0, 6.0, 6.0],
        "K_D per leg joint: hip roll, hip yaw, hip pitch, knee, toe pitch, toe roll",
        "N·m·s/rad",
        (6, 0.0, 1000.0),
    )
    # Hip yaws and knees damped by the contact solver (docs/rates.md, "Digit at 10 ms"): the
    # explicit K_D of those joints is what kept the plant step at 4 ms
    implicit_damping: list[str] = setting(
        ["hip_yaw", "knee"],
        "leg joints (hip_roll, hip_yaw, hip_pitch, knee, toe_pitch, toe_roll) whose K_D "
        "damping the contact solver applies implicitly, at the end of its step, as the "
        "actuator's PD controller (proportional gain 0); the others' K_D s is in the "
        "controller's torque ([]: all explicit)",
    )
    kd_arm: float = setting(20.0, "PD damping of the arms when held", "N·m·s/rad", (0.0, 1000.0))
    kp_arm: float = setting(200.0, "PD stiffness of the arms when held", "N·m/rad", (0.0, 10000.0))
    ankle_torque_fraction: float = setting(
        0.8, "stance toe torque bound, fraction of its limit", "", (0.0, 1.0)
    )
    # Rates (docs/rates.md, "Digit at 10 ms"): the plant and the controller at 10 ms with the
    # solver's implicit damping above, the footstep planner at 50 Hz, walk as the 4 ms stack
    # did (x/y tracking within 2 %) at ~1.8x its speed; the 4 ms stack is
    # configs/walking_4ms.yaml, the 1 ms / 1 kHz / 200 Hz one configs/walking_1ms.yaml
    planner_period: float = setting(0.02, "ALIP footstep planner update (50 Hz)", "s", (0.001, 0.1))
    controller_period: float = setting(
        0.01, "passivity controller period; = time_step: every step", "s", (0.0002, 0.02)
    )
    time_step: float = setting(0.01, "plant step", "s", (0.0002, 0.01))
    friction: float = setting(1.0, "ground friction coefficient", "", (0.1, 2.0))
    arms: str = setting("welded", '"welded" (fixed at the held pose) or "held" (PD-controlled)')
    fall_height: float = setting(0.6, "torso origin below this is a fall", "m", (0.2, 1.0))
    fall_check_period: float = setting(
        0.01, "the fall monitor's period (100 Hz)", "s", (0.0002, 0.02)
    )
