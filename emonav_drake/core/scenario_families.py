"""Named scenario families: seeded samplers of scenes beyond the paper's arena.

`paper` is the paper's distribution (`core/paper_scenario.py`, §IV-B): 1–4
pedestrians crossing a circle of radius 3.5–4.5 m at 1 m/s, 1–3 static discs. The other
families follow the scenario set of Francis et al. (2025, "Principles and guidelines for
evaluating social robot navigation algorithms") as implemented by social-jym — circle
crossing, parallel and perpendicular traffic, robot crowding, delayed crossing, crossing
with static obstacles, corner traffic — the paper's hardware cases (a blocker who steps
into the robot's path and stands, a group walking towards the robot, an all-dynamic
crowd), a corridor with a head-on pedestrian, dense crowds and fast pedestrians.

Each family draws from its own random stream: the generator of seed `s` in family `f` is
`numpy.random.default_rng([crc32(f), s])`, so the same seed gives the same scene, and
two families' seeds are independent. Every scene is validated (`Scenario.validate`: no
overlap at the start) and its robot goal is checked reachable past the static geometry
(`goal_reachable`); a draw that fails either is redrawn (at most `SCENE_TRIES` times).
Emotions are drawn from `crowd.emotion_probs` as in the paper.

World frame: x towards the robot's goal (the robot walks (−4, 0) → (4, 0) except in
`corner_traffic`), y left, metres, seconds, m/s.
"""

from __future__ import annotations

import dataclasses as dc
import math
import zlib
from collections.abc import Callable
from typing import NamedTuple

import numpy as np

from emonav_drake.core.paper_scenario import (
    _sample_obstacles,
    _sample_pedestrians,
    sample_paper_scenario,
)
from emonav_drake.core.scenario_spec import (
    MAX_SEED,
    PedestrianSpec,
    Scenario,
    ScenarioSamplingError,
    WallSpec,
)
from emonav_drake.params import EMOTION_NAMES, SCENARIO_FAMILIES, EmoNavConfig
from emonav_drake.typed_yaml import ConfigError

SCENE_TRIES = 200  # whole-scene draws before a family gives up on a seed
REACH_CELL = 0.1  # [m] grid cell of the reachability check


class Family(NamedTuple):
    """A scenario family: its name, one line on what it tests, and its sampler."""

    name: str
    summary: str
    draw: Callable[[np.random.Generator, EmoNavConfig], Scenario]


def _emotion(rng: np.random.Generator, cfg: EmoNavConfig) -> str:
    return EMOTION_NAMES[int(rng.choice(3, p=np.asarray(cfg.crowd.emotion_probs, dtype=float)))]


def _arena(cfg: EmoNavConfig, **kw: object) -> Scenario:
    """A scene with the configured robot start and goal, facing the goal."""
    start, goal = list(cfg.robot.start), list(cfg.robot.goal)
    heading = math.atan2(goal[1] - start[1], goal[0] - start[0])
    return Scenario(
        robot_start=start,
        robot_goal=goal,
        robot_heading=heading,
        emotion_change_period=cfg.crowd.emotion_change_period,
        **kw,
    )


def _circle(
    rng: np.random.Generator,
    cfg: EmoNavConfig,
    pedestrians: int,
    static: int = 0,
    static_box: tuple[float, float] | None = None,
) -> Scenario:
    """The paper's circle crossing with fixed counts (and optionally a larger disc box)."""
    c = dc.replace(
        cfg.crowd,
        min_pedestrians=pedestrians,
        max_pedestrians=pedestrians,
        min_static=static,
        max_static=static,
    )
    if static_box is not None:
        c.static_x_range = [-static_box[0], static_box[0]]
        c.static_y_range = [-static_box[1], static_box[1]]
    r = cfg.robot
    placed = [(*r.start, r.radius), (*r.goal, r.radius)]
    obstacles = _sample_obstacles(-1, rng, c, placed)
    peds = _sample_pedestrians(-1, rng, c, placed)
    return _arena(cfg, pedestrians=peds, obstacles=obstacles)


def _paper(rng: np.random.Generator, cfg: EmoNavConfig) -> Scenario:
    raise AssertionError("the paper family samples with core.scenario.sample_scenario")


def _parallel(rng: np.random.Generator, cfg: EmoNavConfig) -> Scenario:
    """Six pedestrians in lanes along the robot's path, half towards it, half with it."""
    peds = []
    for k in range(6):
        y = float(rng.uniform(-2.0, 2.0))
        if k % 2 == 0:  # towards the robot
            start, goal = [float(rng.uniform(2.5, 4.5)), y], [-4.5, y]
        else:  # the robot's way, ahead of it
            start, goal = [float(rng.uniform(-3.0, 0.0)), y], [4.5, y]
        peds.append(PedestrianSpec(start=start, goal=goal, emotion=_emotion(rng, cfg)))
    return _arena(cfg, pedestrians=peds)


