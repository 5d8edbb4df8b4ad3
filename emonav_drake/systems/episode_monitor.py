"""`EpisodeMonitor`: rewards (Eq. 6–9), outcome and social metrics of a navigation episode.

Input ports:
    robot_state (4): (x, y, θ, v) of the robot CoM, world frame [m, rad, m/s].
    crowd (abstract `CrowdSnapshot`).
    command (2, optional): the planner's command (u_v [m/s], u_Δθ [rad]); at t_k, before
        the planner's update, the command u_{k−1} of the step that ends. It feeds the
        jerk of the field's metrics only: left unconnected, `jerk_mean` is None.
    has_route (1, optional): the global route layer's `has_route`; 0 at t_k ends the
        episode with the outcome "no_route" (unless step k collided or reached the goal).
        Left unconnected: a route is assumed.
Output port:
    status (abstract `EpisodeStatus`): the `EpisodeRecord` (outcome, steps, path length,
        discomfort steps, IDT, …) including the walking step that ends now, and whether
        the episode is over. At t_k it already counts step k (evaluated on the robot at
        its foot switch and the crowd at t_k), before the periodic update stores it.
Abstract state: the `EpisodeTracker` and the previous foot-switch position (and robot
state, for the field's metrics: `navigation/social_metrics.py`), updated at t_k = kT (a no-op at
k = 0). The robot at t_0 is taken to be the scenario's start: its position and heading,
at rest.

`episode_monitor_callback(diagram, monitor)` gives a `Simulator` monitor that stops the
simulation exactly at the walking step that ends the episode.
"""

from __future__ import annotations

import copy
import dataclasses as dc
import math

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import Context, EventStatus, LeafSystem, State

from emonav_drake.navigation.metrics import EpisodeRecord, EpisodeTracker
from emonav_drake.navigation.reward import StepEvaluation, evaluate_step
from emonav_drake.navigation.social_metrics import StepMotion
from emonav_drake.params import EmoNavConfig
from emonav_drake.robot.lip import LipState
from emonav_drake.scenarios.scenario import Scenario
from emonav_drake.systems.lip_robot_plant import lip_state_from_vector


@dc.dataclass(frozen=True)
class EpisodeStatus:
    """The episode so far."""

    record: EpisodeRecord
    done: bool
    last_step: StepEvaluation | None = None


@dc.dataclass
class _MonitorState:
    tracker: EpisodeTracker
    position: tuple[float, float]
    goal_distance: float
    last_step: StepEvaluation | None = None
    robot: LipState | None = None  # at the previous foot switch


class EpisodeMonitor(LeafSystem):
    """Evaluates every walking step of an episode.

    Args:
        scenario: for the goal and the seed.
        config: reward parameters, time limit, robot radius, step time.
        goal_radius: goal threshold [m]; default `config.episode.goal_radius`.
    """

    def __init__(
        self, scenario: Scenario, config: EmoNavConfig, goal_radius: float | None = None
    ) -> None:
        super().__init__()
        self._config = config
        self._goal = np.asarray(scenario.robot_goal, dtype=float)
        self._goal_radius = config.episode.goal_radius if goal_radius is None else goal_radius
        self._T = config.robot.step_time
        start = tuple(float(v) for v in scenario.robot_start)
        init = _MonitorState(
            tracker=EpisodeTracker(config.episode.max_steps, self._T, seed=scenario.seed),
            position=start,
            goal_distance=float(math.dist(start, self._goal)),
            robot=LipState(start[0], start[1], float(scenario.robot_heading), 0.0),
        )
        self._state = self.DeclareAbstractState(AbstractValue.Make(init))
        self._robot = self.DeclareVectorInputPort("robot_state", 4)
        self._crowd = self.DeclareAbstractInputPort("crowd", AbstractValue.Make(object()))
        self._command = self.DeclareVectorInputPort("command", 2)
        self._has_route = self.DeclareVectorInputPort("has_route", 1)
        self.DeclareAbstractOutputPort(
            "status",
            lambda: AbstractValue.Make(EpisodeStatus(EpisodeRecord(), False)),
            self._calc_status,
            {self.all_input_ports_ticket(), self.all_state_ticket(), self.time_ticket()},
        )
        # Offset 0, like the plant and the crowd, so the event times are the same floats
        # (k·T); an offset of T gives T + (k−1)·T, which differs from k·T by an ulp for
        # some k and would run this update after the others. At t = 0 it does nothing.
        self.DeclarePeriodicUnrestrictedUpdateEvent(self._T, 0.0, self._update)

    def _advanced(self, context: Context) -> _MonitorState:
        """The monitor state including the step that ends at this time, if any."""
        st: _MonitorState = context.get_abstract_state(self._state).get_value()
        t = context.get_time()
        k = round(t / self._T)
        if st.tracker.done or k < 1 or abs(t - k * self._T) > 1e-9 or st.tracker.record.steps >= k:
            return st
        robot = lip_state_from_vector(self._robot.Eval(context))
        xy = np.array([robot.x, robot.y])
        c = self._config
        crowd = self._crowd.Eval(context)
        ev = evaluate_step(
            xy,
            self._goal,
            st.goal_distance,
            crowd,
            c.robot.radius,
            self._goal_radius,
            c.reward,
        )
        new = _MonitorState(
            tracker=copy.deepcopy(st.tracker),
            position=(robot.x, robot.y),
            goal_distance=ev.goal_distance,
            last_step=ev,
            robot=robot,
        )
        command = self._command.Eval(context).copy() if self._command.HasValue(context) else None
        motion = StepMotion(st.robot, robot, crowd, self._goal, c.robot.radius, command)
        no_route = self._has_route.HasValue(context) and self._has_route.Eval(context)[0] < 0.5
        new.tracker.add(ev, math.dist(st.position, new.position), motion, no_route)
        return new

    def _update(self, context: Context, state: State) -> None:
        state.get_mutable_abstract_state(self._state).set_value(self._advanced(context))

    def _calc_status(self, context: Context, output: AbstractValue) -> None:
        st = self._advanced(context)
        output.set_value(
            EpisodeStatus(
                record=copy.deepcopy(st.tracker.record),
                done=st.tracker.done,
                last_step=st.last_step,
            )
        )


def episode_monitor_callback(diagram, monitor: EpisodeMonitor):
    """A `Simulator.set_monitor` callback that stops when the episode is over."""
    port = monitor.GetOutputPort("status")

    def callback(root_context: Context) -> EventStatus:
        status = port.Eval(monitor.GetMyContextFromRoot(root_context))
        if status.done:
            return EventStatus.ReachedTermination(diagram, f"episode {status.record.outcome}")
        return EventStatus.Succeeded()

    return callback
