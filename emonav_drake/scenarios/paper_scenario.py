"""The paper's scenario sampler (§IV-B) and its time-varying emotion schedule.

`sample_paper_scenario(seed, config)` draws the paper's arena with a seeded generator;
`scenarios/scenario.py::sample_scenario` calls it for the default family, "paper". The
placement helpers (`_sample_obstacles`, `_sample_pedestrians`) are shared with the other
families (`scenarios/scenario_families.py`).

World frame: x towards the robot's goal, y left, metres.
"""

import math

import numpy as np

from emonav_drake.params import EMOTION_NAMES, CrowdParams, EmoNavConfig
from emonav_drake.scenarios.scenario_spec import (
    MAX_SEED,
    PedestrianSpec,
    Scenario,
    ScenarioSamplingError,
    StaticDiscSpec,
)
from emonav_drake.typed_yaml import ConfigError

PLACEMENT_TRIES = 1000  # rejection-sampling draws per object


def add_time_varying_emotion(
    scenario: Scenario, seed: int, config: EmoNavConfig | None = None
) -> Scenario:
    """Give one pedestrian (chosen by `seed`) an emotion that changes every period (§IV-F).

    The same rule as `sample_scenario` in the time-varying mode, for a scenario from a
    file: the schedule covers `episode.max_steps` walking steps, every entry differs from
    the previous one. Raises `ConfigError` if the scenario has no pedestrian or already
    has a schedule.
    """
    cfg = config or EmoNavConfig()
    if not scenario.pedestrians:
        raise ConfigError("--time-varying: the scenario has no pedestrian whose emotion could vary")
    if any(p.emotion_schedule for p in scenario.pedestrians):
        raise ConfigError(
            "--time-varying: the scenario already has an emotion_schedule; remove the flag "
            "or the schedule"
        )
    _add_emotion_schedule(
        scenario.pedestrians, np.random.default_rng(seed), cfg, scenario.emotion_change_period
    )
    return scenario


def _add_emotion_schedule(
    pedestrians: list, rng: np.random.Generator, cfg: EmoNavConfig, period: float
) -> None:
    who = int(rng.integers(len(pedestrians)))
    horizon = cfg.episode.max_steps * cfg.robot.step_time
    n = int(math.ceil(horizon / period)) + 1
    current = EMOTION_NAMES.index(pedestrians[who].emotion)
    schedule = [EMOTION_NAMES[current]]
    for _ in range(n - 1):
        current = (current + int(rng.integers(1, 3))) % 3  # always a different one
        schedule.append(EMOTION_NAMES[current])
    pedestrians[who].emotion_schedule = schedule


def sample_paper_scenario(seed: int, config: EmoNavConfig | None = None) -> Scenario:
    """Draw the paper's random scenario (§IV-B) with a seeded generator.

    1–4 pedestrians start on a circle of radius U(3.5, 4.5) m around the origin and head
    for the antipodal point; 1–3 static discs of radius U(0.2, 0.4) m lie in
    x ∈ [−3, 3], y ∈ [−1.5, 1.5]; each pedestrian's emotion is drawn from
    `crowd.emotion_probs`. Rejection sampling keeps every pair of objects (including the
    robot at its start and goal) at least 0.2 m apart at the start, so no episode begins
    in collision. An object that finds no free spot in `PLACEMENT_TRIES` draws raises
    `ScenarioSamplingError` (a `ConfigError`): dropping it would silently sample another
    distribution than the configured counts (never the case with the paper's settings).
    In the time-varying mode, one pedestrian's emotion changes every
    `emotion_change_period` seconds to a different one, for the whole episode.
    The draws, in order: the static discs, the pedestrians, the emotion schedule.
    """
    if not 0 <= seed <= MAX_SEED:
        raise ConfigError(f"seed {seed}: must be in [0, 2**64 - 1]")
    cfg = config or EmoNavConfig()
    c, robot = cfg.crowd, cfg.robot
    rng = np.random.default_rng(seed)
    # Discs already placed: (x, y, radius); the robot at start and goal.
    placed: list[tuple[float, float, float]] = [
        (*robot.start, robot.radius),
        (*robot.goal, robot.radius),
    ]
    obstacles = _sample_obstacles(seed, rng, c, placed)
    pedestrians = _sample_pedestrians(seed, rng, c, placed)
    if c.time_varying_emotions and pedestrians:
        _add_emotion_schedule(pedestrians, rng, cfg, c.emotion_change_period)

    return Scenario(
        pedestrians=pedestrians,
        obstacles=obstacles,
        robot_start=list(robot.start),
        robot_goal=list(robot.goal),
        robot_heading=math.atan2(robot.goal[1] - robot.start[1], robot.goal[0] - robot.start[0]),
        emotion_change_period=c.emotion_change_period,
        seed=int(seed),
    )


