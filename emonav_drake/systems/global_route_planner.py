"""`GlobalRoutePlanner`: the route on the known static map and the sub-goal along it.

The global layer of a navigation stack as a Drake system: a thin front over
`navigation/route_following.RouteFollower`, which holds the rules (when to replan, which
clearances, the line-of-sight sub-goal, "no_route") so that the LIP world and the
training environments follow routes the same way. Every `period` it asks the follower to
replan with the robot where it is; its outputs read the plan it keeps.

Input port:
    robot_state (4): (x [m], y [m], θ [rad], v [m/s]) of the robot, world frame.
Output ports:
    subgoal (2): the point [m, world] `lookahead` along the route beyond the robot's
        nearest point on it (the goal when less is left; the goal itself before any
        route).
    route (abstract (K, 2) float array): the route's points [m, world], robot to goal.
    has_route (1): 1 while a route to the goal exists on the map, 0 once none is left.
Abstract state: the follower's `RoutePlan` (the route, empty before the first plan; the
discs in place when it was planned; whether the last replanning found one). Updated
every `period` from t = 0 and at initialization.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import BasicVector, Context, LeafSystem, State

from emonav_drake.navigation.route_following import RouteFollower, RoutePlan
from emonav_drake.scenarios.global_route import StaticMap
from emonav_drake.systems.lip_robot_plant import lip_state_from_vector


class GlobalRoutePlanner(LeafSystem):
    """Route and sub-goal on a static map (module docstring).

    Args:
        static_map: the walls and static discs (`RouteFollower`, as the five below).
        goal: the goal [m, world].
        clearance: the route's clearance(s) from every obstacle [m], tried in order.
        min_clearance: the clearance tried last [m] (the robot's radius).
        period: replanning check period [s].
        lookahead: sub-goal distance along the route [m].
        stray: replan when the robot is farther than this from the route [m].
        appear_times: when each of the map's discs is put in place [s] (None: all at 0).
        line_of_sight: keep the sub-goal in the robot's line of sight.
        follower: a `RouteFollower` to use instead of the arguments above (all but
            `period`; `of_follower`).
    """

    def __init__(
        self,
        static_map: StaticMap | None,
        goal: np.ndarray | None,
        clearance: float | Sequence[float] = 0.0,
        min_clearance: float = 0.0,
        period: float = 0.4,
        lookahead: float = 2.0,
        stray: float = 1.0,
        appear_times: object = None,
        line_of_sight: bool = False,
        follower: RouteFollower | None = None,
    ) -> None:
        super().__init__()
        if follower is None:
            follower = RouteFollower(
                static_map,
                goal,
                clearance,
                min_clearance,
                lookahead=lookahead,
                stray=stray,
                appear_times=appear_times,
                line_of_sight=line_of_sight,
            )
        self.follower = follower
        self._robot_in = self.DeclareVectorInputPort("robot_state", 4)
        self._plan = self.DeclareAbstractState(AbstractValue.Make(follower.initial_plan()))
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

    @classmethod
    def of_follower(cls, follower: RouteFollower, period: float) -> GlobalRoutePlanner:
        """The system over `follower`, checking every `period` [s]."""
        return cls(None, None, period=period, follower=follower)

    @property
    def min_clearance(self) -> float:
        """The follower's last-resort clearance [m] (the robot's radius)."""
        return self.follower.min_clearance

    def map_at(self, t: float) -> StaticMap:
        """The map at time `t` [s]: the walls and the discs in place by then."""
        return self.follower.map_at(t)

    def _state(self, context: Context) -> RoutePlan:
        return context.get_abstract_state(self._plan).get_value()

    def route(self, context: Context) -> np.ndarray:
        """The route in `context` ((0, 2) before the first plan)."""
        return self._state(context).route

    def _robot_xy(self, context: Context) -> np.ndarray:
        robot = lip_state_from_vector(self._robot_in.Eval(context))
        return np.array([robot.x, robot.y])

    def _replan(self, context: Context, state: State) -> None:
        plan = self._state(context)
        new = self.follower.replan(plan, self._robot_xy(context), context.get_time())
        if new is not plan:
            state.get_mutable_abstract_state(self._plan).set_value(new)

    def _calc_subgoal(self, context: Context, output: BasicVector) -> None:
        plan = self._state(context)
        output.SetFromVector(
            self.follower.subgoal(plan, self._robot_xy(context), context.get_time())
        )