def _perpendicular(rng: np.random.Generator, cfg: EmoNavConfig) -> Scenario:
    """Six pedestrians crossing the robot's path at right angles, from both sides."""
    peds = []
    for k in range(6):
        x = float(rng.uniform(-2.5, 2.5))
        side = 1.0 if k % 2 == 0 else -1.0
        y0 = side * float(rng.uniform(3.0, 4.5))
        peds.append(PedestrianSpec(start=[x, y0], goal=[x, -y0], emotion=_emotion(rng, cfg)))
    return _arena(cfg, pedestrians=peds)


def _crowding(rng: np.random.Generator, cfg: EmoNavConfig) -> Scenario:
    """Five pedestrians converge on the robot's path and stand there."""
    peds: list[PedestrianSpec] = []
    for _ in range(1000):  # 5 goals 0.8 m apart in 5 x 1.2 m: found in a few draws
        if len(peds) == 5:
            break
        angle = float(rng.uniform(0.0, 2.0 * math.pi))
        radius = float(rng.uniform(3.0, 4.5))
        goal = [float(rng.uniform(-2.5, 2.5)), float(rng.uniform(-0.6, 0.6))]
        start = [radius * math.cos(angle), radius * math.sin(angle)]
        if any(math.dist(goal, p.goal) < 0.8 for p in peds):  # room to stand side by side
            continue
        peds.append(
            PedestrianSpec(start=start, goal=goal, emotion=_emotion(rng, cfg), at_goal="stand")
        )
    return _arena(cfg, pedestrians=peds)


def _delayed(rng: np.random.Generator, cfg: EmoNavConfig) -> Scenario:
    """Circle crossing of five, each leaving after its own delay of 0–8 s."""
    scene = _circle(rng, cfg, pedestrians=5)
    for p in scene.pedestrians:
        p.start_delay = round(float(rng.uniform(0.0, 8.0)), 1)
    return scene


def _corner(rng: np.random.Generator, cfg: EmoNavConfig) -> Scenario:
    """An L-shaped corridor 2 m wide: the robot turns left round the corner while two or
    three pedestrians come the other way round it."""
    walls = [
        WallSpec(start=[-5.0, -1.0], end=[1.0, -1.0]),
        WallSpec(start=[1.0, -1.0], end=[1.0, 5.0]),
        WallSpec(start=[-5.0, 1.0], end=[-1.0, 1.0]),
        WallSpec(start=[-1.0, 1.0], end=[-1.0, 5.0]),
    ]
    peds = []
    for k in range(int(rng.integers(2, 4))):
        start = [float(rng.uniform(-0.5, 0.5)), 4.5 - 0.8 * k]
        via = [float(rng.uniform(-0.4, 0.4)), float(rng.uniform(-0.4, 0.4))]
        goal = [float(rng.uniform(-4.5, -3.0)), float(rng.uniform(-0.5, 0.5))]
        peds.append(
            PedestrianSpec(start=start, goal=goal, waypoints=[via], emotion=_emotion(rng, cfg))
        )
    start, goal = [-4.0, 0.0], [0.0, 4.0]
    return Scenario(
        pedestrians=peds,
        walls=walls,
        robot_start=start,
        robot_goal=goal,
        robot_heading=0.0,
        emotion_change_period=cfg.crowd.emotion_change_period,
    )


def _blocker(rng: np.random.Generator, cfg: EmoNavConfig) -> Scenario:
    """A pedestrian steps into the robot's path and stands; one or two others cross."""
    scene = _circle(rng, cfg, pedestrians=int(rng.integers(1, 3)))
    side = 1.0 if rng.random() < 0.5 else -1.0
    x = float(rng.uniform(-1.0, 1.0))
    blocker = PedestrianSpec(
        start=[x, side * float(rng.uniform(2.5, 3.5))],
        goal=[x, float(rng.uniform(-0.3, 0.3))],
        emotion=_emotion(rng, cfg),
        at_goal="stand",
    )
    scene.pedestrians.insert(0, blocker)
    return scene