_SAMPLING_GAP = 0.2  # [m] between any two sampled objects (and the robot) at the start


def _is_free(placed: list[tuple[float, float, float]], x: float, y: float, r: float) -> bool:
    """Whether a disc (x, y, r) keeps `_SAMPLING_GAP` from every disc in `placed`."""
    gap = _SAMPLING_GAP
    return all(math.hypot(x - px, y - py) >= r + pr + gap for px, py, pr in placed)


def _sample_obstacles(
    seed: int, rng: np.random.Generator, c: CrowdParams, placed: list[tuple[float, float, float]]
) -> list[StaticDiscSpec]:
    """The static discs of `sample_scenario` (crowd settings `c`), added to `placed`."""
    gap = _SAMPLING_GAP
    obstacles: list[StaticDiscSpec] = []
    wanted = int(rng.integers(c.min_static, c.max_static + 1))
    for _ in range(wanted):
        for _attempt in range(PLACEMENT_TRIES):
            r = float(rng.uniform(c.static_radius_min, c.static_radius_max))
            x = float(rng.uniform(*c.static_x_range))
            y = float(rng.uniform(*c.static_y_range))
            if _is_free(placed, x, y, r):
                placed.append((x, y, r))
                obstacles.append(StaticDiscSpec(center=[x, y], radius=r))
                break
        else:
            raise ScenarioSamplingError(
                f"seed {seed}: placed only {len(obstacles)} of {wanted} static discs: no free "
                f"spot in {PLACEMENT_TRIES} tries for a disc of radius in "
                f"[{c.static_radius_min}, {c.static_radius_max}] m inside crowd.static_x_range "
                f"{c.static_x_range} x crowd.static_y_range {c.static_y_range}, {gap} m clear "
                "of the robot's start and goal and of the other discs; enlarge the box or "
                "lower crowd.max_static / crowd.static_radius_max"
            )
    return obstacles


def _sample_pedestrians(
    seed: int, rng: np.random.Generator, c: CrowdParams, placed: list[tuple[float, float, float]]
) -> list[PedestrianSpec]:
    """The pedestrians of `sample_scenario` (crowd settings `c`): a start on the circle,
    the antipodal goal, an emotion; their starts and goals added to `placed`."""
    gap, r_ped = _SAMPLING_GAP, c.pedestrian_radius
    pedestrians: list[PedestrianSpec] = []
    probs = np.asarray(c.emotion_probs, dtype=float)
    wanted = int(rng.integers(c.min_pedestrians, c.max_pedestrians + 1))
    for _ in range(wanted):
        for _attempt in range(PLACEMENT_TRIES):
            radius = float(rng.uniform(c.circle_radius_min, c.circle_radius_max))
            angle = float(rng.uniform(0.0, 2.0 * math.pi))
            sx, sy = radius * math.cos(angle), radius * math.sin(angle)
            if _is_free(placed, sx, sy, r_ped) and _is_free(placed, -sx, -sy, r_ped):
                placed += [(sx, sy, r_ped), (-sx, -sy, r_ped)]
                emotion = EMOTION_NAMES[int(rng.choice(3, p=probs))]
                pedestrians.append(PedestrianSpec(start=[sx, sy], goal=[-sx, -sy], emotion=emotion))
                break
        else:
            raise ScenarioSamplingError(
                f"seed {seed}: placed only {len(pedestrians)} of {wanted} pedestrians: no free "
                f"start/goal pair in {PLACEMENT_TRIES} tries on the circle of radius in "
                f"[crowd.circle_radius_min {c.circle_radius_min}, crowd.circle_radius_max "
                f"{c.circle_radius_max}] m, {gap} m clear of the robot, the discs and the other "
                "pedestrians; widen the circle or lower crowd.max_pedestrians"
            )
    return pedestrians
