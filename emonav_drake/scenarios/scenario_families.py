"""Named scenario families: seeded samplers of scenes beyond the paper's arena.

`paper` is the paper's distribution (`scenarios/paper_scenario.py`, §IV-B): 1–4
pedestrians crossing a circle of radius 3.5–4.5 m at 1 m/s, 1–3 static discs. The other
families follow the scenario set of Francis et al. (2025, "Principles and guidelines for
evaluating social robot navigation algorithms") as implemented by social-jym — circle
crossing, parallel and perpendicular traffic, robot crowding, delayed crossing, crossing
with static obstacles, corner traffic — the paper's hardware cases (a blocker who steps
into the robot's path and stands, a group walking towards the robot, an all-dynamic
crowd), a corridor with a head-on pedestrian, dense crowds and fast pedestrians, and three
buildings whose goal is out of sight of the start: a T-junction of corridors
(`t_junction`), two rooms joined by one door (`doorway`) and an office floor of three
rooms off a corridor (`office`). In the buildings every pedestrian walks a route
(`scenarios/global_route.py::plan_route`, waypoints) round the walls and through the doors,
planned with its radius plus `PED_ROUTE_MARGIN`.

Each family draws from its own random stream: the generator of seed `s` in family `f` is
`numpy.random.default_rng([crc32(f), s])`, so the same seed gives the same scene, and
two families' seeds are independent. Every scene is validated (`Scenario.validate`: no
overlap at the start) and its robot goal is checked reachable past the static geometry
(`goal_reachable`); a draw that fails either is redrawn (at most `SCENE_TRIES` times).
Emotions are drawn from `crowd.emotion_probs` as in the paper.

World frame: x towards the robot's goal (the robot walks (−4, 0) → (4, 0) except in
`corner_traffic` and the buildings, whose starts and goals are drawn inside them), y left,
metres, seconds, m/s.
"""

from __future__ import annotations

import dataclasses as dc
import math
import zlib
from collections.abc import Callable
from typing import NamedTuple

import numpy as np

from emonav_drake.params import EMOTION_NAMES, SCENARIO_FAMILIES, EmoNavConfig
from emonav_drake.scenarios.global_route import NoRouteError, StaticMap, plan_route
from emonav_drake.scenarios.paper_scenario import (
    _sample_obstacles,
    _sample_pedestrians,
    sample_paper_scenario,
)
from emonav_drake.scenarios.scenario_spec import (
    MAX_SEED,
    PedestrianSpec,
    Scenario,
    ScenarioSamplingError,
    WallSpec,
)
from emonav_drake.typed_yaml import ConfigError

SCENE_TRIES = 200  # whole-scene draws before a family gives up on a seed
REACH_CELL = 0.1  # [m] grid cell of the reachability check
PED_ROUTE_MARGIN = 0.1  # [m] a building's pedestrian routes keep its ORCA radius + this off walls
DOOR_VIA = (0.8, 0.8)  # [m] a pedestrian's route passes this far before, behind a door's middle
DOORWAY_DOOR = (1.2, 1.5)  # [m] the width of the door of `doorway`: bounds
OFFICE_DOOR = (1.2, 1.3)  # [m] the width of the doors of `office`: bounds
INSET = 0.7  # [m] starts and goals in a building keep this far from its walls
SPOT_TRIES = 100  # draws of a free spot before a building scene is drawn again


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
    raise AssertionError("the paper family samples with scenarios.scenario.sample_scenario")


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


# ------------------------------------------------------------------------------ buildings


def _chain(*points: tuple[float, float]) -> list[WallSpec]:
    """Walls along the polyline through `points` (world [m])."""
    return [
        WallSpec(start=[float(a[0]), float(a[1])], end=[float(b[0]), float(b[1])])
        for a, b in zip(points[:-1], points[1:], strict=True)
    ]


Box = tuple[float, float, float, float]  # x_min, x_max, y_min, y_max, world [m]


def _in_box(rng: np.random.Generator, box: Box, inset: float = INSET) -> list[float]:
    """A uniform point of `box` shrunk by `inset` on every side (world [m])."""
    x0, x1, y0, y1 = box
    return [float(rng.uniform(x0 + inset, x1 - inset)), float(rng.uniform(y0 + inset, y1 - inset))]