def _group(rng: np.random.Generator, cfg: EmoNavConfig) -> Scenario:
    """A group of three walks towards the robot side by side (a leader and two beside it)."""
    y = float(rng.uniform(-0.6, 0.6))
    x = float(rng.uniform(3.0, 4.0))
    gap = float(rng.uniform(0.7, 0.9))
    peds = [
        PedestrianSpec(start=[x, y], goal=[-4.5, y], emotion=_emotion(rng, cfg), group=0),
        PedestrianSpec(start=[x, y + gap], goal=[-4.5, y], emotion=_emotion(rng, cfg), group=0),
        PedestrianSpec(start=[x, y - gap], goal=[-4.5, y], emotion=_emotion(rng, cfg), group=0),
    ]
    return _arena(cfg, pedestrians=peds)


def _corridor(rng: np.random.Generator, cfg: EmoNavConfig) -> Scenario:
    """A corridor 2.5 m wide and 6 m long; one pedestrian walks it head-on."""
    walls = [
        WallSpec(start=[-3.0, 1.25], end=[3.0, 1.25]),
        WallSpec(start=[-3.0, -1.25], end=[3.0, -1.25]),
    ]
    ped = PedestrianSpec(
        start=[float(rng.uniform(3.0, 4.0)), float(rng.uniform(-0.4, 0.4))],
        goal=[float(rng.uniform(-4.5, -3.5)), float(rng.uniform(-0.4, 0.4))],
        emotion=_emotion(rng, cfg),
    )
    return _arena(cfg, pedestrians=[ped], walls=walls)


def _fast(rng: np.random.Generator, cfg: EmoNavConfig) -> Scenario:
    """The paper's crowd, but every pedestrian walks at 1.3–1.6 m/s."""
    c = cfg.crowd
    scene = _circle(
        rng,
        cfg,
        pedestrians=int(rng.integers(c.min_pedestrians, c.max_pedestrians + 1)),
        static=int(rng.integers(c.min_static, c.max_static + 1)),
    )
    for p in scene.pedestrians:
        p.speed = round(float(rng.uniform(1.3, 1.6)), 2)
    return scene


MIXED_PAPER_SHARE = 0.5  # the paper's arena in the mixed family (for training)


def _mixed(rng: np.random.Generator, cfg: EmoNavConfig) -> Scenario:
    """A training distribution that includes the families: the paper's arena with
    probability `MIXED_PAPER_SHARE`, else one of the other families, uniformly. Every
    draw comes from the mixed family's own stream, so no scene of it is an evaluation
    scene of another family (nor a paper seed below 2**63)."""
    others = [n for n in FAMILIES if n not in ("paper", "mixed")]
    if rng.random() < MIXED_PAPER_SHARE:
        return sample_paper_scenario(int(rng.integers(2**63)), cfg)
    return FAMILIES[others[int(rng.integers(len(others)))]].draw(rng, cfg)


FAMILIES: dict[str, Family] = {
    f.name: f
    for f in [
        Family("paper", "the paper's arena: 1-4 pedestrians crossing a circle, 1-3 discs", _paper),
        Family(
            "circle_crossing",
            "5 pedestrians crossing a circle, no discs",
            lambda rng, cfg: _circle(rng, cfg, 5),
        ),
        Family("parallel_traffic", "6 pedestrians in lanes along the path, both ways", _parallel),
        Family(
            "perpendicular_traffic",
            "6 pedestrians crossing the path at right angles",
            _perpendicular,
        ),
        Family("robot_crowding", "5 pedestrians converge on the path and stand", _crowding),
        Family("delayed_crossing", "circle crossing of 5, each leaving after 0-8 s", _delayed),
        Family(
            "crossing_with_obstacles",
            "circle crossing of 4 among 5 discs in a 6 x 4 m box",
            lambda rng, cfg: _circle(rng, cfg, pedestrians=4, static=5, static_box=(3.0, 2.0)),
        ),
        Family("corner_traffic", "an L-shaped corridor, 2-3 pedestrians round the corner", _corner),
        Family("blocker", "one pedestrian steps into the path and stands; 1-2 cross", _blocker),
        Family("group_approach", "a group of 3 walks towards the robot side by side", _group),
        Family(
            "all_dynamic",
            "4 pedestrians crossing a circle, no static obstacle",
            lambda rng, cfg: _circle(rng, cfg, pedestrians=4),
        ),
        Family("corridor_head_on", "a 2.5 m corridor, one pedestrian head-on", _corridor),
        Family("dense_8", "8 pedestrians crossing a circle", lambda rng, cfg: _circle(rng, cfg, 8)),
        Family(
            "dense_12", "12 pedestrians crossing a circle", lambda rng, cfg: _circle(rng, cfg, 12)
        ),
        Family(
            "dense_20", "20 pedestrians crossing a circle", lambda rng, cfg: _circle(rng, cfg, 20)
        ),
        Family("fast_pedestrians", "the paper's crowd at 1.3-1.6 m/s", _fast),
        Family("mixed", "for training: the paper's arena half the time, else any family", _mixed),
    ]
}

