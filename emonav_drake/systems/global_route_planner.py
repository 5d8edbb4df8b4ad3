"""`GlobalRoutePlanner`: the route on the known static map and the sub-goal along it.

The global layer of a navigation stack (Nav2's planner server, move_base's global
planner): at a low rate it plans the shortest route from the robot to the goal around the
walls and static discs (`core/global_route.py`), and at any time it gives the sub-goal a
local planner steers to, `lookahead` metres along the route beyond the robot. It replans
when it has no route yet or the robot has strayed more than `stray` from it. A robot
standing within the clearance of an obstacle (it may pass closer than the route's margin)
is routed from there with the clearance reduced to `min_clearance`; when even that finds
no route, the last route is kept and `has_route` tells the planner.

Input port:
    robot_state (4): (x [m], y [m], θ [rad], v [m/s]) of the robot, world frame.
Output ports:
    subgoal (2): the point [m, world] `lookahead` along the route beyond the robot's
        nearest point on it (the goal when less is left; the goal itself before any
        route).
    route (abstract (K, 2) float array): the route's points [m, world], robot to goal.
Abstract state: the route (empty before the first plan) and whether the last replanning
found one. Updated every `period` from t = 0.
"""

from __future__ import annotations

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import BasicVector, Context, LeafSystem, State

from emonav_drake.core.global_route import (
    NoRouteError,
    StaticMap,
    lookahead_point,
    plan_route,
)
from emonav_drake.core.walls import point_segment_distances
from emonav_drake.systems.lip_robot_plant import lip_state_from_vector


class GlobalRoutePlanner(LeafSystem):
    """Route and sub-goal on a static map (module docstring).

    Args:
        static_map: the walls and static discs.
        goal: the goal [m, world].
        clearance: the route's distance from every obstacle [m] (robot radius + margin).
        min_clearance: the clearance when the robot stands closer than `clearance` [m]
            (its radius).
        period: replanning check period [s].
        lookahead: sub-goal distance along the route [m].
        stray: replan when the robot is farther than this from the route [m].
    """

    def __init__(
        self,
        static_map: StaticMap,
        goal: np.ndarray,
        clearance: float,
        min_clearance: float,
        period: float = 0.4,
        lookahead: float = 2.0,
        stray: float = 1.0,
    ) -> None:
        super().__init__()
        if not 0 < min_clearance <= clearance:
            raise ValueError(f"need 0 < min_clearance ({min_clearance}) <= clearance ({clearance})")
        self.static_map = static_map
        self.goal = np.asarray(goal, dtype=float).reshape(2)
        self.clearance, self.min_clearance = float(clearance), float(min_clearance)
        self.lookahead, self.stray = float(lookahead), float(stray)
        self._robot_in = self.DeclareVectorInputPort("robot_state", 4)
        self._route = self.DeclareAbstractState(AbstractValue.Make(np.zeros((0, 2))))
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
        self.DeclarePeriodicUnrestrictedUpdateEvent(period, 0.0, self._replan)
        self.DeclareInitializationUnrestrictedUpdateEvent(self._replan)

    def route(self, context: Context) -> np.ndarray:
        """The route in `context` ((0, 2) before the first plan)."""
        return context.get_abstract_state(self._route).get_value()

    def _robot_xy(self, context: Context) -> np.ndarray:
        robot = lip_state_from_vector(self._robot_in.Eval(context))
        return np.array([robot.x, robot.y])

    def _replan(self, context: Context, state: State) -> None:
        xy = self._robot_xy(context)
        route = self.route(context)
        if len(route) >= 2:
            seg = np.stack([route[:-1], route[1:]], axis=1)
            if point_segment_distances(xy, seg).min() <= self.stray:
                return
        for clearance in (self.clearance, self.min_clearance):
            try:
                new = plan_route(xy, self.goal, self.static_map, clearance)
            except NoRouteError:
                continue
            state.get_mutable_abstract_state(self._route).set_value(new)
            return

    def _calc_subgoal(self, context: Context, output: BasicVector) -> None:
        route = self.route(context)
        if len(route) < 2:
            output.SetFromVector(self.goal)
            return
        output.SetFromVector(lookahead_point(route, self._robot_xy(context), self.lookahead))
