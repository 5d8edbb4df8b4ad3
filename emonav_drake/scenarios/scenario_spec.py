"""The scenario as data: what fixes everything random about one episode, validated.

A `Scenario` holds the pedestrians (start, goal, emotion; optionally an emotion schedule,
a speed of its own, waypoints, standing, a delayed start, a group), the static discs,
the walls (line segments) and the robot's start and goal. Scenarios load from YAML
(`load_scenario`), with every field validated: a pedestrian needs `start`, `goal` and
`emotion`, an obstacle `center` and `radius`, a wall `start` and `end` (no silent
defaults); the robot's start and goal must be clear of every obstacle and wall, its start
clear of every pedestrian's and its goal farther than the goal radius from its start;
pedestrians must not start overlapping each other nor start, pass or head for a spot
inside an obstacle or on a wall; at most `MAX_PEDESTRIANS` pedestrians, `MAX_OBSTACLES`
obstacles and `MAX_WALLS` walls, and a file's emotion schedules at most `MAX_SCHEDULE`
entries (refused before the typed load). Every field declares its doc, unit and range
(`config_fields.setting`), the configuration's range where a scenario holds the same
quantity (a point of the world, the emotion change period). The samplers are in
`paper_scenario.py` and `scenario_families.py` beside this module; `scenario.py` gathers
all.

World frame: x towards the robot's goal, y left, metres.
"""

# No `from __future__ import annotations`: Drake's typed YAML loader needs real types.
import dataclasses as dc
import math
from pathlib import Path

import numpy as np

from emonav_drake.config_fields import SEED_RANGE, WORLD_POINT, field_range, setting
from emonav_drake.params import EMOTION_NAMES, CrowdParams, EmoNavConfig
from emonav_drake.typed_yaml import (
    ConfigError,
    dump_typed_yaml,
    load_typed_yaml_raw,
    short_repr,
    validate_fields,
)

# The most a scenario may hold: what the sampler can be configured to draw
# (crowd.max_pedestrians, crowd.max_static <= 20); the crowd's ORCA step is quadratic in it.
MAX_PEDESTRIANS = 20
MAX_OBSTACLES = 20
MAX_WAYPOINTS = 50  # per pedestrian
AT_GOAL = ("return", "stand")  # what a pedestrian does at its goal
MAX_WALLS = 40  # a corridor, a room with a door, a maze of a few cells
MIN_WALL_LENGTH = 0.01  # [m]: a shorter segment is a point, not a wall
# The most entries an emotion schedule in a file may hold, checked before the typed load
# (parsing a million took 63 s): at the default period of 2 s an episode of 20 000 s, at
# the shortest (crowd.emotion_change_period >= 0.1 s) 1000 s; the paper's 50 s episodes
# need 26. The crowd holds the last entry beyond the schedule.
MAX_SCHEDULE = 10_000
# Seeds are 64-bit unsigned integers: a larger one would alias a smaller one (the episode's
# step-response generator takes `seed % 2**64`).
MAX_SEED = SEED_RANGE[1]
MAX_GROUPS = 20  # group numbers 0 … 20 (a scenario holds at most 20 pedestrians)


class ScenarioSamplingError(ConfigError):
    """The configured crowd does not fit: an object found no free spot (the message says which)."""


@dc.dataclass
class PedestrianSpec:
    """One pedestrian: walks start → waypoints → goal and back … at its preferred speed (ORCA).

    The paper's pedestrian sets only start, goal and emotion: it walks start → goal →
    start … at the crowd's preferred speed. The other fields make the scenes of the
    scenario families: a speed of its own, a route through waypoints, standing at the
    goal for good or for a while at each end, a delayed start, and walking in a group.
    """

    start: list[float] = setting([0.0, 4.0], "where it starts, world x, y", "m", WORLD_POINT)
    goal: list[float] = setting([0.0, -4.0], "its goal, world x, y", "m", WORLD_POINT)
    emotion: str = setting("neutral", "happy | neutral | negative")
    emotion_schedule: list[str] = setting(
        [],
        "time-varying mode: emotion_schedule[i] holds during [i·period, (i+1)·period); "
        "empty: the emotion is constant",
    )
    # 1.0 m/s is the paper's "high walking speed".
    speed: float | None = setting(
        None,
        "preferred (and ORCA maximum) speed; None: the crowd's `preferred_speed`",
        "m/s",
        (0.05, 2.0),
    )
    waypoints: list[list[float]] = setting(
        [],
        "points [x, y] walked through between start and goal, in order (and reversed on the "
        "way back)",
        "m",
        (None, *WORLD_POINT[1:]),
    )
    at_goal: str = setting(
        "return",
        'at the goal: "return" walks the route back (and so on), "stand" stops there for good',
    )
    stand_time: float = setting(
        0.0, "standing at each end of the route before turning round", "s", (0.0, 1000.0)
    )
    start_delay: float = setting(0.0, "standing at the start before walking", "s", (0.0, 1000.0))
    group: int = setting(
        -1,
        "pedestrians with the same group number (>= 0) walk as a group: the first of them in "
        "the list leads (its route, speed and behaviour), the others keep their start offset "
        "from the leader (world frame) while avoiding; their goals and routes are not used",
        "",
        (-1, MAX_GROUPS),
    )

    _REQUIRED = ("start", "goal", "emotion")  # in YAML (no annotation: not a field)
    _MAX_ITEMS = {  # in YAML, before the typed load
        "emotion_schedule": MAX_SCHEDULE,
        "waypoints": MAX_WAYPOINTS,
    }