assert tuple(FAMILIES) == SCENARIO_FAMILIES, "params.SCENARIO_FAMILIES lists the families"


def sample_family(name: str, seed: int, config: EmoNavConfig | None = None) -> Scenario:
    """The scene of `seed` in family `name`, validated and with a reachable goal.

    `paper` is `core/paper_scenario.py::sample_paper_scenario` (the paper's seeds,
    unchanged). Raises `ConfigError` for an unknown family, `ScenarioSamplingError` if
    `SCENE_TRIES` draws gave no valid scene.
    """
    cfg = config or EmoNavConfig()
    if name not in FAMILIES:
        raise ConfigError(f"scenario family {name!r} is unknown: one of {list(FAMILIES)}")
    if name == "paper":
        return sample_paper_scenario(seed, cfg)
    if not 0 <= seed <= MAX_SEED:
        raise ConfigError(f"seed {seed}: must be in [0, 2**64 - 1]")
    rng = np.random.default_rng([zlib.crc32(name.encode()), seed])
    goal_radius = max(cfg.episode.goal_radius, cfg.episode.eval_goal_radius)
    why = ""
    for _ in range(SCENE_TRIES):
        try:
            scene = FAMILIES[name].draw(rng, cfg)
            scene.seed = int(seed)
            scene.validate(cfg.robot.radius, cfg.crowd.pedestrian_radius, goal_radius)
        except ConfigError as e:  # a sampling failure or an overlap: draw again
            why = str(e)
            continue
        if goal_reachable(scene, cfg.robot.radius):
            return scene
        why = "the robot's goal is walled off"
    raise ScenarioSamplingError(
        f"family {name}, seed {seed}: no valid scene in {SCENE_TRIES} draws (last: {why})"
    )


def goal_reachable(scene: Scenario, robot_radius: float) -> bool:
    """Whether the robot's disc can travel from its start to its goal past the static
    discs and walls (pedestrians ignored): a breadth-first search on a `REACH_CELL` grid
    over the scene's bounding box (2 m margin), cells closer than `robot_radius` to a
    disc or wall blocked."""
    points = [scene.robot_start, scene.robot_goal]
    points += [w.start for w in scene.walls] + [w.end for w in scene.walls]
    points += [o.center for o in scene.obstacles]
    lo = np.min(points, axis=0) - 2.0
    hi = np.max(points, axis=0) + 2.0
    nx, ny = (np.ceil((hi - lo) / REACH_CELL).astype(int) + 1).tolist()
    gx, gy = np.meshgrid(lo[0] + REACH_CELL * np.arange(nx), lo[1] + REACH_CELL * np.arange(ny))
    free = np.ones_like(gx, dtype=bool)
    for o in scene.obstacles:
        free &= np.hypot(gx - o.center[0], gy - o.center[1]) >= o.radius + robot_radius
    for w in scene.walls:
        free &= _segment_distance_grid(gx, gy, w) >= robot_radius

    def cell(p: list[float]) -> tuple[int, int]:
        return int(round((p[1] - lo[1]) / REACH_CELL)), int(round((p[0] - lo[0]) / REACH_CELL))

    start, goal = cell(scene.robot_start), cell(scene.robot_goal)
    free[start] = free[goal] = True  # validated clear; the grid may round next to a wall
    seen = np.zeros_like(free)
    seen[start] = True
    frontier = [start]
    while frontier:
        nxt = []
        for i, j in frontier:
            for a, b in ((i + 1, j), (i - 1, j), (i, j + 1), (i, j - 1)):
                if (
                    0 <= a < free.shape[0]
                    and 0 <= b < free.shape[1]
                    and free[a, b]
                    and not seen[a, b]
                ):
                    seen[a, b] = True
                    nxt.append((a, b))
        frontier = nxt
    return bool(seen[goal])


def _segment_distance_grid(gx: np.ndarray, gy: np.ndarray, wall: WallSpec) -> np.ndarray:
    """Distance [m] of every grid point to the wall segment."""
    (ax, ay), (bx, by) = wall.start, wall.end
    dx, dy = bx - ax, by - ay
    t = np.clip(((gx - ax) * dx + (gy - ay) * dy) / (dx * dx + dy * dy), 0.0, 1.0)
    return np.hypot(gx - ax - t * dx, gy - ay - t * dy)
