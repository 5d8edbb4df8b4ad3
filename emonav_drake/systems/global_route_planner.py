"""`GlobalRoutePlanner`: the route on the known static map and the sub-goal along it.

The global layer of a navigation stack (Nav2's planner server, move_base's global
planner): at a low rate it plans the shortest route from the robot to the goal around the
walls and static discs (`scenarios/global_route.py`), and at any time it gives the sub-goal a
local planner steers to, `lookahead` metres along the route beyond the robot (with
`line_of_sight`, pulled back along the route until the straight line from the robot to
it keeps `min_clearance` from every obstacle: the local planner is never sent across a
door jamb's corner). A route is planned at each of `clearance` in turn (a list: the
widest first, so a route through a door keeps to its middle) and at `min_clearance`
last; the first that exists wins. It replans
when it has no route yet, when the robot has strayed more than `stray` from it, or when
a disc put in place since (`appear_times`: a cart left in a doorway) blocks what is left
of it. A robot standing within the clearance of an obstacle (it may pass closer than the
route's margin) is routed from there with the clearance reduced to `min_clearance`; when
even that finds no route, the last route is kept and `has_route` turns 0 (the episode
monitor ends the trial with the outcome "no_route").

The map is told when a disc is put in place (as a building's map server would be): the
route layer does not discover it with the robot's sensors.

Input port:
    robot_state (4): (x [m], y [m], θ [rad], v [m/s]) of the robot, world frame.
Output ports:
    subgoal (2): the point [m, world] `lookahead` along the route beyond the robot's
        nearest point on it (the goal when less is left; the goal itself before any
        route).
    route (abstract (K, 2) float array): the route's points [m, world], robot to goal.
    has_route (1): 1 while a route to the goal exists on the map, 0 once none is left.
Abstract state: the route (empty before the first plan), the discs in place when it was
planned, and whether the last replanning found one. Updated every `period` from t = 0.
"""

from __future__ import annotations

import dataclasses as dc
from collections.abc import Sequence

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import BasicVector, Context, LeafSystem, State

from emonav_drake.scenarios.global_route import (
    NoRouteError,
    StaticMap,
    lookahead_point,
    plan_route,
    segments_clear,
)
from emonav_drake.scenarios.scenario_spec import discs_in_place
from emonav_drake.scenarios.walls import point_segment_distances
from emonav_drake.systems.lip_robot_plant import lip_state_from_vector


@dc.dataclass(frozen=True)
class _Plan:
    route: np.ndarray  # (K, 2) [m]; (0, 2) before the first plan
    discs: tuple[bool, ...]  # which of the map's discs were in place when it was planned
    found: bool = True  # whether the last replanning found a route


class GlobalRoutePlanner(LeafSystem):
    """Route and sub-goal on a static map (module docstring).

    Args:
        static_map: the walls and static discs.
        goal: the goal [m, world].
        clearance: the route's distance from every obstacle [m] (robot radius + margin),
            or a sequence of them tried in order.
        min_clearance: the clearance tried last, also when the robot stands closer than
            every `clearance` [m] (its radius).
        period: replanning check period [s].
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
        period: float = 0.4,
        lookahead: float = 2.0,
        stray: float = 1.0,
        appear_times: object = None,
        line_of_sight: bool = False,
    ) -> None:
        super().__init__()
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
        self._robot_in = self.DeclareVectorInputPort("robot_state", 4)
        empty = _Plan(np.zeros((0, 2)), tuple(discs_in_place(times, 0.0).tolist()))
        self._plan = self.DeclareAbstractState(AbstractValue.Make(empty))
        self.DeclareVectorOutputPort(
            "subgoal",
            2,
            self._calc_subgoal,
            {self.all_state_ticket(), self.all_input_ports_ticket()},
        )
        self.DeclareAbstractOutputPort(
            "route",
            lambda: AbstractValue.Make(np.zeros((0, 2))),
            lambda context, out: out.set_value(self.route(context)),
            {self.all_state_ticket()},
        )
        self.DeclareVectorOutputPort(
            "has_route",
            1,
            lambda context, out: out.SetAtIndex(0, float(self._state(context).found)),
            {self.all_state_ticket()},
        )
        self.DeclarePeriodicUnrestrictedUpdateEvent(period, 0.0, self._replan)
        self.DeclareInitializationUnrestrictedUpdateEvent(self._replan)

    def _state(self, context: Context) -> _Plan:
        return context.get_abstract_state(self._plan).get_value()

    def route(self, context: Context) -> np.ndarray:
        """The route in `context` ((0, 2) before the first plan)."""
        return self._state(context).route

    def map_at(self, t: float) -> StaticMap:
        """The map at time `t` [s]: the walls and the discs in place by then."""
        return self._map_of(discs_in_place(self.appear_times, t))

    def _map_of(self, here: np.ndarray) -> StaticMap:
        m = self.static_map
        return StaticMap(m.walls, m.centers[here], m.radii[here])

    def _robot_xy(self, context: Context) -> np.ndarray:
        robot = lip_state_from_vector(self._robot_in.Eval(context))
        return np.array([robot.x, robot.y])

    def _replan(self, context: Context, state: State) -> None:
        xy = self._robot_xy(context)
        plan = self._state(context)
        here = discs_in_place(self.appear_times, context.get_time())
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
                    state.get_mutable_abstract_state(self._plan).set_value(
                        dc.replace(plan, discs=discs)
                    )
                return
        elif not plan.found and discs == plan.discs:
            return  # nothing has changed since no route was found
        for clearance in self.clearances:
            try:
                new = plan_route(xy, self.goal, static_map, clearance)
            except NoRouteError:
                continue
            state.get_mutable_abstract_state(self._plan).set_value(_Plan(new, discs))
            return
        state.get_mutable_abstract_state(self._plan).set_value(_Plan(route, discs, found=False))

    def _calc_subgoal(self, context: Context, output: BasicVector) -> None:
        route = self.route(context)
        if len(route) < 2:
            output.SetFromVector(self.goal)
            return
        xy = self._robot_xy(context)
        sub = lookahead_point(route, xy, self.lookahead)
        if self.line_of_sight:
            sub = self._in_sight(route, xy, sub, self.map_at(context.get_time()))
        output.SetFromVector(sub)

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
