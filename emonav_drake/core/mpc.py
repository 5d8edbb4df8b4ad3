"""Model predictive control on the LIP model, solved with OSQP — the model-based baseline.

The planner answers one walking-step command u_0 = (u_v, u_Δθ) per step by optimising a
horizon of N walking steps of the paper's LIP step map (Eq. 1, `core/lip.py`) against a
constant-velocity prediction of the pedestrians and the static discs (privileged
`CrowdSnapshot`, as DWA), then applying the first command (receding horizon).

Decision variables (one QP, n = 2N + N·O + (N − h)·P, O = P pedestrians + S discs)
    u_v,k ∈ [0, ū_v]  and  u_Δθ,k ∈ [−ū_Δθ, ū_Δθ],  k = 0 … N−1   (paper Eq. 2)
    s_k,o ∈ [0, d_o^zone − d_o^col]   discomfort slack of step k, obstacle o
    σ_k,i ≥ 0                          late-contact slack, pedestrians, steps k ≥ h

Dynamics (exact LIP step map, written in the world frame). Step k is walked along
φ_k = θ_0 + Σ_{j≤k} u_Δθ,j; the speed at its end is the command, v_{k+1} = u_v,k
(v_0 = the robot's current speed), and the CoM advances
    Δx_k = v_k sinh(ωT)/ω + d_k (1 − cosh ωT),  d_k = (v_k cosh ωT − u_v,k)/(ω sinh ωT)
         = c (v_k + u_v,k),  c = tanh(ωT/2)/ω,
so p_{k+1} = p_k + c (v_k + u_v,k) (cos φ_k, sin φ_k). Speeds enter linearly, headings
through cos/sin: the positions p_1 … p_N are nonlinear in u. They are linearised around
a reference ū (the shifted previous plan or a seed, then each SCP iterate):
    p_k(u) ≈ p̄_k + J_k (u − ū),
    ∂p_k/∂u_v,m  = c e(φ_m)[m < k] + c e(φ_{m+1})[m + 1 < k],
    ∂p_k/∂u_Δθ,i = Σ_{i ≤ j < k} c (v̄_j + ū_v,j) e⊥(φ_j),
with e(φ) = (cos φ, sin φ) and e⊥ = (−sin φ, cos φ); no state variables are needed
(condensed form), J is built for all k at once with cumulative sums.

Constraints, for each step end k = 1 … N and obstacle o with centre c_o(t_k)
(pedestrians: c_o + v_o kT; discs: fixed), linearised as half-planes around p̄_k with
n_k,o = (p̄_k − c_o)/|p̄_k − c_o| (a half-plane tangent to the disc: conservative):
    n_k,oᵀ (p_k(u) − c_o) + s_k,o [+ σ_k,o] ≥ d_o^zone
    d_o^zone = r_o + r_robot + d_o^emo + discomfort_margin  (pedestrian: emotion distance;
               disc: d_static) — the emotion-aware discomfort zone, a soft constraint;
    d_o^col  = r_o + r_robot + collision_margin — contact: the slack cap s ≤ d^zone − d^col
               makes it hard for every disc and for pedestrians in the first h steps
               (`hard_pedestrian_steps`); later pedestrian steps add σ (soft, costly),
               because a constant-velocity prediction that far is only a guess.
Box rows keep u within Eq. 2 and within a trust region |u_Δθ − ū_Δθ| ≤ Δ around the
linearisation point.

Cost (½ zᵀ P z + qᵀ z, P built from the Gauss–Newton approximation of the goal term)
    Σ_k w_k |p_k(u) − p_k^ref|²                  goal reaching, w_N += terminal_weight
  + w_sv Σ_k (u_v,k − u_v,k−1)² + w_sθ Σ_k (u_Δθ,k − u_Δθ,k−1)²   smoothness (k = 0 uses
                                                   the last command)
  + w_θ Σ_k u_Δθ,k²                                turning effort
  + Σ_k,o γ_o^k (ρ_zone s_k,o + ρ_col σ_k,o) + ε Σ (s² + σ²)       slack penalties
    (γ_o = prediction_discount for pedestrians, 1 for discs; the linear penalty is exact).
The reference p_k^ref lies on a guide path to the goal, k full-speed steps plus
`reference_lead` ahead of the robot (clamped at the goal): a bounded residual that asks
for the speed limit and stops at the goal. The guide path is the shortest path around the
static discs on a grid (`GuidePath`: Dijkstra from the goal, contact cells blocked,
discomfort cells dearer), built once per episode — without it the local goal term leaves
the robot in the pockets that two or three discs can form.

SCP loop. An initial guess is chosen by evaluating the nonlinear cost of a few seed
plans with one vectorised rollout: the previous plan shifted by one step (with a small
hysteresis bonus, so the robot does not swap sides of an obstacle) and "turn towards
heading bearing+ψ at full or half speed, then hold" for a fan of offsets ψ, plus
standing still. This choice of seed is what picks the side on which obstacles are
passed; the SCP iterations (re-linearise → update the QP in place → solve) then refine
it for a fixed number of iterations, stopping early when the plan stops changing.

OSQP. One `osqp.OSQP` object per obstacle count (P, S), set up once with a fixed sparsity
pattern: every QP only rewrites the values of P and A, q, l and u (`update`), so OSQP
re-factorises numerically without a new symbolic analysis. Every solve is explicitly
warm-started: the first of a planning step with the previous plan's primal and dual
solution shifted by one step, the next ones with the previous iterate. Solutions are
polished (active-set refinement), so commands on a bound are exactly on it.

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
iterations and rho adapted every `_RHO_INTERVAL` = 50 iterations (OSQP's iteration-based
rule, set explicitly: OSQP also has a rule that adapts rho after a fraction of the setup
*time*). So a plan is the same on an idle and on a starved machine. OSQP's wall-clock
`time_limit` (`mpc.time_limit`, 1 s per QP, ~1000× what a QP takes here) is only a
safety: a solve it cuts would depend on the load, so each time it fires the planner counts
it (`time_limit_hits`) and logs a warning naming the planning step; no result we publish
had one (`tests/test_mpc_load.py` runs the MPC beside a CPU hog and under stalls).

scipy (a dependency of osqp) provides the sparse matrices OSQP takes and the Dijkstra of
the guide path; the module needs nothing else beyond numpy.

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
import math

import numpy as np
import osqp
import scipy.sparse as sp
from scipy.sparse import csgraph

from emonav_drake.core.navigation import PlannerInput
from emonav_drake.params import EmoNavConfig, MpcParams

log = logging.getLogger(__name__)

_HARD_PENALTY = 1e4  # seed selection: cost per metre of hard-constraint violation
_MIN_NORMAL_DISTANCE = 1e-6  # [m]
_CONVERGED = 1e-4  # SCP stops when no command changes by more than this
_MAX_ITER_RESIDUAL = 1e-2  # a solve stopped by max_iter/time_limit is kept below this [m]
_RHO0 = 0.1  # OSQP's initial rho, restored at each planning step
_RHO_INTERVAL = 50  # ADMM iterations between rho adaptations (never OSQP's timed rule)
_GUIDE_MAX_CELLS = 60_000  # the guide grid is coarsened beyond this


_OK = {int(osqp.SolverStatus.OSQP_SOLVED), int(osqp.SolverStatus.OSQP_SOLVED_INACCURATE)}
_TIME_LIMIT = int(osqp.SolverStatus.OSQP_TIME_LIMIT_REACHED)
_STOPPED = {int(osqp.SolverStatus.OSQP_MAX_ITER_REACHED), _TIME_LIMIT}


@dc.dataclass
class _Layout:
    """The QP's fixed structure for P pedestrians and S discs, and its OSQP object."""

    num_ped: int
    num_static: int
    n: int  # variables
    m: int  # constraints
    src_a: np.ndarray  # CSC slot of A → index into the A value buffer
    src_p: np.ndarray  # CSC slot of P → index into the P value buffer
    buf_a: np.ndarray  # A value buffer: dense row coefficients (N·O·2N), then 1.0
    buf_p: np.ndarray  # P value buffer: dense (2N)², then the slack weight ε
    soft_rows: np.ndarray  # obstacle rows (k·O + o) that carry a late-contact slack σ
    a_mat: sp.csc_matrix  # the pattern of A (values written at the first solve)
    p_mat: sp.csc_matrix  # the pattern of P (upper triangle)
    zero_q: np.ndarray  # (n,) zeros: q before a matrix update (see `_solve`)
    solver: osqp.OSQP | None = None


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