@dc.dataclass
class StaticDiscSpec:
    """A static obstacle: a disc in the world frame."""

    center: list[float] = setting([0.0, 0.0], "its centre, world x, y", "m", WORLD_POINT)
    # A hand-placed disc may be larger than the sampler's (`crowd.static_radius_max`).
    radius: float = setting(0.3, "its radius", "m", (0.01, 5.0))
    appears_at: float = setting(
        0.0,
        "when it is put in place (a cart left in a doorway): before, it is not there for "
        "anyone (crowd, sensors, collisions, the route's map)",
        "s",
        (0.0, 1000.0),
    )

    _REQUIRED = ("center", "radius")  # in YAML (no annotation: not a field)


@dc.dataclass
class WallSpec:
    """A wall: the line segment start → end in the world frame, of no thickness.

    Seen by the LiDAR, respected by the pedestrians (an ORCA obstacle, as RVO2's
    two-vertex obstacles) and a collision for the robot (its disc must not touch it).
    """

    start: list[float] = setting([0.0, 0.0], "one end, world x, y", "m", WORLD_POINT)
    end: list[float] = setting([1.0, 0.0], "the other end, world x, y", "m", WORLD_POINT)

    _REQUIRED = ("start", "end")  # in YAML (no annotation: not a field)


@dc.dataclass
class Scenario:
    """Everything random about one episode."""

    pedestrians: list[PedestrianSpec] = setting([], "the pedestrians (`PedestrianSpec`)")
    obstacles: list[StaticDiscSpec] = setting([], "the static discs (`StaticDiscSpec`)")
    walls: list[WallSpec] = setting([], "the walls, line segments (`WallSpec`)")
    robot_start: list[float] = setting(
        [-4.0, 0.0], "the robot's start, world x, y", "m", field_range(EmoNavConfig, "robot.start")
    )
    robot_goal: list[float] = setting(
        [4.0, 0.0], "the robot's goal, world x, y", "m", field_range(EmoNavConfig, "robot.goal")
    )
    robot_heading: float = setting(
        0.0, "the robot's initial heading", "rad", (-2 * math.pi, 2 * math.pi)
    )
    emotion_change_period: float = setting(
        2.0,
        "period of the emotion schedules' changes (used when a schedule is present)",
        "s",
        field_range(CrowdParams, "emotion_change_period"),
    )
    seed: int = setting(
        -1, "the seed it was sampled with, −1 when written by hand", "", (-1, MAX_SEED)
    )

    _MAX_ITEMS = {  # in YAML
        "pedestrians": MAX_PEDESTRIANS,
        "obstacles": MAX_OBSTACLES,
        "walls": MAX_WALLS,
    }

    def wall_segments(self) -> np.ndarray:
        """The walls as (W, 2, 2) segments [m, world]: wall k from [k, 0] to [k, 1]."""
        return np.array([[w.start, w.end] for w in self.walls], dtype=float).reshape(-1, 2, 2)

    def validate(
        self, robot_radius: float = 0.3, pedestrian_radius: float = 0.3, goal_radius: float = 0.2
    ) -> "Scenario":
        """Raise `ConfigError` naming the field if any value is invalid.

        Besides ranges and counts (at most `MAX_PEDESTRIANS` pedestrians and
        `MAX_OBSTACLES` obstacles): the robot's start and goal must be clear of every
        obstacle (the robot's disc of `robot_radius` must not overlap it: a start inside
        one is an instant collision, a goal inside one a certain timeout), its goal
        farther than `goal_radius` from its start, and it must not start overlapping a
        pedestrian's start (disc of `pedestrian_radius`). Pedestrians must not start
        overlapping each other, and their starts and goals must be clear of every obstacle.
        The checks run in this order (the first failing one is reported): the scenario's
        own values, the pedestrians' and obstacles' values, the robot's placement, the
        pedestrians' placement.
        """
        self._check_own_values()
        self._check_item_values()
        self._check_robot_placement(robot_radius, goal_radius)
        self._check_pedestrian_placement(robot_radius, pedestrian_radius)
        return self

    def _check_own_values(self) -> None:
        """The counts, the seed, the robot's start, goal and heading, the emotion period."""
        if len(self.pedestrians) > MAX_PEDESTRIANS:
            raise ConfigError(
                f"pedestrians: {len(self.pedestrians)} given, at most {MAX_PEDESTRIANS} allowed"
            )
        if len(self.obstacles) > MAX_OBSTACLES:
            raise ConfigError(
                f"obstacles: {len(self.obstacles)} given, at most {MAX_OBSTACLES} allowed"
            )
        if len(self.walls) > MAX_WALLS:
            raise ConfigError(f"walls: {len(self.walls)} given, at most {MAX_WALLS} allowed")
        if not (self.seed == -1 or 0 <= self.seed <= MAX_SEED):
            raise ConfigError(
                f"seed = {self.seed!r} is invalid: must be -1 (written by hand) or in "
                "[0, 2**64 - 1]"
            )
        validate_fields(self)

    def _check_item_values(self) -> None:
        """Each pedestrian's values, route and emotions; each obstacle's and wall's values."""
        for i, p in enumerate(self.pedestrians):
            validate_fields(p, f"pedestrians[{i}].")
            _check_route(p, f"pedestrians[{i}].")
            for j, e in enumerate([p.emotion, *p.emotion_schedule]):
                if e not in EMOTION_NAMES:
                    where = "emotion" if j == 0 else f"emotion_schedule[{j - 1}]"
                    raise ConfigError(
                        f"pedestrians[{i}].{where} = {short_repr(e)} is invalid: "
                        f"must be one of {list(EMOTION_NAMES)}"
                    )
        for i, o in enumerate(self.obstacles):
            validate_fields(o, f"obstacles[{i}].")
        for i, w in enumerate(self.walls):
            validate_fields(w, f"walls[{i}].")
            if math.dist(w.start, w.end) < MIN_WALL_LENGTH:
                raise ConfigError(
                    f"walls[{i}]: start {w.start!r} and end {w.end!r} are "
                    f"{math.dist(w.start, w.end):.3g} m apart; a wall must be at least "
                    f"{MIN_WALL_LENGTH} m long"
                )

    def _check_robot_placement(self, robot_radius: float, goal_radius: float) -> None:
        """The robot's start and goal clear of every obstacle, its goal not within
        `goal_radius` of its start."""
        for name in ("robot_start", "robot_goal"):
            point = getattr(self, name)
            for i, o in enumerate(self.obstacles):
                gap = math.dist(point, o.center) - o.radius - robot_radius
                if gap < 0:
                    raise ConfigError(
                        f"{name} = {point!r} is inside obstacles[{i}] (center {o.center!r}, "
                        f"radius {o.radius}): the robot (radius {robot_radius} m) must stand "
                        f"clear of it ({-gap:.2f} m overlap)"
                    )
            for i, w in enumerate(self.walls):
                gap = point_segment_distance(point, w.start, w.end) - robot_radius
                if gap < 0:
                    raise ConfigError(
                        f"{name} = {point!r} touches walls[{i}] ({w.start!r} → {w.end!r}): "
                        f"the robot (radius {robot_radius} m) must stand clear of it "
                        f"({-gap:.2f} m overlap)"
                    )
        if math.dist(self.robot_start, self.robot_goal) <= goal_radius:
            raise ConfigError(
                f"robot_goal = {self.robot_goal!r} is within the goal radius ({goal_radius} m) "
                f"of robot_start = {self.robot_start!r}: there would be nothing to navigate"
            )

    def _check_pedestrian_placement(self, robot_radius: float, pedestrian_radius: float) -> None:
        """Per pedestrian, in order: its start clear of the robot's start and of the earlier
        pedestrians' starts, its start and goal clear of every obstacle."""
        for i, p in enumerate(self.pedestrians):
            gap = math.dist(self.robot_start, p.start) - pedestrian_radius - robot_radius
            if gap < 0:
                raise ConfigError(
                    f"robot_start = {self.robot_start!r} overlaps pedestrians[{i}].start "
                    f"= {p.start!r}: the episode would begin in collision"
                )
            for j, q in enumerate(self.pedestrians[:i]):
                if math.dist(p.start, q.start) < 2 * pedestrian_radius:
                    raise ConfigError(
                        f"pedestrians[{i}].start = {p.start!r} overlaps pedestrians[{j}].start "
                        f"= {q.start!r}: pedestrians (radius {pedestrian_radius} m) must start "
                        f"at least {2 * pedestrian_radius:g} m apart"
                    )
            points = [("start", p.start), ("goal", p.goal)]
            points += [(f"waypoints[{k}]", w) for k, w in enumerate(p.waypoints)]
            for where, point in points:
                for k, o in enumerate(self.obstacles):
                    if math.dist(point, o.center) < o.radius + pedestrian_radius:
                        raise ConfigError(
                            f"pedestrians[{i}].{where} = {point!r} is inside obstacles[{k}] "
                            f"(center {o.center!r}, radius {o.radius}): the pedestrian (radius "
                            f"{pedestrian_radius} m) must stand clear of it"
                        )
                for k, w in enumerate(self.walls):
                    if point_segment_distance(point, w.start, w.end) < pedestrian_radius:
                        raise ConfigError(
                            f"pedestrians[{i}].{where} = {point!r} touches walls[{k}] "
                            f"({w.start!r} → {w.end!r}): the pedestrian (radius "
                            f"{pedestrian_radius} m) must stand clear of it"
                        )


