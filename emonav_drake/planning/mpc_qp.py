"""The MPC's quadratic program: its fixed structure, its data at a plan, its OSQP solve.

The planner (`planners/mpc.py`, `MpcPlanner`) answers one walking-step command
u_0 = (u_v, u_Δθ) per step by optimising a horizon of N walking steps of the paper's LIP
step map (Eq. 1, `robot/lip.py`) against a constant-velocity prediction of the pedestrians
and the static discs, then applying the first command (receding horizon). The QP:

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

This module builds and solves it:

* `build_layout`: the QP's sparsity pattern for P pedestrians and S discs (one `QpLayout`
  per obstacle count, kept by the planner), with the maps from CSC slots to the dense
  value buffers that every linearisation rewrites;
* `linearise`: the values of P and A and the vectors q, l, u around a plan ū — the
  Gauss–Newton goal term, the box and trust region on u, the half-planes tangent to the
  obstacles' discs (`half_plane_normals`) and their slacks;
* `shift_duals`: the previous plan's duals moved one step earlier (the warm start);
* `solve_qp` / `solution_accepted`: one OSQP solve and whether its result is kept.

OSQP. One `osqp.OSQP` object per obstacle count (P, S), set up once with a fixed sparsity
pattern: every QP only rewrites the values of P and A, q, l and u (`update`), so OSQP
re-factorises numerically without a new symbolic analysis. Every solve is explicitly
warm-started: the first of a planning step with the previous plan's primal and dual
solution shifted by one step, the next ones with the previous iterate. Solutions are
polished (active-set refinement), so commands on a bound are exactly on it.

Every QP goes through the same sequence of updates — q zeroed, then the matrices, then
the vectors — and rho is reset at each planning step, so that a plan does not depend on
what the workspace solved before (`planners/mpc.py`, "Memory and determinism"). Every number
that decides how far OSQP iterates is a count (`max_iter`, rho adapted every
`_RHO_INTERVAL` iterations); the wall-clock `time_limit` is only a safety, which the
planner counts and logs (`planners/mpc.py`, "Work budget").

Units: the world frame; positions and distances [m], speeds [m/s], heading changes [rad].
Variables are ordered (u_v,0…N−1, u_Δθ,0…N−1, s_k,o for k·O + o, σ of the soft rows).
"""

from __future__ import annotations

import ctypes
import dataclasses as dc
import math
import signal
from collections.abc import Callable
from typing import Any

import numpy as np
import osqp
import scipy.sparse as sp

from emonav_drake.params import MpcParams
from emonav_drake.planning.mpc_model import HorizonModel

_MIN_NORMAL_DISTANCE = 1e-6  # [m]
_MAX_ITER_RESIDUAL = 1e-2  # a solve stopped by max_iter/time_limit is kept below this [m]
_RHO0 = 0.1  # OSQP's initial rho, restored at each planning step
_RHO_INTERVAL = 50  # ADMM iterations between rho adaptations (never OSQP's timed rule)

_OK = {int(osqp.SolverStatus.OSQP_SOLVED), int(osqp.SolverStatus.OSQP_SOLVED_INACCURATE)}
_TIME_LIMIT = int(osqp.SolverStatus.OSQP_TIME_LIMIT_REACHED)
_STOPPED = {int(osqp.SolverStatus.OSQP_MAX_ITER_REACHED), _TIME_LIMIT}
_SOLVED = int(osqp.SolverStatus.OSQP_SOLVED)
# OSQP installs its own SIGINT handler for the length of a solve: a Ctrl-C (or any SIGINT,
# even one the process ignores) stops the ADMM loop and returns this status instead of
# reaching Python. Such a solve did not finish: it is never used (`SolveInterrupted`).
_INTERRUPTED = int(osqp.SolverStatus.OSQP_SIGINT)


def _load_osqp_interrupt_flag() -> Callable[[], int] | None:
    """OSQP's `osqp_is_interrupted()`: whether a SIGINT reached OSQP's handler in the
    last solve (the flag is cleared when the next solve starts). None where the
    extension does not export it."""
    try:
        import osqp.ext_builtin as ext

        flag = ctypes.CDLL(ext.__file__).osqp_is_interrupted
    except (ImportError, OSError, AttributeError):
        return None
    flag.restype = ctypes.c_int
    flag.argtypes = []
    return flag


_osqp_interrupt_flag = _load_osqp_interrupt_flag()


class SolveInterrupted(Exception):
    """OSQP stopped a solve because a SIGINT arrived during it (status `OSQP_SIGINT`).

    The signal never reached Python: whoever catches this passes it on to the process's
    SIGINT handler and, if that does not stop the run, solves again from the same inputs.
    """


@dc.dataclass
class QpLayout:
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
    zero_q: np.ndarray  # (n,) zeros: q before a matrix update (see `solve_qp`)
    solver: osqp.OSQP | None = None