class GuidePath:
    """Shortest path to the goal around the static discs, on a grid (built once per episode).

    The goal term of the MPC is local; alone it leaves the robot in the pockets that a few
    discs can form. This cost-to-go field (Dijkstra from the goal over an 8-connected grid;
    cells within contact distance of a disc are blocked, cells in its discomfort zone cost
    `zone_cost` times more) gives the reference the goal term follows instead.

    Args:
        goal: (2,) [m].
        centers: the static discs' centres (S, 2) [m].
        r_col, r_zone: contact and discomfort distances from each centre (S,) [m].
        start: (2,) a point the grid must cover (the robot's position) [m].
        resolution: cell size [m] (coarser if the grid would pass 60 000 cells).
        padding: grid margin around start, goal and discs [m].
        zone_cost: extra cost factor inside discomfort zones.
    """

    def __init__(
        self,
        goal: np.ndarray,
        centers: np.ndarray,
        r_col: np.ndarray,
        r_zone: np.ndarray,
        start: np.ndarray,
        resolution: float,
        padding: float,
        zone_cost: float,
    ) -> None:
        pts = np.vstack([goal[None], start[None], centers.reshape(-1, 2)])
        reach = np.concatenate([[0.0, 0.0], r_zone])
        lo = (pts - reach[:, None]).min(axis=0) - padding
        hi = (pts + reach[:, None]).max(axis=0) + padding
        # A far goal would make a huge grid: coarsen it to at most _GUIDE_MAX_CELLS cells.
        resolution = max(resolution, math.sqrt(float(np.prod(hi - lo)) / _GUIDE_MAX_CELLS))
        self.res = resolution
        self.origin = lo
        self.shape = nx, ny = (np.ceil((hi - lo) / resolution).astype(int) + 1).tolist()
        xs = lo[0] + resolution * np.arange(nx)
        ys = lo[1] + resolution * np.arange(ny)
        cx, cy = np.meshgrid(xs, ys, indexing="ij")
        cost = np.ones((nx, ny))
        blocked = np.zeros((nx, ny), dtype=bool)
        for c, r_c, r_z in zip(centers.reshape(-1, 2), r_col, r_zone, strict=True):
            d = np.hypot(cx - c[0], cy - c[1])
            blocked |= d < r_c
            cost = np.where(d < r_z, np.maximum(cost, zone_cost), cost)
        idx = np.arange(nx * ny).reshape(nx, ny)
        rows, cols, weights = [], [], []
        for dx, dy in ((1, 0), (0, 1), (1, 1), (1, -1)):
            i0, i1 = max(0, -dx), nx - max(0, dx)
            j0, j1 = max(0, -dy), ny - max(0, dy)
            a = idx[i0:i1, j0:j1].ravel()
            b = idx[i0 + dx : i1 + dx, j0 + dy : j1 + dy].ravel()
            keep = ~(blocked.ravel()[a] | blocked.ravel()[b])
            a, b = a[keep], b[keep]
            length = resolution * math.hypot(dx, dy)
            rows.append(a)
            cols.append(b)
            weights.append(length * 0.5 * (cost.ravel()[a] + cost.ravel()[b]))
        graph = sp.csr_matrix(
            (np.concatenate(weights), (np.concatenate(rows), np.concatenate(cols))),
            shape=(nx * ny, nx * ny),
        )
        self.goal = np.array(goal, dtype=float)
        self.goal_cell = self._cell(self.goal)
        dist, pred = csgraph.dijkstra(
            graph, directed=False, indices=int(self.goal_cell), return_predecessors=True
        )
        self.dist, self.pred = dist, pred
        self.blocked = blocked
        for a in (self.origin, self.goal, self.dist, self.pred, self.blocked):
            a.flags.writeable = False  # part of the planner's memory: never modified

    def covers(self, p: np.ndarray) -> bool:
        """Whether p lies on the grid."""
        ij = (np.asarray(p) - self.origin) / self.res
        return bool(np.all(ij >= 0) and np.all(ij <= np.array(self.shape) - 1))

    def _cell(self, p: np.ndarray) -> int:
        ij = np.rint((np.asarray(p) - self.origin) / self.res).astype(int)
        ij = np.clip(ij, 0, np.array(self.shape) - 1)
        return int(ij[0] * self.shape[1] + ij[1])

    def _center(self, cells: np.ndarray) -> np.ndarray:
        ij = np.stack(np.divmod(cells, self.shape[1]), axis=-1)
        return self.origin + self.res * ij

    def path(self, p: np.ndarray) -> np.ndarray | None:
        """Waypoints (W, 2) from p to the goal, or None if the goal cannot be reached."""
        cell = self._cell(p)
        if not np.isfinite(self.dist[cell]):  # p in a blocked cell: best neighbour
            i, j = divmod(cell, self.shape[1])
            best, best_d = -1, np.inf
            for di in range(-3, 4):
                for dj in range(-3, 4):
                    ii, jj = i + di, j + dj
                    if 0 <= ii < self.shape[0] and 0 <= jj < self.shape[1]:
                        c = ii * self.shape[1] + jj
                        if self.dist[c] < best_d:
                            best, best_d = c, self.dist[c]
            if best < 0:
                return None
            cell = best
        cells = [cell]
        while cells[-1] != self.goal_cell:
            nxt = int(self.pred[cells[-1]])
            if nxt < 0:
                return None
            cells.append(nxt)
        pts = self._center(np.array(cells))
        pts[0] = p
        pts[-1] = self.goal
        return pts


