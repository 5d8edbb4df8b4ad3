"""Following a route on the known static map: when to replan, and the sub-goal along it.

The global layer of a navigation stack (Nav2's planner server, move_base's global
planner), in plain numpy so that the Drake system (`systems/global_route_planner.py`) and
the LIP world (`navigation/lip_world.py`, the training environments) follow routes the
same way, bit for bit.

`RouteFollower.replan(plan, xy, t)` is called once per walking step (and once at the
start): it plans the shortest route from the robot at `xy` to the goal around the walls
and static discs (`scenarios/global_route.py`) when there is no route yet, when the robot
has strayed more than `stray` from it, or when a disc put in place since (`appear_times`:
a cart left in a doorway) blocks what is left of it. A route is planned at each of the
`clearances` in turn (the widest first, so a route through a door keeps to its middle)
and at `min_clearance` last; the first that exists wins. When even that finds none, the
last route is kept and `found` turns False (the episode ends "no_route").

`RouteFollower.subgoal(plan, xy, t)` is the point `lookahead` metres along the route
beyond the robot's nearest point on it (the goal when less is left; the goal itself
before any route); with `line_of_sight`, pulled back along the route until the straight
line from the robot to it keeps `min_clearance` from every obstacle (the local planner is
never sent across a door jamb's corner).

The map is told when a disc is put in place (as a building's map server would be): the
route layer does not discover it with the robot's sensors. World frame, metres, seconds.
"""

from __future__ import annotations

import dataclasses as dc
from collections.abc import Sequence

import numpy as np

from emonav_drake.params import ConfigError, EmoNavConfig
from emonav_drake.scenarios.global_route import (
    NoRouteError,
    StaticMap,
    lookahead_point,
    plan_route,
    segments_clear,
)
from emonav_drake.scenarios.scenario import Scenario
from emonav_drake.scenarios.scenario_spec import discs_in_place
from emonav_drake.scenarios.walls import point_segment_distances


@dc.dataclass(frozen=True)
class RoutePlan:
    """What the route layer remembers between walking steps.

    Attributes:
        route: (K, 2) the route's points [m, world], robot to goal; (0, 2) before any plan.
        discs: which of the map's discs were in place when it was planned.
        found: whether the last replanning found a route.
    """

    route: np.ndarray
    discs: tuple[bool, ...]
    found: bool = True

    def to_plain(self) -> dict:
        return {"route": self.route.tolist(), "discs": list(self.discs), "found": self.found}

    @classmethod
    def from_plain(cls, d: dict) -> RoutePlan:
        route = np.asarray(d["route"], dtype=float).reshape(-1, 2)
        return cls(route, tuple(bool(x) for x in d["discs"]), bool(d["found"]))


