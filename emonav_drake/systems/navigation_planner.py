"""`NavigationPlanner`: any planner (DWA, MPC, learned policy) as one Drake system that
owns its rate — one plan per walking step, the command held in between.

Input ports:
    robot_state (4): (x [m], y [m], θ [rad], v [m/s]) of the robot CoM, world frame.
    crowd (abstract `CrowdSnapshot`): privileged crowd state (used by DWA / MPC): world
        frame positions [m] and velocities [m/s], emotions and discomfort distances.
    lgm_stack (abstract numpy array): the map observation, robot frame, oldest first
        (used by learned policies): uint8 (N, M, M) LGM/OGM stack, float32 (N, K) scan
        stack [m] or uint8 (1, 3, M, M) DRL-VO* image (`LidarGridMapBuilder`). May be
        left unconnected for planners that ignore it (DWA, MPC).
    action (2, only when built without a planner): the command to store at the next
        planner instant, (u_v [m/s], u_Δθ [rad]) — an external agent's action.
Output port:
    command (2): (u_v [m/s], u_Δθ [rad]), the command of the walking step in progress: u_k
        during step k (t_k ≤ t < t_{k+1}); before the update at t_k it is still u_{k−1}.
        A state output: no direct feedthrough from any input.
State (the Context holds everything the planner remembers):
    command (discrete, 2): the stored command; (0, 0) initially, like the Gymnasium env
        after `reset` (the "previous command" of step 0).
    plan_log (discrete, 3): [time of the last plan t [s] (NaN before the first one),
        number of plans, number of clipped commands].
    memory (abstract): the planner's memory (`Planner.initial_memory()` initially; e.g.
        the MPC's previous plan, duals and guide path; None for memoryless planners).

Timing. A periodic unrestricted update every T = `robot.step_time` from t = 0, like every
navigation update (the LIP plant, the crowd, the grid maps and the episode monitor are
all periodic unrestricted events at offset 0, so at t_k = kT each reads the same
pre-update state). At t_k the planner reads the robot at its foot switch, the crowd and
the grid-map stack at t_k, and its own previous command u_{k−1}; it stores u_k, which the
robot executes during step k (t_k → t_{k+1}). The command is checked with
`navigation.lip_world.check_command`: NaN raises `CommandError`; out of range is clipped to the
bounds of Eq. 2, counted in `plan_log` and logged as a warning naming the system, the time
and the command.

A planner's answer that is not a (command, memory) pair, or whose command is not two
finite numbers (a string, three numbers, NaN), raises `PlannerOutputError` (a
`CommandError`) naming the planner and what it returned. A decision that takes longer
than `episode.decision_timeout` of wall time (60 s by default; 0: no limit) raises
`PlannerTimeout` naming the planner (`watchdog.wall_clock_limit`: in the main thread of
the process, as in `emonav` and in a Ray worker; elsewhere there is no limit). The
watchdog only turns a hang into an error: a decision made in time is untouched. For a
planner of the user's own (its class in a module outside the package) any of these, and
any exception its decision raises, becomes a `PluginError` naming the planner and its
module: the user's to fix (exit code 2), not a bug of the package.
"""

from __future__ import annotations

import copy
import logging
from typing import Any

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import Context, LeafSystem, State

from emonav_drake.crowd.crowd import with_wall_discs
from emonav_drake.errors import PluginError
from emonav_drake.navigation.lip_world import CommandError, PlannerInput, check_command
from emonav_drake.params import EmoNavConfig
from emonav_drake.planners.protocol import Planner
from emonav_drake.planners.registry import outside_module
from emonav_drake.systems.lip_robot_plant import lip_state_from_vector
from emonav_drake.watchdog import wall_clock_limit

log = logging.getLogger(__name__)


class PlannerOutputError(CommandError):
    """A planner's decision that is not a (command, memory) pair whose command is a
    (speed, turn) pair of finite numbers; the message names the planner and its answer."""


class PlannerTimeout(RuntimeError):
    """A planner's decision still running after `episode.decision_timeout` of wall time."""


def planner_label(planner: object) -> str:
    """What errors call a planner: its `name` (the registered name `make_planner` gives
    it), else its class's name."""
    name = getattr(planner, "name", None)
    return name if isinstance(name, str) and name else type(planner).__name__


def _shown(value: object, limit: int = 80) -> str:
    """`value` for an error message: its repr (an array as a list), at most `limit` chars."""
    text = repr(value.tolist() if isinstance(value, np.ndarray) else value)
    return text if len(text) <= limit else text[: limit - 1] + "…"