def _spot(rng: np.random.Generator, box: Box, taken: list[list[float]], gap: float) -> list[float]:
    """A point of `box` (`INSET` inside it) at least `gap` [m] from every point in `taken`,
    which it joins; `ScenarioSamplingError` after `SPOT_TRIES` draws (the scene is drawn
    again)."""
    for _ in range(SPOT_TRIES):
        p = _in_box(rng, box)
        if all(math.dist(p, q) >= gap for q in taken):
            taken.append(p)
            return p
    raise ScenarioSamplingError(f"no spot {gap:g} m clear of {len(taken)} others")


def _crosses(a: list[float], b: list[float], walls: list[WallSpec]) -> bool:
    """Whether the segment a → b (world [m]) crosses or touches a wall."""

    def side(p: list[float], q: list[float], r: list[float]) -> float:
        return (q[0] - p[0]) * (r[1] - p[1]) - (q[1] - p[1]) * (r[0] - p[0])

    for w in walls:
        d1, d2 = side(w.start, w.end, a), side(w.start, w.end, b)
        d3, d4 = side(a, b, w.start), side(a, b, w.end)
        if d1 * d2 <= 0 and d3 * d4 <= 0:
            return True
    return False


class Door(NamedTuple):
    """A door: the middle of its opening and the unit normal of its wall (world [m])."""

    middle: tuple[float, float]
    normal: tuple[float, float]

    def through(self, coming_from: list[float]) -> list[list[float]]:
        """The two points `DOOR_VIA` before and behind the door on its axis, the one on the
        side of `coming_from` first: a route through them crosses the door head-on."""
        (mx, my), (nx, ny) = self.middle, self.normal
        side = 1.0 if (coming_from[0] - mx) * nx + (coming_from[1] - my) * ny >= 0 else -1.0
        before, behind = DOOR_VIA
        return [[mx + s * d * nx, my + s * d * ny] for s, d in ((side, before), (-side, behind))]


def _walker(
    rng: np.random.Generator,
    cfg: EmoNavConfig,
    walls: list[WallSpec],
    start: list[float],
    goal: list[float],
    via: list[list[float]] | None = None,
    **kw: object,
) -> PedestrianSpec:
    """A pedestrian walking the shortest route start → `via`… → goal round `walls`, kept
    its ORCA radius (radius plus safety space) plus `PED_ROUTE_MARGIN` off every wall: the
    via points and the route's corners are its waypoints. `ScenarioSamplingError` (the
    scene is drawn again) if there is no such route."""
    static_map = StaticMap.of([[w.start, w.end] for w in walls])
    c = cfg.crowd
    clearance = c.pedestrian_radius + c.safety_space + PED_ROUTE_MARGIN
    stops = [start, *(via or []), goal]
    waypoints: list[list[float]] = []
    for a, b in zip(stops[:-1], stops[1:], strict=True):
        try:
            leg = plan_route(a, b, static_map, clearance)
        except NoRouteError as e:
            raise ScenarioSamplingError(f"a pedestrian has no route: {e}") from None
        waypoints += [[float(x), float(y)] for x, y in leg[1:]]
    return PedestrianSpec(
        start=start, goal=goal, waypoints=waypoints[:-1], emotion=_emotion(rng, cfg), **kw
    )


def _building(
    cfg: EmoNavConfig,
    walls: list[WallSpec],
    start: list[float],
    goal: list[float],
    heading: float,
    pedestrians: list[PedestrianSpec],
) -> Scenario:
    return Scenario(
        pedestrians=pedestrians,
        walls=walls,
        robot_start=start,
        robot_goal=goal,
        robot_heading=heading,
        emotion_change_period=cfg.crowd.emotion_change_period,
    )


def _gap(cfg: EmoNavConfig) -> float:
    """The least distance [m] between two ends of pedestrians' routes (they walk to and fro
    and must pass each other there) and between one and the robot's start: two ORCA discs
    (radius plus safety space) or a pedestrian's and the robot's disc, plus 0.2 m."""
    r, p = cfg.robot.radius, cfg.crowd.pedestrian_radius + cfg.crowd.safety_space
    return max(2.0 * p, r + p) + 0.2