def _check_route(p: PedestrianSpec, prefix: str) -> None:
    """A pedestrian's waypoints are points [x, y] (their range: the field's); its
    `at_goal` is one of `AT_GOAL`."""
    for k, w in enumerate(p.waypoints):
        if len(w) != 2:
            raise ConfigError(
                f"{prefix}waypoints[{k}] = {short_repr(w)} is invalid: must be a point [x, y]"
            )
    if p.at_goal not in AT_GOAL:
        raise ConfigError(
            f"{prefix}at_goal = {short_repr(p.at_goal)} is invalid: must be one of {list(AT_GOAL)}"
        )


def discs_in_place(appear_times: np.ndarray, t: float) -> np.ndarray:
    """(S,) whether each static disc is in place at time `t` [s], from their
    `StaticDiscSpec.appears_at` times [s] (a disc appears at its time, to the ns)."""
    return np.asarray(appear_times, dtype=float) <= t + 1e-9


def point_segment_distance(point: list[float], a: list[float], b: list[float]) -> float:
    """Distance [m] from `point` to the segment a → b (all world [m])."""
    (px, py), (ax, ay), (bx, by) = point, a, b
    dx, dy = bx - ax, by - ay
    length2 = dx * dx + dy * dy
    t = 0.0 if length2 == 0 else min(1.0, max(0.0, ((px - ax) * dx + (py - ay) * dy) / length2))
    return math.hypot(px - ax - t * dx, py - ay - t * dy)