class MpcPlanner:
    """MPC over LIP walking steps with linearised, emotion-aware collision constraints.

    Implements the planner interface (`name`, `initial_memory()`, `plan_with_memory`,
    `reset()`, `plan(PlannerInput)`; see `systems.navigation_planner.Planner`), so it runs
    in the navigation diagram (`emonav sim --planner mpc`) and as a policy on the
    Gymnasium environment. The formulation is in the module docstring.

    Args:
        config: robot bounds and LIP constants, discomfort distances and the `mpc` params.

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

    def __init__(self, config: EmoNavConfig) -> None:
        self.config = config
        p: MpcParams = config.mpc
        r = config.robot
        self.params = p
        self.horizon = n = p.horizon_steps
        self.hard_steps = min(p.hard_pedestrian_steps, n)
        self._c = math.tanh(r.omega * r.step_time / 2.0) / r.omega
        self._lo = np.array([0.0, -r.max_heading_change])
        self._hi = np.array([r.max_speed, r.max_heading_change])
        self._times = r.step_time * np.arange(1, n + 1)  # step ends t_1 … t_N [s]
        self._w_goal = np.full(n, p.goal_weight)
        self._w_goal[-1] += p.terminal_weight
        self._w_goal2 = np.repeat(self._w_goal, 2)  # per (k, x|y)
        self._lo_u = np.repeat(self._lo, n)  # (u_v,0…N−1, u_Δθ,0…N−1)
        self._hi_u = np.repeat(self._hi, n)
        # Constant part of the u-block Hessian: smoothness, turning effort, regulariser.
        diff = np.eye(n) - np.eye(n, k=-1)
        dtd = diff.T @ diff
        self._p_const = np.zeros((2 * n, 2 * n))
        self._p_const[:n, :n] = 2.0 * p.speed_smoothness_weight * dtd
        self._p_const[n:, n:] = 2.0 * p.turn_smoothness_weight * dtd + 2.0 * p.turn_weight * np.eye(
            n
        )
        self._p_const += 1e-6 * np.eye(2 * n)
        # Masks of the Jacobian of p_{k+1} (row k) w.r.t. u_v,m: m ≤ k and m + 1 ≤ k.
        kk, mm = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
        self._mask0 = (mm <= kk).astype(float)
        self._mask1 = (mm <= kk - 1).astype(float)
        self._tri = mm <= kk  # u_Δθ,i affects p_{k+1} for i ≤ k
        # OSQP workspaces: a cache (see the module docstring: a plan does not depend on
        # what they solved before); the planner's memory is `MpcMemory`.
        self._layouts: dict[tuple[int, int], _Layout] = {}
        self._memory = self.initial_memory()
        self.fallbacks = 0
        self.plans = 0
        self.qp_solves = 0
        self.qp_failures = 0
        self.time_limit_hits = 0
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
        """
        memory = self.initial_memory() if memory is None else memory
        self.plans += 1
        p = self.params
        n = self.horizon
        rb = obs.robot
        p0 = np.array([rb.x, rb.y], dtype=float)
        th0, v0 = float(rb.heading), float(rb.speed)
        last = np.asarray(obs.last_command, dtype=float)
        goal = np.asarray(obs.goal_xy, dtype=float)
        obst = self._obstacles(obs)
        guide, guide_key = self._guide_for(p0, goal, obs, memory)
        has_discs = len(np.asarray(obs.crowd.static_radii).reshape(-1)) > 0
        target = self.references(p0, goal, guide if has_discs else None)
        key = (obst["num_ped"], obst["num_static"])
        layout = self._layout(key)
        info = {
            "step": int(obs.step),
            "solves": 0,
            "iterations": 0,
            "status": [],
            "run_time": 0.0,
            "qp_run_times": [],
            "qp_iterations": [],
            "fallback": False,
            "time_limit_hits": 0,
        }
        self.last_info = info

        prev = memory.plan
        prev_u = None
        y0 = np.zeros(layout.m)
        if prev is not None and prev.step == obs.step - 1 and prev.key == key:
            prev_u = np.vstack([prev.u[1:], prev.u[-1:]])
            y0 = self._shift_duals(prev.y, layout)
        u_bar = self._choose_seed(p0, th0, v0, last, target, obst, prev_u)

        solved: np.ndarray | None = None
        y_sol = y0
        x_warm = None
        for it in range(p.scp_iterations):
            lin = self._linearise(u_bar, p0, th0, v0, last, target, obst, layout)
            if x_warm is None:
                x_warm = np.concatenate([u_bar[:, 0], u_bar[:, 1], lin["s0"]])
            z, y, ok = self._solve(layout, lin, x_warm, y_sol, first=(it == 0), info=info)
            if not ok:
                break
            u_new = np.clip(np.stack([z[:n], z[n : 2 * n]], axis=1), self._lo, self._hi)
            solved, y_sol, x_warm = u_new, y, z
            change = float(np.abs(u_new - u_bar).max())
            u_bar = u_new
            if change < _CONVERGED:
                break

        if solved is None:
            self.fallbacks += 1
            info["fallback"] = True
            # No plan for this step: the next one starts cold.
            command = np.array([p.fallback_speed_scale * v0, 0.0])
            return np.clip(command, self._lo, self._hi), MpcMemory(None, guide, guide_key)
        new_plan = _Plan(solved.copy(), y_sol.copy(), key, int(obs.step))
        command = np.clip(solved[0].copy(), self._lo, self._hi)
        return command, MpcMemory(new_plan, guide, guide_key)

    # ------------------------------------------------------------------ reference
    def _guide_for(
        self, p0: np.ndarray, goal: np.ndarray, obs: PlannerInput, memory: MpcMemory
    ) -> tuple[GuidePath | None, tuple | None]:
        """The guide path to keep: the memory's if it was built for the same goal and
        discs and covers the robot, else a new one; without static discs the memory's,
        unused (the straight line to the goal is the guide then)."""
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
        step = 2.0 * self._c * r.max_speed  # a full-speed step [m]
        want = np.minimum(step * np.arange(1, self.horizon + 1) + p.reference_lead, arc[-1])
        return np.stack([np.interp(want, arc, path[:, 0]), np.interp(want, arc, path[:, 1])], -1)

    # ------------------------------------------------------------------ model
    def rollout(
        self, p0: np.ndarray, th0: float, v0: float, u: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Exact LIP step map over the horizon for a batch of plans.

        Args:
            p0: (2,) CoM position at the current foot switch [m].
            th0: heading [rad]; v0: sagittal speed [m/s].
            u: (B, N, 2) commands.

        Returns:
            positions (B, N, 2) at the step ends, headings φ (B, N) walked in each step,
            and displacements Δx (B, N) of each step.
        """
        a, d = u[..., 0], u[..., 1]
        phi = th0 + np.cumsum(d, axis=-1)
        v = np.concatenate([np.full(a.shape[:-1] + (1,), v0), a[..., :-1]], axis=-1)
        dx = self._c * (v + a)
        e = np.stack([np.cos(phi), np.sin(phi)], axis=-1)
        pos = p0 + np.cumsum(dx[..., None] * e, axis=-2)
        return pos, phi, dx

    def jacobian(self, phi: np.ndarray, dx: np.ndarray) -> np.ndarray:
        """∂p_{k+1}/∂u for one plan: (N, 2N, 2), columns u_v,0…N−1 then u_Δθ,0…N−1."""
        n = self.horizon
        e = np.stack([np.cos(phi), np.sin(phi)], axis=-1)  # (N, 2)
        e_perp = np.stack([-e[:, 1], e[:, 0]], axis=-1)
        e_next = np.vstack([e[1:], np.zeros((1, 2))])
        jac = np.empty((n, 2 * n, 2))
        jac[:, :n] = self._c * (
            self._mask0[..., None] * e[None, :, :] + self._mask1[..., None] * e_next[None, :, :]
        )
        csum = np.cumsum(dx[:, None] * e_perp, axis=0)  # C_k = Σ_{j≤k} Δx_j e⊥(φ_j)
        before = np.vstack([np.zeros((1, 2)), csum[:-1]])  # C_{i−1}
        jac[:, n:] = np.where(self._tri[..., None], csum[:, None, :] - before[None, :, :], 0.0)
        return jac

    # ------------------------------------------------------------------ obstacles
    def _obstacles(self, obs: PlannerInput) -> dict:
        """Predicted centres (N, O, 2), zone and contact radii, slack caps and weights."""
        cfg, p = self.config, self.params
        crowd = obs.crowd
        ped_pos = np.asarray(crowd.positions, dtype=float).reshape(-1, 2)
        ped_vel = np.asarray(crowd.velocities, dtype=float).reshape(-1, 2)
        st_c = np.asarray(crowd.static_centers, dtype=float).reshape(-1, 2)
        st_r = np.asarray(crowd.static_radii, dtype=float).reshape(-1)
        n_ped, n_st = len(ped_pos), len(st_c)
        t = self._times[:, None, None]
        centers = np.concatenate(
            [ped_pos[None] + t * ped_vel[None], np.broadcast_to(st_c, (self.horizon, n_st, 2))],
            axis=1,
        )
        r_robot = cfg.robot.radius
        radii = np.concatenate([np.full(n_ped, crowd.radius), st_r])
        zone_d = np.concatenate(
            [
                np.asarray(crowd.discomfort, dtype=float).reshape(-1),
                np.full(n_st, crowd.static_discomfort),
            ]
        )
        r_col = radii + r_robot + p.collision_margin
        r_zone = np.maximum(radii + r_robot + zone_d + p.discomfort_margin, r_col)
        steps = np.arange(self.horizon)[:, None]
        weight = np.concatenate(
            [
                np.broadcast_to(p.prediction_discount**steps, (self.horizon, n_ped)),
                np.ones((self.horizon, n_st)),
            ],
            axis=1,
        )
        hard = np.ones((self.horizon, n_ped + n_st), dtype=bool)
        hard[self.hard_steps :, :n_ped] = False
        return {
            "num_ped": n_ped,
            "num_static": n_st,
            "centers": centers,  # (N, O, 2)
            "r_col": r_col,  # (O,)
            "r_zone": r_zone,  # (O,)
            "weight": weight,  # (N, O)
            "hard": hard,  # (N, O)
        }

    # ------------------------------------------------------------------ seeds
    def _seeds(self, th0: float, p0: np.ndarray, target: np.ndarray) -> np.ndarray:
        """Seed plans (B, N, 2): turn at the maximum rate to a heading, then hold it —
        walking at full or half speed all along, or standing while turning (the way out
        when facing an obstacle; from standing still the linearisation cannot see it, as
        turning on the spot moves no position), plus standing still."""
        p, r = self.params, self.config.robot
        n = self.horizon
        aim = target[-1]
        bearing = math.atan2(aim[1] - p0[1], aim[0] - p0[0])
        if p.seed_headings > 1:
            half = np.linspace(0.0, p.seed_max_offset, (p.seed_headings + 1) // 2)[1:]
            offsets = np.concatenate([[0.0], np.ravel(np.stack([half, -half], axis=1))])
        else:
            offsets = np.zeros(1)
        offsets = offsets[: p.seed_headings]
        turn = (bearing + offsets - th0 + math.pi) % (2 * math.pi) - math.pi  # (H,)
        dmax = r.max_heading_change
        done = dmax * np.arange(n)[None, :]
        d = np.sign(turn)[:, None] * np.clip(np.abs(turn)[:, None] - done, 0.0, dmax)
        u = np.empty((3, len(offsets), n, 2))
        u[0, ..., 0] = r.max_speed
        u[1, ..., 0] = 0.5 * r.max_speed
        u[2, ..., 0] = np.where(np.abs(d) >= dmax - 1e-12, 0.0, r.max_speed)  # turn, then go
        u[..., 1] = d[None]
        u = u.reshape(-1, n, 2)
        return np.concatenate([u, np.zeros((1, n, 2))], axis=0)

    def _choose_seed(
        self,
        p0: np.ndarray,
        th0: float,
        v0: float,
        last: np.ndarray,
        target: np.ndarray,
        obst: dict,
        prev_u: np.ndarray | None,
    ) -> np.ndarray:
        """The seed with the lowest nonlinear cost (the previous plan first, with a bonus)."""
        seeds = self._seeds(th0, p0, target)
        if prev_u is not None:
            seeds = np.concatenate([prev_u[None], seeds], axis=0)
        cost = self.nonlinear_cost(seeds, p0, th0, v0, last, target, obst)
        if prev_u is not None:
            cost[0] -= self.params.previous_plan_bonus * abs(cost[0])
        return seeds[int(np.argmin(cost))].copy()

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
        """The QP's cost evaluated on the exact rollout of plans u (B, N, 2): (B,)."""
        p = self.params
        pos, _, _ = self.rollout(p0, th0, v0, u)
        goal = (self._w_goal * ((pos - target) ** 2).sum(-1)).sum(-1)
        a = np.concatenate([np.full((len(u), 1), last[0]), u[..., 0]], axis=1)
        d = np.concatenate([np.full((len(u), 1), last[1]), u[..., 1]], axis=1)
        smooth = (
            p.speed_smoothness_weight * (np.diff(a, axis=1) ** 2).sum(-1)
            + p.turn_smoothness_weight * (np.diff(d, axis=1) ** 2).sum(-1)
            + p.turn_weight * (u[..., 1] ** 2).sum(-1)
        )
        if obst["centers"].shape[1] == 0:
            return goal + smooth
        dist = np.linalg.norm(pos[:, :, None, :] - obst["centers"][None], axis=-1)  # (B,N,O)
        cap = obst["r_zone"] - obst["r_col"]
        zone = np.clip(obst["r_zone"] - dist, 0.0, cap)
        contact = np.clip(obst["r_col"] - dist, 0.0, None)
        w = obst["weight"]
        contact_w = np.where(obst["hard"], _HARD_PENALTY, p.collision_weight * w)
        penalty = (p.discomfort_weight * w * zone + contact_w * contact).sum(axis=(1, 2))
        return goal + smooth + penalty

    # ------------------------------------------------------------------ QP
    def _layout(self, key: tuple[int, int]) -> _Layout:
        """The QP structure for (P pedestrians, S discs), built once and kept."""
        if key in self._layouts:
            return self._layouts[key]
        n = self.horizon
        n_ped, n_st = key
        n_obs = n_ped + n_st
        nu = 2 * n
        soft = [
            k * n_obs + o for k in range(self.hard_steps, n) for o in range(n_ped)
        ]  # rows with a σ
        soft_rows = np.array(soft, dtype=int)
        n_s, n_sig = n * n_obs, len(soft)
        nvar = nu + n_s + n_sig
        m = n * n_obs + nu + n_s + n_sig
        one = n * n_obs * nu  # index of the constant 1.0 in the A buffer
        rows, cols, src = [], [], []
        # Obstacle rows: u_v,m and u_Δθ,m for m ≤ k, then the slacks.
        for k in range(n):
            for o in range(n_obs):
                row = k * n_obs + o
                for c in list(range(k + 1)) + list(range(n, n + k + 1)):
                    rows.append(row)
                    cols.append(c)
                    src.append(row * nu + c)
                rows.append(row)
                cols.append(nu + row)
                src.append(one)
        for j, row in enumerate(soft):
            rows.append(row)
            cols.append(nu + n_s + j)
            src.append(one)
        # Identity rows for the box on u and on the slacks.
        base = n * n_obs
        for j in range(nvar):
            rows.append(base + j)
            cols.append(j)
            src.append(one)
        a_mat = sp.csc_matrix(
            (np.arange(1, len(src) + 1, dtype=float), (np.array(rows), np.array(cols))),
            shape=(m, nvar),
        )
        a_mat.sort_indices()
        order = a_mat.data.astype(int) - 1
        src_a = np.array(src)[order]
        # P: dense upper triangle of the u block, then the slack diagonal.
        iu, ju = np.triu_indices(nu)
        p_rows = np.concatenate([iu, np.arange(nu, nvar)])
        p_cols = np.concatenate([ju, np.arange(nu, nvar)])
        p_src = np.concatenate([iu * nu + ju, np.full(nvar - nu, nu * nu)])
        p_mat = sp.csc_matrix(
            (np.arange(1, len(p_src) + 1, dtype=float), (p_rows, p_cols)), shape=(nvar, nvar)
        )
        p_mat.sort_indices()
        src_p = p_src[p_mat.data.astype(int) - 1]
        buf_a = np.zeros(one + 1)
        buf_a[one] = 1.0
        buf_p = np.zeros(nu * nu + 1)
        buf_p[-1] = 2.0 * self.params.slack_quadratic_weight
        layout = _Layout(
            n_ped,
            n_st,
            nvar,
            m,
            src_a,
            src_p,
            buf_a,
            buf_p,
            soft_rows,
            a_mat,
            p_mat,
            np.zeros(nvar),
        )
        self._layouts[key] = layout
        return layout

    def _linearise(
        self,
        u_bar: np.ndarray,
        p0: np.ndarray,
        th0: float,
        v0: float,
        last: np.ndarray,
        target: np.ndarray,
        obst: dict,
        layout: _Layout,
    ) -> dict:
        """QP data (P and A values, q, l, u) linearised around the plan u_bar (N, 2)."""
        p = self.params
        n = self.horizon
        nu = 2 * n
        pos, phi, dx = self.rollout(p0, th0, v0, u_bar[None])
        pos, phi, dx = pos[0], phi[0], dx[0]
        jac = self.jacobian(phi, dx)  # (N, 2N, 2)
        ub = np.concatenate([u_bar[:, 0], u_bar[:, 1]])
        # Gauss–Newton goal term: with J2 (2N, 2N) = rows ∂/∂u, columns (k, x|y),
        # Σ_k w_k |p̄_k + J_k (u − ū) − p_k^ref|² = |J2ᵀ u + r|²_W, r = p̄ − p^ref − J2ᵀ ū.
        j2 = jac.transpose(1, 0, 2).reshape(nu, nu)
        j2w = j2 * self._w_goal2
        res = (pos - target).ravel() - j2.T @ ub
        layout.buf_p[: nu * nu] = (2.0 * (j2w @ j2.T) + self._p_const).ravel()
        q_u = 2.0 * (j2w @ res)
        q_u[0] -= 2.0 * p.speed_smoothness_weight * last[0]
        q_u[n] -= 2.0 * p.turn_smoothness_weight * last[1]
        # Box and trust region on u.
        lo_u, hi_u = self._lo_u.copy(), self._hi_u.copy()
        lo_u[n:] = np.maximum(lo_u[n:], ub[n:] - p.trust_region)
        hi_u[n:] = np.minimum(hi_u[n:], ub[n:] + p.trust_region)
        n_obs = obst["centers"].shape[1]
        n_sig = len(layout.soft_rows)
        if n_obs:
            diff = pos[:, None, :] - obst["centers"]  # (N, O, 2)
            dist = np.sqrt((diff**2).sum(-1))
            normal = self._normals(diff, dist, p0, obst["centers"], th0)
            coef = normal @ jac.transpose(0, 2, 1)  # (N, O, 2N): n_k,oᵀ J_k
            layout.buf_a[: n * n_obs * nu] = coef.ravel()
            # n·(p̄ − c) = |p̄ − c| where the normal came from p̄.
            signed = (normal * diff).sum(-1)
            lo_obs = (obst["r_zone"][None] - signed + coef @ ub).ravel()
            cap = np.broadcast_to(obst["r_zone"] - obst["r_col"], (n, n_obs)).ravel()
            ped_w = obst["weight"].ravel()
            q_s = p.discomfort_weight * ped_w
            q_sig = p.collision_weight * ped_w[layout.soft_rows]
            need = np.clip(obst["r_zone"][None] - dist, 0.0, None).ravel()
            s0 = np.minimum(need, cap)
            sig0 = (need - s0)[layout.soft_rows]
        else:
            lo_obs = cap = q_s = q_sig = s0 = sig0 = np.zeros(0)
        q = np.concatenate([q_u, q_s, q_sig])
        lower = np.concatenate([lo_obs, lo_u, np.zeros(len(cap) + n_sig)])
        upper = np.concatenate([np.full(len(lo_obs), np.inf), hi_u, cap, np.full(n_sig, np.inf)])
        return {
            "Px": layout.buf_p[layout.src_p],
            "Ax": layout.buf_a[layout.src_a],
            "q": q,
            "l": lower,
            "u": upper,
            "s0": np.concatenate([s0, sig0]),
        }

    @staticmethod
    def _normals(
        diff: np.ndarray, dist: np.ndarray, p0: np.ndarray, centers: np.ndarray, th0: float
    ) -> np.ndarray:
        """Unit normals (N, O, 2) of the half-planes: from the obstacle to the plan.

        Where the plan passes through an obstacle's centre, the direction from the centre
        to the robot's current position is used, or the robot's left if that too is 0.
        """
        normal = diff / np.maximum(dist, _MIN_NORMAL_DISTANCE)[..., None]
        degenerate = dist < _MIN_NORMAL_DISTANCE
        if degenerate.any():
            alt = p0 - centers
            alt_d = np.linalg.norm(alt, axis=-1)
            left = np.array([-math.sin(th0), math.cos(th0)])
            alt = np.where(
                (alt_d > _MIN_NORMAL_DISTANCE)[..., None],
                alt / np.maximum(alt_d, _MIN_NORMAL_DISTANCE)[..., None],
                left,
            )
            normal = np.where(degenerate[..., None], alt, normal)
        return normal

    def _solve(
        self,
        layout: _Layout,
        lin: dict,
        x0: np.ndarray,
        y0: np.ndarray,
        first: bool,
        info: dict,
    ) -> tuple[np.ndarray, np.ndarray, bool]:
        """One QP with OSQP (set up at the layout's first use, updated in place after)."""
        p = self.params
        if layout.solver is None:
            a_mat, p_mat = layout.a_mat, layout.p_mat
            a_mat.data = lin["Ax"].copy()
            p_mat.data = lin["Px"].copy()
            solver = osqp.OSQP()
            solver.setup(
                P=p_mat,
                q=lin["q"],
                A=a_mat,
                l=lin["l"],
                u=lin["u"],
                verbose=False,
                eps_abs=p.osqp_eps,
                eps_rel=p.osqp_eps,
                max_iter=p.osqp_max_iter,
                time_limit=p.time_limit,
                polishing=True,
                warm_starting=True,
                rho=_RHO0,
                adaptive_rho=1,  # iteration-based adaptation: deterministic
                adaptive_rho_interval=_RHO_INTERVAL,
            )
            layout.solver = solver
        # Always the same sequence of operations, also right after the setup, so that a
        # plan does not depend on what the solver did before, bit for bit. A matrix update
        # makes OSQP re-scale the problem, and its cost scaling reads the q in the
        # workspace — the previous QP's, unscaled with the previous scaling (rounding): so
        # q is zeroed first (zero survives any scaling exactly), then the matrices, then
        # the vectors with the new scaling.
        if first:
            layout.solver.update_settings(rho=_RHO0)
        layout.solver.update(q=layout.zero_q)
        layout.solver.update(Px=lin["Px"], Ax=lin["Ax"])
        layout.solver.update(q=lin["q"], l=lin["l"], u=lin["u"])
        layout.solver.warm_start(x=x0, y=y0)
        res = layout.solver.solve(raise_error=False)
        self.qp_solves += 1
        info["solves"] += 1
        info["iterations"] += int(res.info.iter)
        info["qp_iterations"].append(int(res.info.iter))
        info["status"].append(str(res.info.status))
        info["run_time"] += float(res.info.run_time)
        info["qp_run_times"].append(float(res.info.run_time))
        status = int(res.info.status_val)
        if status == _TIME_LIMIT:
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
        ok = bool(np.all(np.isfinite(x))) and (
            status in _OK or (status in _STOPPED and res.info.prim_res <= _MAX_ITER_RESIDUAL)
        )
        if not ok:
            self.qp_failures += 1
            return x, y0, False
        return x.copy(), np.asarray(res.y, dtype=float).copy(), True

    def _shift_duals(self, y: np.ndarray, layout: _Layout) -> np.ndarray:
        """The previous plan's duals moved one step earlier (the last step repeated)."""
        n = self.horizon
        n_obs = layout.num_ped + layout.num_static
        out = y.copy()
        if n_obs:
            obs_rows = y[: n * n_obs].reshape(n, n_obs)
            out[: n * n_obs] = np.vstack([obs_rows[1:], obs_rows[-1:]]).ravel()
            base = n * n_obs + 2 * n
            s_rows = y[base : base + n * n_obs].reshape(n, n_obs)
            out[base : base + n * n_obs] = np.vstack([s_rows[1:], s_rows[-1:]]).ravel()
        base = n * n_obs
        for part in (slice(base, base + n), slice(base + n, base + 2 * n)):
            seg = y[part]
            out[part] = np.concatenate([seg[1:], seg[-1:]])
        return out