OFFICE_DELAY = 6.0  # [s] an office pedestrian starts after U(0, this)


def _t_junction(rng: np.random.Generator, cfg: EmoNavConfig) -> Scenario:
    """A stem corridor (x < 0, |y| < w/2) meets a cross corridor (0 < x < w, |y| < 6 m) in a T, w ~
    U(2.2, 2.6) m, walled all round (the ends closed). The robot starts in the stem facing the
    junction and turns left or right (even odds) to a goal 4–5 m along the cross corridor; two
    to four pedestrians start in the cross corridor and walk to its other end (two in three) or
    down the stem towards the robot."""
    width = float(rng.uniform(2.2, 2.6))
    h, stem, arm = width / 2.0, 6.0, 6.0
    walls = _chain(
        (-stem, h), (0.0, h), (0.0, arm), (width, arm), (width, -arm), (0.0, -arm), (0.0, -h),
        (-stem, -h), (-stem, h),
    )  # fmt: skip
    start = [-stem + float(rng.uniform(1.0, 1.5)), float(rng.uniform(-0.3, 0.3))]
    side = 1.0 if rng.random() < 0.5 else -1.0  # +1: the robot turns left
    goal = [float(rng.uniform(0.7, width - 0.7)), side * float(rng.uniform(arm - 2.0, arm - 1.0))]
    upper: Box = (0.0, width, 1.0, arm)
    lower: Box = (0.0, width, -arm, -1.0)
    ends, gap, peds = [start], _gap(cfg), []
    for _ in range(int(rng.integers(2, 5))):
        up = rng.random() < 0.5  # it starts in the upper arm of the cross corridor
        ped_start = _spot(rng, upper if up else lower, ends, gap)
        if rng.random() < 2.0 / 3.0:  # to the cross corridor's other end
            ped_goal = _spot(rng, lower if up else upper, ends, gap)
        else:  # down the stem, towards the robot
            ped_goal = _spot(rng, (-stem, -2.0, -h, h), ends, gap)
        peds.append(_walker(rng, cfg, walls, ped_start, ped_goal))
    return _building(cfg, walls, start, goal, 0.0, peds)


def _robot_ends(
    rng: np.random.Generator, start_box: Box, goal_box: Box, walls: list[WallSpec]
) -> tuple[list[float], list[float]]:
    """The robot's start in `start_box` and goal in `goal_box` (`INSET` inside them) such
    that the straight segment between them meets a wall: the goal is out of sight."""
    for _ in range(SPOT_TRIES):
        start, goal = _in_box(rng, start_box), _in_box(rng, goal_box)
        if _crosses(start, goal, walls):
            return start, goal
    raise ScenarioSamplingError("the robot's goal is in sight of its start in every draw")


def _heading(start: list[float], towards: list[float]) -> float:
    """The heading [rad] from `start` towards a point (world frame)."""
    return math.atan2(towards[1] - start[1], towards[0] - start[0])