def checked_decision(planner: object, answer: object) -> tuple[np.ndarray, Any]:
    """(command (2,) float, memory) of a planner's `plan_with_memory` answer `answer`;
    `PlannerOutputError` naming the planner if it is not a (command, memory) pair whose
    command is two finite numbers."""
    name = planner_label(planner)
    if not (isinstance(answer, tuple | list) and len(answer) == 2):
        raise PlannerOutputError(
            f"planner {name!r} returned {_shown(answer)} from plan_with_memory, not a "
            "(command, memory) pair"
        )
    raw, memory = answer
    try:
        u = np.asarray(raw, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        u = None
    if u is None or u.shape != (2,) or isinstance(raw, str | bytes):
        raise PlannerOutputError(
            f"planner {name!r} returned {_shown(raw)}, not a (speed, turn) pair of numbers"
        )
    if not np.all(np.isfinite(u)):
        raise PlannerOutputError(
            f"planner {name!r} returned {_shown(raw)}: a command that is not finite, not a "
            "(speed, turn) pair of finite numbers"
        )
    return u, memory


class NavigationPlanner(LeafSystem):
    """A planner wrapped as a system that plans once per walking step (see the module).

    Args:
        planner: the planner (see `Planner`). The system keeps no planner memory outside
            its Context, so one planner object may serve several contexts. None: the
            system has an `action` input port (2) instead, whose value at t_k becomes u_k
            (the Gymnasium env `EmoNavDigit-v0`).
        goal_xy: the robot's goal in the world frame [m]. The optional `goal` input (2)
            [m, world], when connected, replaces it at every decision: the sub-goal of a
            global route (`GlobalRoutePlanner`).
        config: the step time T and the command bounds.
    """

    def __init__(self, planner: Planner | None, goal_xy: np.ndarray, config: EmoNavConfig) -> None:
        super().__init__()
        self.planner = planner
        self._goal = np.asarray(goal_xy, dtype=float)
        self._robot_params = config.robot
        self.step_time = config.robot.step_time  # T [s]: the planning period
        self.decision_timeout = config.episode.decision_timeout  # [s] of wall time; 0: none
        self._robot = self.DeclareVectorInputPort("robot_state", 4)
        self._crowd = self.DeclareAbstractInputPort("crowd", AbstractValue.Make(object()))
        self._lgm = self.DeclareAbstractInputPort("lgm_stack", AbstractValue.Make(object()))
        self._goal_in = self.DeclareVectorInputPort("goal", 2)
        self._command = self.DeclareDiscreteState(np.zeros(2))
        self._plan_log = self.DeclareDiscreteState(np.array([np.nan, 0.0, 0.0]))
        memory = None if planner is None else planner.initial_memory()
        self._memory = self.DeclareAbstractState(AbstractValue.Make(copy.deepcopy(memory)))
        # Without a planner the command comes from outside (a Gymnasium agent): the
        # `action` input, sampled at t_k exactly as a planner's answer would be stored.
        self._action = None if planner is not None else self.DeclareVectorInputPort("action", 2)
        self.DeclareStateOutputPort("command", self._command)
        self.DeclarePeriodicUnrestrictedUpdateEvent(self.step_time, 0.0, self._plan)

    def planner_input(self, context: Context) -> PlannerInput:
        """The `PlannerInput` the planner sees in `context` (its `last_command` is the
        stored command, i.e. the previous step's at a foot switch before the update)."""
        lgm = self._lgm.Eval(context) if self._lgm.HasValue(context) else None
        goal = self._goal_in.Eval(context) if self._goal_in.HasValue(context) else self._goal
        return PlannerInput(
            robot=lip_state_from_vector(self._robot.Eval(context)),
            goal_xy=np.asarray(goal, dtype=float),
            last_command=context.get_discrete_state(self._command).get_value().copy(),
            crowd=with_wall_discs(self._crowd.Eval(context)),
            lgm_stack=lgm,
            step=round(context.get_time() / self.step_time),
            goal_is_subgoal=self._goal_in.HasValue(context),
        )

    def memory(self, context: Context) -> Any:
        """The planner memory stored in `context` (a deep copy)."""
        return copy.deepcopy(context.get_abstract_state(self._memory).get_value())

    def plan_log(self, context: Context) -> tuple[float, int, int]:
        """(time of the last plan [s] or NaN, number of plans, number of clipped commands)."""
        t, plans, clipped = context.get_discrete_state(self._plan_log).get_value()
        return float(t), int(plans), int(clipped)

    def _decide(self, context: Context, t: float) -> tuple[np.ndarray, Any]:
        """The planner's decision at `t`: (command, memory), checked (`checked_decision`),
        within the wall-clock limit `decision_timeout` (`PlannerTimeout` past it)."""
        obs, memory = self.planner_input(context), self.memory(context)
        name, limit = planner_label(self.planner), self.decision_timeout

        def timeout() -> PlannerTimeout:
            return PlannerTimeout(
                f"planner {name!r} made no decision at t = {t:.2f} s within {limit:g} s of "
                "wall time (episode.decision_timeout): it hangs, or is far too slow"
            )

        try:
            with wall_clock_limit(limit, timeout):
                answer = self.planner.plan_with_memory(obs, memory)
            return checked_decision(self.planner, answer)
        except Exception as e:
            module = outside_module(self.planner)
            if module is None:  # the package's own planner: its error is a bug of ours
                raise
            what = (
                str(e)
                if isinstance(e, PlannerOutputError | PlannerTimeout)
                else (f"planner {name!r} raised {type(e).__name__}: {e}")
            )
            raise PluginError(f"{what} (module {module})") from e

    def _plan(self, context: Context, state: State) -> None:
        t = context.get_time()
        if self._action is not None:
            raw, memory = self._action.Eval(context), None
        else:
            raw, memory = self._decide(context, t)
        command, clipped = check_command(raw, self._robot_params, clip=True)
        _, plans, clips = self.plan_log(context)
        if clipped:
            clips += 1
            log.warning(
                "NavigationPlanner %s: command %s out of bounds at t = %.2f s, clipped to %s",
                self.GetSystemPathname(),
                np.asarray(raw).tolist(),
                t,
                command.tolist(),
            )
        state.get_mutable_discrete_state(self._command).set_value(command)
        state.get_mutable_discrete_state(self._plan_log).set_value(
            np.array([t, plans + 1.0, float(clips)])
        )
        state.get_mutable_abstract_state(self._memory).set_value(copy.deepcopy(memory))
