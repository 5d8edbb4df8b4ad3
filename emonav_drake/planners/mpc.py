"""The MPC planner on the LIP model, solved with OSQP — the model-based baseline.

The planner answers one walking-step command u_0 = (u_v, u_Δθ) per step by optimising a
horizon of N walking steps of the paper's LIP step map (Eq. 1, `robot/lip.py`) against a
constant-velocity prediction of the pedestrians and the static discs (privileged
`CrowdSnapshot`, as DWA), then applying the first command (receding horizon).

The formulation (decision variables, the LIP dynamics in condensed form, the emotion-aware
discomfort and contact half-planes, the cost and the guide path it follows) is in the
docstring of `planning/mpc_qp.py`, which builds and solves it; this module is the planner
around it.

SCP loop. An initial guess is chosen by evaluating the nonlinear cost of a few seed
plans with one vectorised rollout: the previous plan shifted by one step (with a small
hysteresis bonus, so the robot does not swap sides of an obstacle) and "turn towards
heading bearing+ψ at full or half speed, then hold" for a fan of offsets ψ, plus
standing still. This choice of seed is what picks the side on which obstacles are
passed; the SCP iterations (re-linearise → update the QP in place → solve) then refine
it for a fixed number of iterations, stopping early when the plan stops changing.

Memory and determinism. What a planning step takes from the previous ones is its memory,
an immutable `MpcMemory`: the previous step's plan and duals (the warm start) and the
guide path with the goal and discs it was built for. `plan_with_memory(obs, memory)`
returns the command and the next memory without touching its argument, so in the Drake
diagram the memory lives in the Context (`systems.NavigationPlanner`); `plan(obs)` /
`reset()` keep one on the object for the Gymnasium env and scripts. The OSQP workspaces
and the counters are a cache and diagnostics, not memory: a command (and the next memory)
is a deterministic function of (planner input, memory), bit for bit, whatever the OSQP
objects solved before. For that, rho is reset to its initial value at each planning step,
the number of SCP iterations is fixed, and every QP goes through the same sequence of
updates — q zeroed, then the matrices, then the vectors. OSQP re-scales the data on a
matrix update, and its cost scaling reads the q left in the workspace: the previous QP's
q, unscaled with the previous scaling, leaked into the new scaling in the last bits (one
random problem in ten gave a command differing in the last bit depending on what the
workspace had solved before). Zero survives any scaling exactly; the price is a cost
scaling that ignores q (about 50 % more ADMM iterations, ~0.3 ms a planning step; a new
workspace per planning step would keep the q-aware scaling but a setup costs ~1.3 ms).
`tests/test_navigation_planner_rate.py` checks it bit for bit.

Work budget in iterations, not seconds. Every number that decides how far OSQP iterates is
a count: `max_iter` (400 ADMM iterations per QP), the termination check every 25
iterations and rho adapted every `_RHO_INTERVAL` = 50 iterations (`planning/mpc_qp.py`;
OSQP's iteration-based rule, set explicitly: OSQP also has a rule that adapts rho after a
fraction of the setup *time*). So a plan is the same on an idle and on a starved
machine. OSQP's wall-clock `time_limit` (`mpc.time_limit`, 1 s per QP, ~1000× what a QP
takes here) is only a safety: a solve it cuts would depend on the load, so each time it
fires the planner counts it (`time_limit_hits`) and logs a warning naming the planning
step; no result we publish had one (`tests/test_mpc_load.py` runs the MPC beside a CPU
hog and under stalls).

Modules. This one (a planner, beside the others in `planners/`) holds `MpcPlanner` (seed
choice, SCP loop, memory, fallback, counters) and `MpcMemory`; `planning/mpc_model.py` the
horizon's constants and solver-free model (rollout, Jacobian, obstacle prediction, seeds,
nonlinear cost); `planning/mpc_qp.py` the QP's structure, its linearisation and the OSQP solve
(one `osqp.OSQP` per obstacle count, fixed sparsity, values updated in place, explicit warm
starts, polished solutions: see its docstring); `planning/mpc_guide.py` the guide path. Beyond
numpy they need osqp and scipy (sparse matrices, the guide path's Dijkstra).

Fallback. If the first QP of a planning step is infeasible (e.g. the hard contact
constraints cannot be met) or fails, the command is the safe one — slow down to
`fallback_speed_scale` × the current speed and keep the heading — and `fallbacks` is
incremented (the next step then starts cold); a later SCP iteration that fails keeps the
previous iterate. Planning never raises for a solver problem and the command is always
clipped to the bounds of Eq. 2.
"""