def build_layout(
    key: tuple[int, int], horizon: int, hard_steps: int, slack_quadratic_weight: float
) -> QpLayout:
    """The QP structure for key = (P pedestrians, S discs) over `horizon` steps, with
    hard contact for pedestrians in the first `hard_steps` steps."""
    n = horizon
    n_ped, n_st = key
    n_obs = n_ped + n_st
    nu = 2 * n
    soft = [k * n_obs + o for k in range(hard_steps, n) for o in range(n_ped)]  # rows with a σ
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
    buf_p[-1] = 2.0 * slack_quadratic_weight
    return QpLayout(
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


def linearise(
    model: HorizonModel,
    u_bar: np.ndarray,
    p0: np.ndarray,
    th0: float,
    v0: float,
    last: np.ndarray,
    target: np.ndarray,
    obst: dict,
    layout: QpLayout,
) -> dict:
    """QP data (P and A values, q, l, u) linearised around the plan u_bar (N, 2).

    Writes the layout's value buffers; returns the values in CSC slot order ("Px", "Ax"),
    "q", "l", "u", and "s0", the slacks that make u_bar feasible (the first warm start).
    """
    p = model.params
    n = model.horizon
    nu = 2 * n
    pos, jac = model.positions_and_jacobian(p0, th0, v0, u_bar)  # (N, 2), (N, 2N, 2)
    ub = np.concatenate([u_bar[:, 0], u_bar[:, 1]])
    # Gauss–Newton goal term: with J2 (2N, 2N) = rows ∂/∂u, columns (k, x|y),
    # Σ_k w_k |p̄_k + J_k (u − ū) − p_k^ref|² = |J2ᵀ u + r|²_W, r = p̄ − p^ref − J2ᵀ ū.
    j2 = jac.transpose(1, 0, 2).reshape(nu, nu)
    j2w = j2 * model.w_goal2
    res = (pos - target).ravel() - j2.T @ ub
    layout.buf_p[: nu * nu] = (2.0 * (j2w @ j2.T) + model.p_const).ravel()
    q_u = 2.0 * (j2w @ res)
    q_u[0] -= 2.0 * p.speed_smoothness_weight * last[0]
    q_u[n] -= 2.0 * p.turn_smoothness_weight * last[1]
    # Box and trust region on u.
    lo_u, hi_u = model.lo_u.copy(), model.hi_u.copy()
    lo_u[n:] = np.maximum(lo_u[n:], ub[n:] - p.trust_region)
    hi_u[n:] = np.minimum(hi_u[n:], ub[n:] + p.trust_region)
    n_obs = obst["centers"].shape[1]
    n_sig = len(layout.soft_rows)
    if n_obs:
        diff = pos[:, None, :] - obst["centers"]  # (N, O, 2)
        dist = np.sqrt((diff**2).sum(-1))
        normal = half_plane_normals(diff, dist, p0, obst["centers"], th0)
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


def half_plane_normals(
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


def solve_qp(
    layout: QpLayout,
    lin: dict,
    x0: np.ndarray,
    y0: np.ndarray,
    first: bool,
    params: MpcParams,
) -> Any:
    """One QP with OSQP (set up at the layout's first use, updated in place after).

    `first`: the first QP of a planning step (rho is reset). Returns OSQP's result
    (`x`, `y`, `info`); `solution_accepted` says whether to keep it. Raises
    `SolveInterrupted` if a SIGINT stopped the solve (its result is never returned).
    """
    p = params
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
    if int(res.info.status_val) == _INTERRUPTED:
        raise SolveInterrupted("OSQP: the solve was interrupted by SIGINT")
    if _osqp_interrupt_flag is not None and _osqp_interrupt_flag():
        # The SIGINT reached OSQP's handler after its last check (while polishing): the
        # solve finished and is good, but the signal would be lost. Send it again, now
        # that the process's own handler is back (Python's default: KeyboardInterrupt
        # here; an ignored SIGINT: nothing).
        signal.raise_signal(signal.SIGINT)
    return res


def hit_time_limit(res: Any) -> bool:
    """Whether OSQP's wall-clock safety (`mpc.time_limit`) stopped this solve."""
    return int(res.info.status_val) == _TIME_LIMIT


def solved_exactly(res: Any) -> bool:
    """Whether OSQP reports the solve as solved to its tolerances (`OSQP_SOLVED`); an
    accepted solve that is not (inaccurate, or stopped by max_iter with a small residual)
    is counted by the planner as inexact."""
    return int(res.info.status_val) == _SOLVED


def solution_accepted(res: Any, x: np.ndarray) -> bool:
    """Whether a solve's primal x is kept: finite, and solved or stopped (by max_iter or
    the time limit) with a primal residual below `_MAX_ITER_RESIDUAL`."""
    status = int(res.info.status_val)
    return bool(np.all(np.isfinite(x))) and (
        status in _OK or (status in _STOPPED and res.info.prim_res <= _MAX_ITER_RESIDUAL)
    )


def shift_duals(y: np.ndarray, layout: QpLayout, horizon: int) -> np.ndarray:
    """The previous plan's duals moved one step earlier (the last step repeated)."""
    n = horizon
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