def load_scenario(path: str | Path, config: EmoNavConfig | None = None) -> Scenario:
    """A scenario from a YAML file (fields as in `Scenario`), validated.

    Absent top-level fields take the documented defaults (no obstacles, no pedestrians,
    the paper's start (−4, 0) and goal (4, 0)); `robot_heading`, if absent, faces the
    goal. Inside `pedestrians` and `obstacles` every field but `emotion_schedule` is
    required. `config` gives the robot's and pedestrians' radii for the overlap checks and
    the goal radius (the larger of training's and evaluation's) for the start–goal check.
    """
    cfg = config or EmoNavConfig()
    scenario, raw = load_typed_yaml_raw(Scenario, path=path)
    if "robot_heading" not in raw:
        (sx, sy), (gx, gy) = scenario.robot_start, scenario.robot_goal
        scenario.robot_heading = math.atan2(gy - sy, gx - sx) if (sx, sy) != (gx, gy) else 0.0
    try:
        goal_radius = max(cfg.episode.goal_radius, cfg.episode.eval_goal_radius)
        return scenario.validate(cfg.robot.radius, cfg.crowd.pedestrian_radius, goal_radius)
    except ConfigError as e:
        raise ConfigError(f"{path}: {e}") from None


def dump_scenario(scenario: Scenario) -> str:
    """The scenario as YAML text (loadable by `load_scenario`)."""
    return dump_typed_yaml(scenario)