from __future__ import annotations

import dataclasses as dc
import logging
import signal

import numpy as np

from emonav_drake.navigation.lip_world import PlannerInput
from emonav_drake.params import EmoNavConfig
from emonav_drake.planning.dwa import ResponseMemory
from emonav_drake.planning.mpc_guide import GuidePath
from emonav_drake.planning.mpc_model import HorizonModel
from emonav_drake.planning.mpc_qp import (
    QpLayout,
    SolveInterrupted,
    build_layout,
    hit_time_limit,
    linearise,
    shift_duals,
    solution_accepted,
    solve_qp,
    solved_exactly,
)
from emonav_drake.planning.mpc_response import ResponseHorizonModel
from emonav_drake.robot.step_response import StepResponseModel

log = logging.getLogger(__name__)

_CONVERGED = 1e-4  # SCP stops when no command changes by more than this
# The counters a planning step adds to (restored when an interrupted step is redone).
_STEP_COUNTERS = ("fallbacks", "plans", "qp_solves", "qp_failures", "qp_inexact", "time_limit_hits")


@dc.dataclass(frozen=True)
class _Plan:
    """A plan kept for warm-starting the next planning step (never modified)."""

    u: np.ndarray  # (N, 2): (u_v, u_Δθ) per step
    y: np.ndarray  # (m,) OSQP dual solution
    key: tuple[int, int]  # layout (P, S)
    step: int  # the walking step it was planned at

    def __post_init__(self) -> None:
        self.u.flags.writeable = False
        self.y.flags.writeable = False


@dc.dataclass(frozen=True)
class MpcMemory:
    """What the MPC carries from one walking step to the next: its memory.

    `plan_with_memory` never modifies a memory, it returns a new one (which may share the
    guide path, itself never modified after construction). In the Drake diagram the
    memory is an abstract state of `NavigationPlanner` (deep-copied in and out).
    """

    plan: _Plan | None = None  # the previous step's plan and duals (the warm start)
    guide: GuidePath | None = None  # the guide path of the episode's static discs …
    guide_key: tuple | None = None  # … and what it was built for (goal, discs)
    # With a step-response model: u_{k−2} and the pose one step ago (v̄ is measured).
    response: ResponseMemory | None = None