def _doorway(rng: np.random.Generator, cfg: EmoNavConfig) -> Scenario:
    """Two rooms side by side, x in [−a, 0] and [0, b] (a, b ~ U(5.5, 6.5) m), |y| < d/2 (d ~
    U(5.5, 6.5) m), walled all round; the wall x = 0 between them has one door U(1.2, 1.5) m
    wide (`DOORWAY_DOOR`) at a drawn height. The robot starts in the left room facing the door,
    its goal is in the right room out of sight; one to three pedestrians walk from the right
    room through the door to the left one, zero to two more walk to and fro inside one room,
    standing 0–3 s at each end."""
    left, right = float(rng.uniform(5.5, 6.5)), float(rng.uniform(5.5, 6.5))
    h = float(rng.uniform(5.5, 6.5)) / 2.0
    width = float(rng.uniform(*DOORWAY_DOOR))
    yd = float(rng.uniform(-h + 0.8 + width / 2.0, h - 0.8 - width / 2.0))  # the door's middle
    walls = _chain((-left, -h), (right, -h), (right, h), (-left, h), (-left, -h))
    walls += _chain((0.0, -h), (0.0, yd - width / 2.0))
    walls += _chain((0.0, yd + width / 2.0), (0.0, h))
    door = Door((0.0, yd), (1.0, 0.0))
    rooms: tuple[Box, Box] = ((-left, 0.0, -h, h), (0.0, right, -h, h))
    start, goal = _robot_ends(rng, (-left, -1.0, -h, h), (1.0, right, -h, h), walls)
    ends, gap, peds = [start], _gap(cfg), []
    for _ in range(int(rng.integers(1, 4))):  # through the door, against the robot
        ped_start, ped_goal = _spot(rng, rooms[1], ends, gap), _spot(rng, rooms[0], ends, gap)
        peds.append(_walker(rng, cfg, walls, ped_start, ped_goal, door.through(ped_start)))
    for _ in range(int(rng.integers(0, 3))):  # to and fro in one room
        room = rooms[int(rng.integers(2))]
        ped_start, ped_goal = _spot(rng, room, ends, gap), _spot(rng, room, ends, gap)
        stand = round(float(rng.uniform(0.0, 3.0)), 1)
        peds.append(_walker(rng, cfg, walls, ped_start, ped_goal, stand_time=stand))
    return _building(cfg, walls, start, goal, _heading(start, [0.0, yd]), peds)


def _office(rng: np.random.Generator, cfg: EmoNavConfig) -> Scenario:
    """An office floor: three rooms side by side (each U(3.5, 4.5) m wide, all U(3.5, 4.5) m deep,
    y < 0) off a corridor U(2.2, 2.6) m wide along their north side (y > 0), walled all round.
    Each room opens onto the corridor through a door U(1.2, 1.3) m wide (`OFFICE_DOOR`) at a
    drawn place in its north wall. The robot starts in one room facing its door, its goal is in
    another; two to four pedestrians walk between two different places of the four (a room or
    the corridor), each starting after U(0, `OFFICE_DELAY`) s."""
    widths = rng.uniform(3.5, 4.5, size=3)
    depth, corridor = float(rng.uniform(3.5, 4.5)), float(rng.uniform(2.2, 2.6))
    xs = [float(x) for x in np.concatenate([[0.0], np.cumsum(widths)]) - widths.sum() / 2.0]
    walls = _chain((xs[0], -depth), (xs[3], -depth), (xs[3], corridor), (xs[0], corridor))
    walls += _chain((xs[0], corridor), (xs[0], -depth))
    walls += _chain((xs[1], -depth), (xs[1], 0.0)) + _chain((xs[2], -depth), (xs[2], 0.0))
    jambs = [xs[0]]  # the north wall of the rooms, broken by the doors
    doors = []
    for k in range(3):
        width = float(rng.uniform(*OFFICE_DOOR))
        middle = float(rng.uniform(xs[k] + 0.5 + width / 2.0, xs[k + 1] - 0.5 - width / 2.0))
        doors.append(Door((middle, 0.0), (0.0, 1.0)))
        jambs += [middle - width / 2.0, middle + width / 2.0]
    jambs.append(xs[3])
    for a, b in zip(jambs[0::2], jambs[1::2], strict=True):
        walls += _chain((a, 0.0), (b, 0.0))
    places: list[Box] = [(xs[k], xs[k + 1], -depth, 0.0) for k in range(3)]
    places.append((xs[0], xs[3], 0.0, corridor))
    here, there = (int(k) for k in rng.choice(3, size=2, replace=False))
    start, goal = _robot_ends(rng, places[here], places[there], walls)
    ends, gap, peds = [start], _gap(cfg), []
    for _ in range(int(rng.integers(2, 5))):
        a, b = (int(k) for k in rng.choice(4, size=2, replace=False))
        ped_start, ped_goal = _spot(rng, places[a], ends, gap), _spot(rng, places[b], ends, gap)
        via = []  # out of its room into the corridor, from the corridor into its room
        if a < 3:
            via += doors[a].through(ped_start)
        if b < 3:
            via += doors[b].through(ped_goal)[::-1]
        delay = round(float(rng.uniform(0.0, OFFICE_DELAY)), 1)
        peds.append(_walker(rng, cfg, walls, ped_start, ped_goal, via, start_delay=delay))
    return _building(cfg, walls, start, goal, _heading(start, list(doors[here].middle)), peds)


