"""The MPC's model of the next N walking steps, and what needs no solver (`planners/mpc.py`).

`HorizonModel` holds what the planner derives once from the configuration — the LIP step
constant c = tanh(ωT/2)/ω, the command bounds of paper Eq. 2, the step-end times, the
goal weights, the constant part of the QP's Hessian and the masks of the Jacobian — and
the parts of the problem that are plain numpy:

* `rollout`: the exact LIP step map (paper Eq. 1) over the horizon for a batch of plans;
* `jacobian`: ∂p_{k+1}/∂u of one plan, built with cumulative sums (condensed form);
* `obstacles`: the constant-velocity prediction of the pedestrians and the fixed static
  discs, with their contact and discomfort radii, slack weights and hard/soft flags;
* `seeds`: the "turn to a heading, then hold" seed plans of the SCP;
* `nonlinear_cost`: the QP's cost evaluated on the exact rollout (it picks the seed).

Frame and units: the world frame; positions [m], speeds [m/s], headings and heading
changes [rad], times [s]. A plan u is (N, 2) or (B, N, 2): (u_v [m/s], u_Δθ [rad]) per
step.
"""

from __future__ import annotations

import math

import numpy as np

from emonav_drake.crowd.crowd import CrowdSnapshot
from emonav_drake.params import EmoNavConfig, MpcParams

_HARD_PENALTY = 1e4  # seed selection: cost per metre of hard-constraint violation


class HorizonModel:
    """The constants and the solver-free model of the MPC's horizon of N walking steps.

    Args:
        config: robot bounds and LIP constants and the `mpc` params.

    Attributes:
        horizon: N; hard_steps: h, the steps in which pedestrian contact is hard.
        c: tanh(ωT/2)/ω [s]: a step advances c (v_k + u_v,k).
        lo, hi: (2,) bounds of (u_v, u_Δθ) (paper Eq. 2); lo_u, hi_u: the same for the
            stacked (u_v,0…N−1, u_Δθ,0…N−1).
        times: (N,) step ends t_1 … t_N [s].
        w_goal: (N,) goal weights (terminal weight added at N); w_goal2: per (k, x|y).
        p_const: (2N, 2N) constant part of the u-block Hessian (smoothness, turning
            effort, regulariser).
    """

    def __init__(self, config: EmoNavConfig) -> None:
        self.config = config
        p: MpcParams = config.mpc
        r = config.robot
        self.params = p
        self.horizon = n = p.horizon_steps
        self.hard_steps = min(p.hard_pedestrian_steps, n)
        self.c = math.tanh(r.omega * r.step_time / 2.0) / r.omega
        self.lo = np.array([0.0, -r.max_heading_change])
        self.hi = np.array([r.max_speed, r.max_heading_change])
        self.times = r.step_time * np.arange(1, n + 1)  # step ends t_1 … t_N [s]
        self.w_goal = np.full(n, p.goal_weight)
        self.w_goal[-1] += p.terminal_weight
        self.w_goal2 = np.repeat(self.w_goal, 2)  # per (k, x|y)
        self.lo_u = np.repeat(self.lo, n)  # (u_v,0…N−1, u_Δθ,0…N−1)
        self.hi_u = np.repeat(self.hi, n)
        # Constant part of the u-block Hessian: smoothness, turning effort, regulariser.
        diff = np.eye(n) - np.eye(n, k=-1)
        dtd = diff.T @ diff
        self.p_const = np.zeros((2 * n, 2 * n))
        self.p_const[:n, :n] = 2.0 * p.speed_smoothness_weight * dtd
        self.p_const[n:, n:] = 2.0 * p.turn_smoothness_weight * dtd + 2.0 * p.turn_weight * np.eye(
            n
        )
        self.p_const += 1e-6 * np.eye(2 * n)
        # Masks of the Jacobian of p_{k+1} (row k) w.r.t. u_v,m: m ≤ k and m + 1 ≤ k.
        kk, mm = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
        self.mask0 = (mm <= kk).astype(float)
        self.mask1 = (mm <= kk - 1).astype(float)
        self.tri = mm <= kk  # u_Δθ,i affects p_{k+1} for i ≤ k

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
        dx = self.c * (v + a)
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
        jac[:, :n] = self.c * (
            self.mask0[..., None] * e[None, :, :] + self.mask1[..., None] * e_next[None, :, :]
        )
        csum = np.cumsum(dx[:, None] * e_perp, axis=0)  # C_k = Σ_{j≤k} Δx_j e⊥(φ_j)
        before = np.vstack([np.zeros((1, 2)), csum[:-1]])  # C_{i−1}
        jac[:, n:] = np.where(self.tri[..., None], csum[:, None, :] - before[None, :, :], 0.0)
        return jac

    def positions_and_jacobian(
        self, p0: np.ndarray, th0: float, v0: float, u: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Step-end positions (N, 2) of one plan u (N, 2) and ∂p_{k+1}/∂u (N, 2N, 2): what
        the QP is linearised with (`mpc_qp.linearise`)."""
        pos, phi, dx = self.rollout(p0, th0, v0, u[None])
        return pos[0], self.jacobian(phi[0], dx[0])

    # ------------------------------------------------------------------ obstacles
    def obstacles(self, crowd: CrowdSnapshot) -> dict:
        """Predicted centres (N, O, 2), zone and contact radii, slack caps and weights."""
        cfg, p = self.config, self.params
        ped_pos = np.asarray(crowd.positions, dtype=float).reshape(-1, 2)
        ped_vel = np.asarray(crowd.velocities, dtype=float).reshape(-1, 2)
        st_c = np.asarray(crowd.static_centers, dtype=float).reshape(-1, 2)
        st_r = np.asarray(crowd.static_radii, dtype=float).reshape(-1)
        n_ped, n_st = len(ped_pos), len(st_c)
        t = self.times[:, None, None]
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
    def seeds(self, th0: float, p0: np.ndarray, target: np.ndarray) -> np.ndarray:
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
        goal = (self.w_goal * ((pos - target) ** 2).sum(-1)).sum(-1)
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