class MpcPlanner:
    """MPC over LIP walking steps with linearised, emotion-aware collision constraints.

    Implements the planner interface (`name`, `initial_memory()`, `plan_with_memory`,
    `reset()`, `plan(PlannerInput)`; see `planners.protocol.Planner`), so it runs
    in the navigation diagram (`emonav sim --planner mpc`) and as a policy on the
    Gymnasium environment. The formulation is in the module docstring.

    Args:
        config: robot bounds and LIP constants, discomfort distances and the `mpc` params.
        response: None plans with the LIP (paper Eq. 1); a `StepResponseModel` plans with
            the robot's fitted step response instead (`planning/mpc_response.py`): the commands
            already sent (u_{k−2} from the memory, u_{k−1} = `obs.last_command`) first, the
            step-averaged speed measured from the memory's previous pose.

    Attributes:
        fallbacks: planning steps that fell back to the safe command (never reset).
        plans, qp_solves, qp_failures: counters since construction.
        time_limit_hits: QPs cut by OSQP's wall-clock safety (`mpc.time_limit`) since
            construction; each makes that plan depend on the machine's load (a warning is
            logged), so a reproducible run has none.
        last_info: diagnostics of the last planning step (solves, iterations, statuses,
            OSQP run time [s], whether it fell back).
    """

    name = "mpc"

    def __init__(self, config: EmoNavConfig, response: StepResponseModel | None = None) -> None:
        self.config = config
        self.params = config.mpc
        self.response = response
        # The horizon's constants and solver-free model (rollout, Jacobian, obstacles,
        # seeds, nonlinear cost): `planning/mpc_model.py` (`planning/mpc_response.py` with a
        # step-response model).
        self.model = (
            HorizonModel(config) if response is None else ResponseHorizonModel(config, response)
        )
        self.horizon = self.model.horizon
        self.hard_steps = self.model.hard_steps
        # OSQP workspaces: a cache (see the module docstring: a plan does not depend on
        # what they solved before); the planner's memory is `MpcMemory`.
        self._layouts: dict[tuple[int, int], QpLayout] = {}
        self._memory = self.initial_memory()
        self.fallbacks = 0
        self.plans = 0
        self.qp_solves = 0
        self.qp_failures = 0
        self.time_limit_hits = 0
        self.qp_inexact = 0  # accepted solves OSQP did not report as solved exactly
        self.interrupted_solves = 0  # solves a SIGINT stopped (their planning step redone)
        self.last_info: dict = {}

    # ------------------------------------------------------------------ interface
    def initial_memory(self) -> MpcMemory:
        """The memory at the start of an episode: no previous plan, no guide path."""
        return MpcMemory()

    def reset(self) -> None:
        """Forget the previous plan and the guide path (a new episode); counters are kept."""
        self._memory = self.initial_memory()

    def plan(self, obs: PlannerInput) -> np.ndarray:
        """The command (u_v [m/s], u_Δθ [rad]) for this walking step, with the planner's
        own memory (for the Gymnasium env and scripts; call `reset` between episodes)."""
        command, self._memory = self.plan_with_memory(obs, self._memory)
        return command

    def plan_with_memory(
        self, obs: PlannerInput, memory: MpcMemory | None
    ) -> tuple[np.ndarray, MpcMemory]:
        """The command for this walking step and the memory for the next one.

        A deterministic function of (obs, memory), bit for bit, whatever the planner
        object solved before; `memory` is not modified. The previous plan warm-starts
        this step only if it was planned at step `obs.step − 1`.

        A SIGINT that arrives inside an OSQP solve stops the solve without reaching
        Python (OSQP handles it): the unfinished plan is thrown away, the signal is passed
        on to the process's SIGINT handler (Python's default raises `KeyboardInterrupt`),
        and if that handler lets the run go on (SIGINT ignored, or a handler that only
        asks for a stop later) the whole planning step is planned again from the same
        input and memory: the same command, bit for bit, as without the signal. A SIGINT
        that reaches OSQP after its last check (while it polishes) leaves a finished,
        usable solve; `solve_qp` sends that signal again to the process's handler.
        """
        counters = {name: getattr(self, name) for name in _STEP_COUNTERS}
        while True:
            try:
                return self._plan_once(obs, memory)
            except SolveInterrupted:
                for name, value in counters.items():  # the redone step counts once
                    setattr(self, name, value)
                self.interrupted_solves += 1
                pass_on_sigint()

    def _plan_once(
        self, obs: PlannerInput, memory: MpcMemory | None
    ) -> tuple[np.ndarray, MpcMemory]:
        """`plan_with_memory` without the handling of an interrupted solve."""
        memory = self.initial_memory() if memory is None else memory
        self.plans += 1
        p = self.params
        lo, hi = self.model.lo, self.model.hi
        rb = obs.robot
        p0 = np.array([rb.x, rb.y], dtype=float)
        th0, v0 = float(rb.heading), float(rb.speed)
        last = np.asarray(obs.last_command, dtype=float)
        model, response_memory = self.model, None
        if self.response is not None:  # the commands already sent, the speed v̄
            sent = memory.response or ResponseMemory()
            v0 = sent.step_speed(rb, self.config.robot.step_time)
            model = self.model.with_committed(sent.committed(obs))
            response_memory = ResponseMemory.after(obs)
        goal = np.asarray(obs.goal_xy, dtype=float)
        obst = self.model.obstacles(obs.crowd)
        guide, guide_key = self._guide_for(p0, goal, obs, memory)
        has_discs = len(np.asarray(obs.crowd.static_radii).reshape(-1)) > 0
        target = self.references(p0, goal, guide if has_discs else None)
        key = (obst["num_ped"], obst["num_static"])
        layout = self._layout(key)
        info = _new_info(int(obs.step))
        self.last_info = info

        prev = memory.plan
        prev_u = None
        y0 = np.zeros(layout.m)
        if prev is not None and prev.step == obs.step - 1 and prev.key == key:
            prev_u = np.vstack([prev.u[1:], prev.u[-1:]])
            y0 = shift_duals(prev.y, layout, self.horizon)
        u_bar = self._choose_seed(model, p0, th0, v0, last, target, obst, prev_u)
        solved, y_sol = self._scp(model, u_bar, y0, p0, th0, v0, last, target, obst, layout, info)

        if solved is None:
            self.fallbacks += 1
            info["fallback"] = True
            # No plan for this step: the next one starts cold.
            command = np.array([p.fallback_speed_scale * v0, 0.0])
            return np.clip(command, lo, hi), MpcMemory(None, guide, guide_key, response_memory)
        new_plan = _Plan(solved.copy(), y_sol.copy(), key, int(obs.step))
        command = np.clip(solved[0].copy(), lo, hi)
        return command, MpcMemory(new_plan, guide, guide_key, response_memory)

    def _scp(
        self,
        model: HorizonModel,
        u_bar: np.ndarray,
        y0: np.ndarray,
        p0: np.ndarray,
        th0: float,
        v0: float,
        last: np.ndarray,
        target: np.ndarray,
        obst: dict,
        layout: QpLayout,
        info: dict,
    ) -> tuple[np.ndarray | None, np.ndarray]:
        """The SCP iterations from the seed u_bar (re-linearise → update the QP → solve):
        the last solved plan (N, 2), None if the first QP failed, and its duals."""
        n = self.horizon
        solved: np.ndarray | None = None
        y_sol = y0
        x_warm = None
        for it in range(self.params.scp_iterations):
            lin = linearise(model, u_bar, p0, th0, v0, last, target, obst, layout)
            if x_warm is None:
                x_warm = np.concatenate([u_bar[:, 0], u_bar[:, 1], lin["s0"]])
            z, y, ok = self._solve(layout, lin, x_warm, y_sol, first=(it == 0), info=info)
            if not ok:
                break
            u_new = np.clip(np.stack([z[:n], z[n : 2 * n]], axis=1), self.model.lo, self.model.hi)
            solved, y_sol, x_warm = u_new, y, z
            change = float(np.abs(u_new - u_bar).max())
            u_bar = u_new
            if change < _CONVERGED:
                break
        return solved, y_sol

    # ------------------------------------------------------------------ reference
    def _guide_for(
        self, p0: np.ndarray, goal: np.ndarray, obs: PlannerInput, memory: MpcMemory
    ) -> tuple[GuidePath | None, tuple | None]:
        """The guide path to keep: the memory's if it was built for the same goal and
        discs and covers the robot, else a new one; without static discs the memory's,
        unused (the straight line to the goal is the guide then); none for a global route's
        sub-goal (the route already goes round the walls and discs, and a guide rebuilt
        for a sub-goal that moves every step would cost ~70 ms a step)."""
        if obs.goal_is_subgoal:
            return None, None
        p, r = self.params, self.config.robot
        crowd = obs.crowd
        centers = np.asarray(crowd.static_centers, dtype=float).reshape(-1, 2)
        radii = np.asarray(crowd.static_radii, dtype=float).reshape(-1)
        if not len(radii):
            return memory.guide, memory.guide_key
        key = (goal.tobytes(), centers.tobytes(), radii.tobytes(), float(crowd.static_discomfort))
        if memory.guide is not None and memory.guide_key == key and memory.guide.covers(p0):
            return memory.guide, memory.guide_key
        r_col = radii + r.radius + p.collision_margin
        r_zone = radii + r.radius + crowd.static_discomfort + p.discomfort_margin
        guide = GuidePath(
            goal,
            centers,
            r_col,
            r_zone,
            p0,
            p.guide_resolution,
            p.guide_padding,
            p.guide_zone_cost,
        )
        return guide, key

    def references(
        self, p0: np.ndarray, goal: np.ndarray, guide: GuidePath | None = None
    ) -> np.ndarray:
        """Reference positions p_k^ref (N, 2) for the step ends: along the guide path (or
        the straight line without one), at full-speed progress plus `reference_lead` from
        the robot, clamped at the goal."""
        p, r = self.params, self.config.robot
        path = None if guide is None else guide.path(p0)
        if path is None:
            path = np.stack([p0, goal])
        arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(path, axis=0), axis=1))])
        step = 2.0 * self.model.c * r.max_speed  # a full-speed step [m]
        want = np.minimum(step * np.arange(1, self.horizon + 1) + p.reference_lead, arc[-1])
        return np.stack([np.interp(want, arc, path[:, 0]), np.interp(want, arc, path[:, 1])], -1)

    # ------------------------------------------------------------------ model
    def rollout(
        self, p0: np.ndarray, th0: float, v0: float, u: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Exact LIP step map over the horizon for plans u (B, N, 2): positions (B, N, 2),
        headings (B, N), displacements (B, N) (`HorizonModel.rollout`)."""
        return self.model.rollout(p0, th0, v0, u)

    def jacobian(self, phi: np.ndarray, dx: np.ndarray) -> np.ndarray:
        """∂p_{k+1}/∂u for one plan: (N, 2N, 2) (`HorizonModel.jacobian`)."""
        return self.model.jacobian(phi, dx)

    def nonlinear_cost(
        self,
        u: np.ndarray,
        p0: np.ndarray,
        th0: float,
        v0: float,
        last: np.ndarray,
        target: np.ndarray,
        obst: dict,
    ) -> np.ndarray:
        """The QP's cost on the exact rollout of plans u (B, N, 2): (B,) (`HorizonModel`)."""
        return self.model.nonlinear_cost(u, p0, th0, v0, last, target, obst)

    # ------------------------------------------------------------------ seeds
    def _choose_seed(
        self,
        model: HorizonModel,
        p0: np.ndarray,
        th0: float,
        v0: float,
        last: np.ndarray,
        target: np.ndarray,
        obst: dict,
        prev_u: np.ndarray | None,
    ) -> np.ndarray:
        """The seed with the lowest nonlinear cost (the previous plan first, with a bonus)."""
        seeds = model.seeds(th0, p0, target)
        if prev_u is not None:
            seeds = np.concatenate([prev_u[None], seeds], axis=0)
        cost = model.nonlinear_cost(seeds, p0, th0, v0, last, target, obst)
        if prev_u is not None:
            cost[0] -= self.params.previous_plan_bonus * abs(cost[0])
        return seeds[int(np.argmin(cost))].copy()

    # ------------------------------------------------------------------ QP
    def _layout(self, key: tuple[int, int]) -> QpLayout:
        """The QP structure for (P pedestrians, S discs), built once and kept."""
        if key not in self._layouts:
            self._layouts[key] = build_layout(
                key, self.horizon, self.hard_steps, self.params.slack_quadratic_weight
            )
        return self._layouts[key]

    def _solve(
        self,
        layout: QpLayout,
        lin: dict,
        x0: np.ndarray,
        y0: np.ndarray,
        first: bool,
        info: dict,
    ) -> tuple[np.ndarray, np.ndarray, bool]:
        """One QP with OSQP (`mpc_qp.solve_qp`), counted in the diagnostics; a solve cut
        by the wall-clock safety is counted and logged."""
        p = self.params
        res = solve_qp(layout, lin, x0, y0, first, p)
        self.qp_solves += 1
        info["solves"] += 1
        info["iterations"] += int(res.info.iter)
        info["qp_iterations"].append(int(res.info.iter))
        info["status"].append(str(res.info.status))
        info["run_time"] += float(res.info.run_time)
        info["qp_run_times"].append(float(res.info.run_time))
        if hit_time_limit(res):
            self.time_limit_hits += 1
            info["time_limit_hits"] += 1
            log.warning(
                "MPC: OSQP stopped by its wall-clock safety (mpc.time_limit %.3g s) after "
                "%d iterations at planning step %s: this plan depends on the machine's load",
                p.time_limit,
                int(res.info.iter),
                info["step"],
            )
        x = np.asarray(res.x, dtype=float)
        if not solution_accepted(res, x):
            self.qp_failures += 1
            return x, y0, False
        if not solved_exactly(res):
            self.qp_inexact += 1
            info["inexact"] += 1
        return x.copy(), np.asarray(res.y, dtype=float).copy(), True


def _new_info(step: int) -> dict:
    """Empty diagnostics of one planning step (`MpcPlanner.last_info`)."""
    return {
        "step": step,
        "solves": 0,
        "iterations": 0,
        "status": [],
        "run_time": 0.0,
        "qp_run_times": [],
        "qp_iterations": [],
        "fallback": False,
        "time_limit_hits": 0,
        "inexact": 0,
    }


def pass_on_sigint() -> None:
    """Deliver a SIGINT that a solver swallowed to the handler Python has for it now.

    Python's default handler and `SIG_DFL` → `KeyboardInterrupt` (the run stops: exit 130,
    resumable); `SIG_IGN` → nothing (the caller solves again); any other handler (e.g. a
    trainer's stop request) is called and, if it returns, the caller solves again.
    """
    handler = signal.getsignal(signal.SIGINT)
    if handler is signal.SIG_IGN:
        return
    if callable(handler) and handler is not signal.default_int_handler:
        handler(signal.SIGINT, None)
        return
    raise KeyboardInterrupt