MIXED_PAPER_SHARE = 0.5  # the paper's arena in the mixed family (for training)
# The families `mixed` draws from besides the paper's arena: those it was made with, fixed
# so that a mixed seed keeps its scene as families are added (the buildings are not in it).
MIXED_FAMILIES = SCENARIO_FAMILIES[
    SCENARIO_FAMILIES.index("circle_crossing") : SCENARIO_FAMILIES.index("fast_pedestrians") + 1
]


def _mixed(rng: np.random.Generator, cfg: EmoNavConfig) -> Scenario:
    """A training distribution that includes the families: the paper's arena with
    probability `MIXED_PAPER_SHARE`, else one of `MIXED_FAMILIES`, uniformly. Every
    draw comes from the mixed family's own stream, so no scene of it is an evaluation
    scene of another family (nor a paper seed below 2**63)."""
    if rng.random() < MIXED_PAPER_SHARE:
        return sample_paper_scenario(int(rng.integers(2**63)), cfg)
    return FAMILIES[MIXED_FAMILIES[int(rng.integers(len(MIXED_FAMILIES)))]].draw(rng, cfg)


# `mixed_buildings` (training where a robot goes, issue 53): the paper's arena a third of
# the time, else any family but the mixes, the buildings included, uniformly.
MIXED_BUILDINGS_PAPER_SHARE = 1 / 3
MIXED_BUILDINGS_FAMILIES = SCENARIO_FAMILIES[
    SCENARIO_FAMILIES.index("circle_crossing") : SCENARIO_FAMILIES.index("office") + 1
]


def _mixed_buildings(rng: np.random.Generator, cfg: EmoNavConfig) -> Scenario:
    """Training in every family: the paper's arena with probability
    `MIXED_BUILDINGS_PAPER_SHARE`, else one of `MIXED_BUILDINGS_FAMILIES` (the 18 named
    families, buildings included), uniformly; from its own stream, as `mixed`."""
    if rng.random() < MIXED_BUILDINGS_PAPER_SHARE:
        return sample_paper_scenario(int(rng.integers(2**63)), cfg)
    names = MIXED_BUILDINGS_FAMILIES
    return FAMILIES[names[int(rng.integers(len(names)))]].draw(rng, cfg)


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
        Family(
            "t_junction", "a T of 2.4 m corridors, the robot turns; 2-4 pedestrians", _t_junction
        ),
        Family(
            "doorway",
            "two 6 x 6 m rooms, a 1.2-1.5 m door; 1-3 come through it, 0-2 wander",
            _doorway,
        ),
        Family(
            "office", "three rooms off a corridor, 1.2 m doors; room to room, 2-4 walk", _office
        ),
        Family(
            "mixed",
            "training: the paper's arena half the time, else one of 15 families",
            _mixed,
        ),
        Family(
            "mixed_buildings",
            "training: the arena a third of the time, else any of 18 families",
            _mixed_buildings,
        ),
    ]
}

assert tuple(FAMILIES) == SCENARIO_FAMILIES, "params.SCENARIO_FAMILIES lists the families"

# The families whose scenes have walls (`mixed`: some of them), where the global route
# layer is built; in every other family it never is (tests/test_building_families.py
# checks this set against drawn scenes).
WALLED_FAMILIES = frozenset(
    {
        "corner_traffic",
        "corridor_head_on",
        "t_junction",
        "doorway",
        "office",
        "mixed",
        "mixed_buildings",
    }
)


def sample_family(name: str, seed: int, config: EmoNavConfig | None = None) -> Scenario:
    """The scene of `seed` in family `name`, validated and with a reachable goal.

    `paper` is `scenarios/paper_scenario.py::sample_paper_scenario` (the paper's seeds,
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