class RouteFollower:
    """Route and sub-goal on a static map (module docstring).

    Args:
        static_map: the walls and static discs.
        goal: the goal [m, world].
        clearance: the route's distance from every obstacle [m] (robot radius + margin),
            or a sequence of them tried in order.
        min_clearance: the clearance tried last, also when the robot stands closer than
            every `clearance` [m] (its radius).
        lookahead: sub-goal distance along the route [m].
        stray: replan when the robot is farther than this from the route [m].
        appear_times: when each of the map's discs is put in place [s] (None: all at 0).
        line_of_sight: keep the sub-goal in the robot's line of sight (module docstring).
    """

    def __init__(
        self,
        static_map: StaticMap,
        goal: np.ndarray,
        clearance: float | Sequence[float],
        min_clearance: float,
        lookahead: float = 2.0,
        stray: float = 1.0,
        appear_times: object = None,
        line_of_sight: bool = False,
    ) -> None:
        wanted = [float(c) for c in np.atleast_1d(np.asarray(clearance, dtype=float))]
        if not (0 < min_clearance and all(c >= min_clearance for c in wanted)):
            raise ValueError(f"need 0 < min_clearance ({min_clearance}) <= clearance ({clearance})")
        self.static_map = static_map
        self.goal = np.asarray(goal, dtype=float).reshape(2)
        self.clearances = tuple(dict.fromkeys((*wanted, float(min_clearance))))  # no repeats
        self.clearance, self.min_clearance = self.clearances[0], float(min_clearance)
        self.line_of_sight = bool(line_of_sight)
        self.lookahead, self.stray = float(lookahead), float(stray)
        n = len(static_map.radii)
        times = np.zeros(n) if appear_times is None else np.asarray(appear_times, float)
        if times.shape != (n,) or not (np.isfinite(times).all() and (times >= 0).all()):
            raise ValueError(f"appear_times: {n} finite times >= 0 expected, got {times!r}")
        self.appear_times = times

    def initial_plan(self) -> RoutePlan:
        """The plan before the first replanning: no route, the discs in place at t = 0."""
        return RoutePlan(np.zeros((0, 2)), tuple(discs_in_place(self.appear_times, 0.0).tolist()))

    def map_at(self, t: float) -> StaticMap:
        """The map at time `t` [s]: the walls and the discs in place by then."""
        return self._map_of(discs_in_place(self.appear_times, t))

    def _map_of(self, here: np.ndarray) -> StaticMap:
        m = self.static_map
        return StaticMap(m.walls, m.centers[here], m.radii[here])

    def replan(self, plan: RoutePlan, xy: np.ndarray, t: float) -> RoutePlan:
        """The plan after the check at time `t` [s] with the robot at `xy` [m]: `plan`
        itself when nothing needs changing (module docstring)."""
        xy = np.asarray(xy, dtype=float)
        here = discs_in_place(self.appear_times, t)
        discs = tuple(here.tolist())
        static_map = self._map_of(here)
        route = plan.route
        if len(route) >= 2 and plan.found:
            seg = np.stack([route[:-1], route[1:]], axis=1)
            gaps = point_segment_distances(xy, seg)
            near = int(np.argmin(gaps))
            blocked = discs != plan.discs and not segments_clear(
                route[near:], static_map, self.min_clearance
            )
            if gaps[near] <= self.stray and not blocked:
                if discs != plan.discs:  # a disc elsewhere: the route still holds
                    return dc.replace(plan, discs=discs)
                return plan
        elif not plan.found and discs == plan.discs:
            return plan  # nothing has changed since no route was found
        for clearance in self.clearances:
            try:
                return RoutePlan(plan_route(xy, self.goal, static_map, clearance), discs)
            except NoRouteError:
                continue
        return RoutePlan(route, discs, found=False)

    def subgoal(self, plan: RoutePlan, xy: np.ndarray, t: float) -> np.ndarray:
        """The sub-goal [m, world] for the robot at `xy` [m] at time `t` [s] on `plan`."""
        route = plan.route
        if len(route) < 2:
            return self.goal.copy()
        xy = np.asarray(xy, dtype=float)
        sub = lookahead_point(route, xy, self.lookahead)
        if self.line_of_sight:
            sub = self._in_sight(route, xy, sub, self.map_at(t))
        return sub

    def _in_sight(
        self, route: np.ndarray, xy: np.ndarray, sub: np.ndarray, static_map: StaticMap
    ) -> np.ndarray:
        """The farthest point up to `sub` along the route that the robot sees with its
        radius clear (bisection over the distance along the route, 1 cm)."""
        if segments_clear(np.stack([xy, sub]), static_map, self.min_clearance):
            return sub
        lo, hi = 0.0, self.lookahead
        while hi - lo > 0.01:
            mid = 0.5 * (lo + hi)
            point = lookahead_point(route, xy, mid)
            if segments_clear(np.stack([xy, point]), static_map, self.min_clearance):
                lo = mid
            else:
                hi = mid
        return lookahead_point(route, xy, lo)


def uses_route(scenario: Scenario, config: EmoNavConfig, global_route: bool | None = None) -> bool:
    """Whether an episode of `scenario` follows a global route: only in a scene with walls,
    and there as `global_route` says (None: `config.route.enabled`, on by default)."""
    enabled = config.route.enabled if global_route is None else bool(global_route)
    return enabled and len(scenario.walls) > 0


def route_follower(scenario: Scenario, config: EmoNavConfig) -> RouteFollower:
    """The route layer of a scene: its walls and static discs, its goal, the clearances of
    the robot's radius + each of `config.route.margins` (then the radius alone),
    look-ahead, line of sight and stray distance of `config.route`. `ConfigError` naming
    what blocks it when no route with the robot's radius joins the start to the goal on
    the map at t = 0 (a disc put in place later, `appears_at` > 0, may close the route
    during the episode: the outcome "no_route")."""
    static_map = StaticMap.of(
        scenario.wall_segments(),
        [o.center for o in scenario.obstacles],
        [o.radius for o in scenario.obstacles],
    )
    r, rp = config.robot.radius, config.route
    follower = RouteFollower(
        static_map,
        np.asarray(scenario.robot_goal, float),
        [r + m for m in rp.margins],
        r,
        lookahead=rp.lookahead,
        stray=rp.stray,
        appear_times=[o.appears_at for o in scenario.obstacles],
        line_of_sight=rp.line_of_sight,
    )
    try:  # a goal no route reaches is refused here, naming what blocks it
        plan_route(
            scenario.robot_start, scenario.robot_goal, follower.map_at(0.0), follower.min_clearance
        )
    except NoRouteError as e:
        raise ConfigError(f"the scene's goal cannot be reached: {e}") from None
    return follower
