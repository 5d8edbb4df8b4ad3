"""`PassivityController`: the passivity-based whole-body controller (the paper's 1 kHz
layer; here at every plant step).

Input ports:
    state (nq + nv): the Digit plant state (q, v).
    targets (abstract `robot.walking_targets.WalkingTargets`): the footstep planner's
        targets; the controller evaluates their reference motion at its own time.
Output ports:
    actuation (nu): joint torques [N·m] in the plant's actuator order, within the
        joint-side effort limits; the stance toe (ankle) torques within
        `ankle_torque_fraction` of theirs. For the joints the contact solver damps
        (`walking.implicit_damping`) this is the feed-forward only: the solver adds
        −K_D (v − v_r) at the end of its step and bounds the sum by the effort limit.
    desired_state (2 nu, only with `walking.implicit_damping`): [q; v_r] of each
        actuator's joint in actuator order [rad; rad/s], for the plant's desired-state
        port (proportional gain 0: q is the measured position; v_r the reference
        velocity q̇_r of the law below). Both ports read one computation per step.
Computed from the current state (no one-step delay): the discrete plant pulls the torques
at every step. With a `controller_period` longer than the plant's `time_step` (explicit
damping only) they are computed only at the controller's instants and held in between (a
zero-order hold, kept in a discrete state by a periodic update).

Law (Slotine–Li / Sadeghian form on the stance-constrained dynamics). The stance foot is
a holonomic constraint J_st v = 0; with it the robot's 12 leg joints are fully actuated
(the toe motors are the ankle). Twelve task coordinates y are tracked: torso orientation
(3, heading from the hip yaws), torso height (1), the CoM horizontally (2, against the
LIP trajectory of the step, through the stance ankle) and the swing foot pose (6). With
task errors e = y − y_d:

    ẏ_r = ẏ_d − Λ e,   ÿ_r = ÿ_d − Λ ė,   q̇_r, q̈_r from ẏ_r, ÿ_r and J_st q̇ = 0,
    s = q̇ − q̇_r,       τ = Φᵀ (M q̈_r + C q̇ + G) − K_D s,

with Φ = [−J_st,b⁻¹ J_st,j; I] the null-space map of the stance constraint (so
Φᵀ(M q̈ + C q̇ + G) is M̄ q̈ + C̄ q̇ + Ḡ of the reduced dynamics), evaluated in O(n) with
Drake's recursive `CalcInverseDynamics`; C̄ q̇_r is taken as C̄ q̇ (they differ by C̄ s,
which vanishes as tracking converges). Because the torso is the floating base, the torso
tasks are the base velocities themselves, and the block structure leaves one 6 × 6 LAPACK
solve per leg (velocity and acceleration as two right-hand sides). Horizontally ÿ_d is the
pendulum's own (g/H)(c − p_stance) at the measured CoM, so the ankle only corrects the
error to the LIP trajectory. In double support (standing) both feet are constrained and
the contact wrench is the least-norm one. The CoM horizontal Jacobian is approximated by
the base's (the legs move the CoM relative to the torso by a few cm; the error is
measured, not modelled).

Frames: world W; torso T (floating base, velocities [ω_WT; v_WTo] in W); foot frames at
the ankle (toe-roll axis); all task quantities in W.
"""

from __future__ import annotations

import math
import time

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.multibody.tree import JacobianWrtVariable, MultibodyForces
from pydrake.systems.framework import BasicVector, Context, LeafSystem, State, ValueProducer
from scipy.linalg.lapack import dgesv

from emonav_drake.params import WalkingParams
from emonav_drake.robot.walking_targets import WalkingTargets
from emonav_drake.systems.digit_plant import DigitModel

_ZERO3 = np.zeros(3)


def _as_slice(idx: np.ndarray) -> slice | np.ndarray:
    """A contiguous index array as a slice (views instead of copies), else unchanged."""
    idx = np.asarray(idx)
    if len(idx) and np.all(np.diff(idx) == 1):
        return slice(int(idx[0]), int(idx[-1]) + 1)
    return idx


def _orientation_error(
    qw: float, qx: float, qy: float, qz: float, yaw: float, pitch: float
) -> tuple[float, float, float]:
    """Error of the torso orientation (a unit quaternion: normalise it first) against
    Rz(yaw)·Ry(pitch), world axes: ½ vee(R R_dᵀ − R_d Rᵀ) ≈ θ k for R = exp(θ k̂) R_d.
    Scalar math: no arrays."""
    R00 = 1 - 2 * (qy * qy + qz * qz)
    R01 = 2 * (qx * qy - qw * qz)
    R02 = 2 * (qx * qz + qw * qy)
    R10 = 2 * (qx * qy + qw * qz)
    R11 = 1 - 2 * (qx * qx + qz * qz)
    R12 = 2 * (qy * qz - qw * qx)
    R20 = 2 * (qx * qz - qw * qy)
    R21 = 2 * (qy * qz + qw * qx)
    R22 = 1 - 2 * (qx * qx + qy * qy)
    return _vee_error(R00, R01, R02, R10, R11, R12, R20, R21, R22, yaw, pitch)


def _vee_error(
    R00: float,
    R01: float,
    R02: float,
    R10: float,
    R11: float,
    R12: float,
    R20: float,
    R21: float,
    R22: float,
    yaw: float,
    pitch: float,
) -> tuple[float, float, float]:
    cy, sy, cp, sp = math.cos(yaw), math.sin(yaw), math.cos(pitch), math.sin(pitch)
    # R_d = Rz(yaw) Ry(pitch)
    D00, D01, D02 = cy * cp, -sy, cy * sp
    D10, D11, D12 = sy * cp, cy, sy * sp
    D20, D21, D22 = -sp, 0.0, cp
    # E = R R_dᵀ, E_ij = R_i · D_j
    E01 = R00 * D10 + R01 * D11 + R02 * D12
    E02 = R00 * D20 + R01 * D21 + R02 * D22
    E10 = R10 * D00 + R11 * D01 + R12 * D02
    E12 = R10 * D20 + R11 * D21 + R12 * D22
    E20 = R20 * D00 + R21 * D01 + R22 * D02
    E21 = R20 * D10 + R21 * D11 + R22 * D12
    return 0.5 * (E21 - E12), 0.5 * (E02 - E20), 0.5 * (E10 - E01)


class PassivityController(LeafSystem):
    """Passivity-based whole-body controller (see the module docstring).

    Args:
        model: the Digit plant and its index maps.
        params: gains, gait and torque bounds (`WalkingParams`).
        record_timing: keep every tick's duration in `tick_seconds` (benchmarks).
    """

    def __init__(
        self, model: DigitModel, params: WalkingParams, record_timing: bool = False
    ) -> None:
        super().__init__()
        plant = model.plant
        self._m = model
        self._plant = plant
        self._ctx = plant.CreateDefaultContext()
        self._p = params
        self._nq = plant.num_positions()
        self._nv = plant.num_velocities()
        self._nu = plant.num_actuators()
        self._forces = MultibodyForces(plant)
        self._world = plant.world_frame()
        self._foot_frames = [b.body_frame() for b in model.foot_bodies]
        self._feet = model.foot_bodies
        self._wrt = JacobianWrtVariable.kV
        self._bq0 = int(model.base_q[0])
        self._bv = _as_slice(model.base_v)
        self._bv0 = int(model.base_v[0])
        self._lv = [_as_slice(i) for i in model.leg_v]
        self._lu = [_as_slice(i) for i in model.leg_u]
        # K_D s of the joints the solver damps (`implicit_legs`) is the plant's, not ours
        implicit = np.asarray(model.implicit_legs, dtype=bool)
        self._kd = np.where(implicit, 0.0, np.asarray(params.kd_leg, dtype=float))
        limits = np.array(
            [plant.get_joint_actuator(i).effort_limit() for i in plant.GetJointActuatorIndices()]
        )
        self._ankle_max = params.ankle_torque_fraction * limits[model.leg_u[0][4:6]]
        # the solver bounds feed-forward + damping of those joints by the effort limit
        # itself: their feed-forward is left unbounded here
        self._u_max = limits.copy()
        for leg_u in model.leg_u:
            self._u_max[np.asarray(leg_u)[implicit]] = np.inf
        self._mass = model.total_mass
        self._record = record_timing
        self.tick_seconds: list[float] = []
        nx = plant.num_positions() + plant.num_velocities()
        self._state_in = self.DeclareVectorInputPort("state", nx)
        self._targets_in = self.DeclareAbstractInputPort("targets", AbstractValue.Make(object()))
        self._period = params.controller_period
        self._held = None  # the discrete state of a zero-order hold, if any (below)
        if implicit.any():  # torques and the reference velocity, computed once per step
            self._aq, self._av = model.actuated_q, model.actuated_v
            self._result = self.DeclareCacheEntry(
                "torques and the solver's desired state",
                ValueProducer(
                    allocate=lambda: AbstractValue.Make(np.zeros(3 * self._nu)),
                    calc=self._calc_result,
                ),
                {self.all_input_ports_ticket(), self.time_ticket()},
            )
            self._out = self.DeclareVectorOutputPort("actuation", self._nu, self._calc_from_result)
            self.DeclareVectorOutputPort("desired_state", 2 * self._nu, self._calc_desired)
        elif abs(self._period / params.time_step - 1.0) < 1e-9:
            self._out = self.DeclareVectorOutputPort("actuation", self._nu, self._calc_actuation)
        else:
            self._held = self.DeclareDiscreteState(self._nu)
            self._out = self.DeclareVectorOutputPort("actuation", self._nu, self._calc_held)
            self.DeclarePeriodicUnrestrictedUpdateEvent(self._period, 0.0, self._hold)
        # preallocated work arrays (no re-allocation of the big ones per tick)
        self._vr = np.zeros(self._nv)
        self._ar = np.zeros(self._nv)
        self._u = np.zeros(self._nu)

    # ------------------------------------------------------------------------------
    def _calc_actuation(self, context: Context, output: BasicVector) -> None:
        t0 = time.perf_counter()
        x = self._state_in.Eval(context)
        tg = self._targets_in.Eval(context)
        output.SetFromVector(self.compute(x, tg, context.get_time()))
        if self._record:
            self.tick_seconds.append(time.perf_counter() - t0)

    def _calc_result(self, context: Context, value: AbstractValue) -> None:
        t0 = time.perf_counter()
        x = self._state_in.Eval(context)
        nu = self._nu
        out = value.get_mutable_value()  # [u; q; v_r], the cache's own array, filled in place
        out[:nu] = self.compute(x, self._targets_in.Eval(context), context.get_time())
        out[nu : 2 * nu] = x[self._aq]
        out[2 * nu :] = self._vr[self._av]
        if self._record:
            self.tick_seconds.append(time.perf_counter() - t0)

    def _calc_from_result(self, context: Context, output: BasicVector) -> None:
        output.SetFromVector(self._result.Eval(context)[: self._nu])

    def _calc_desired(self, context: Context, output: BasicVector) -> None:
        output.SetFromVector(self._result.Eval(context)[self._nu :])

    def _on_tick(self, t: float) -> bool:
        return abs(t - round(t / self._period) * self._period) < 1e-9

    def _calc_held(self, context: Context, output: BasicVector) -> None:
        # A zero-order hold without delay: at a controller instant the torque is computed
        # from the current state (the plant's step at that instant pulls it); in between,
        # the value the update stored at that instant.
        if self._on_tick(context.get_time()):
            self._calc_actuation(context, output)
        else:
            output.SetFrom(context.get_discrete_state(self._held))

    def _hold(self, context: Context, state: State) -> None:
        # Every update of an instant reads the same context, so this is the value the
        # plant's step just pulled (cached), not a second computation.
        state.get_mutable_discrete_state(self._held).set_value(self._out.Eval(context))

    def compute(self, x: np.ndarray, tg: WalkingTargets, t: float) -> np.ndarray:
        """Joint torques for plant state `x`, planner targets `tg` at time `t` [s]; for the
        joints in `walking.implicit_damping` the feed-forward only (the solver adds
        −K_D (v − v_r)), the reference velocity v_r left in `self._vr`.

        One piece on purpose: it runs at every controller tick (every plant step, about a
        third of the Digit loop's wall time) and every split measured slower. Timed on fixed inputs
        of each phase, 100-call blocks alternated 300 times with this version on the same
        instance, one core, paired medians of ≈ 75–90 µs per call: the swing task and the
        torques as methods +0.2 … +1.3 µs, all four steps as methods +0.7 … +2.1 µs,
        against −0.2 … +0.4 µs for a second copy of this version. The steps are the
        `# ----` sections: the base's reference (torso orientation and height, CoM against
        the ALIP), the stance legs' (stance constraint), the swing leg's (foot pose task),
        the torques (inverse dynamics, contact wrench, bounds).
        """
        p = self._p
        plant, ctx = self._plant, self._ctx
        plant.SetPositionsAndVelocities(ctx, x)
        xs = x.tolist()  # scalar work in Python floats, matrix work in numpy
        b0, v0 = self._bq0, self._nq + self._bv0
        qw, qx, qy, qz, z = xs[b0], xs[b0 + 1], xs[b0 + 2], xs[b0 + 3], xs[b0 + 6]
        # the discrete plant does not renormalise the torso's quaternion (its norm grows
        # as the robot turns; Drake's kinematics normalise it): the rotation below must
        n = 1.0 / math.sqrt(qw * qw + qx * qx + qy * qy + qz * qz)
        qw, qx, qy, qz = qw * n, qx * n, qy * n, qz * n
        wx, wy, wz, vbx, vby, vbz = xs[v0 : v0 + 6]
        phase = tg.phase

        # ---- torso orientation: heading from the planner, upright, pitch target
        yaw_d, dyaw_d, ddyaw_d = tg.torso_yaw(t)
        ex, ey, ez = _orientation_error(qw, qx, qy, qz, yaw_d, p.torso_pitch)
        lo = p.lambda_orientation

        # ---- CoM horizontal vs the ALIP of this step (through the stance ankle)
        cx, cy, _ = plant.CalcCenterOfMassPositionInWorld(ctx).tolist()
        vcx, vcy, _ = plant.CalcCenterOfMassTranslationalVelocityInWorld(ctx).tolist()
        (cdx, cdy), (dcdx, dcdy) = tg.com(t, yaw_d)
        # the pendulum's own acceleration at the measured CoM: zero ankle torque in the
        # ALIP sense; the ankle only corrects the error below
        ax0, ay0 = tg.pendulum_acceleration(cx, cy)
        lh, lz = p.lambda_horizontal, p.lambda_height
        # base reference [ω; v] and [α; a] (world); horizontal CoM mapped onto the base
        VA = np.array(
            [
                [-lo * ex, -lo * wx],
                [-lo * ey, -lo * wy],
                [dyaw_d - lo * ez, ddyaw_d - lo * (wz - dyaw_d)],
                [vbx - vcx + dcdx - lh * (cx - cdx), ax0 - lh * (vcx - dcdx)],
                [vby - vcy + dcdy - lh * (cy - cdy), ay0 - lh * (vcy - dcdy)],
                [-lz * (z - p.torso_height), -lz * vbz],
            ]
        )
        vr, ar, bv = self._vr, self._ar, self._bv
        vr[:] = 0.0
        ar[:] = 0.0
        vr[bv] = VA[:, 0]
        ar[bv] = VA[:, 1]

        # ---- stance legs: J_st v = 0 and J_st v̇ + J̇v = 0 given the base's reference
        stance_legs = (0, 1) if phase < 0 else (phase,)
        Jst = [None, None]
        for i in stance_legs:
            frame = self._foot_frames[i]
            J = plant.CalcJacobianSpatialVelocity(
                ctx, self._wrt, frame, _ZERO3, self._world, self._world
            )
            Jd = plant.CalcBiasSpatialAcceleration(
                ctx, self._wrt, frame, _ZERO3, self._world, self._world
            ).get_coeffs()
            Jb, Jl = J[:, bv], J[:, self._lv[i]]
            rhs = Jb @ VA  # J_st v = 0 and J_st v̇ + J̇v = 0, solved for this leg
            rhs[:, 1] += Jd
            sol = dgesv(Jl, rhs)[2]
            vr[self._lv[i]] = -sol[:, 0]
            ar[self._lv[i]] = -sol[:, 1]
            Jst[i] = (Jb, Jl)

        # ---- swing leg: the foot pose task (position and yaw, upright)
        if phase >= 0:
            j = 1 - phase
            frame = self._foot_frames[j]
            X = plant.EvalBodyPoseInWorld(ctx, self._feet[j])
            J = plant.CalcJacobianSpatialVelocity(
                ctx, self._wrt, frame, _ZERO3, self._world, self._world
            )
            Jd = plant.CalcBiasSpatialAcceleration(
                ctx, self._wrt, frame, _ZERO3, self._world, self._world
            ).get_coeffs()
            Vx = (J @ x[self._nq :]).tolist()
            ref = tg.swing(t)
            phx, phy, phz = ref.position
            dphx, dphy, dz = ref.velocity
            ddphx, ddphy, ddz = ref.acceleration
            yw, dyw, ddyw = ref.yaw
            Rm = X.rotation().matrix().ravel().tolist()
            erx, ery, erz = _vee_error(*Rm, yw, 0.0)
            px, py, pz = X.translation().tolist()
            ls = p.lambda_swing
            VAs = np.array(
                [
                    [-ls * erx, -ls * Vx[0]],
                    [-ls * ery, -ls * Vx[1]],
                    [dyw - ls * erz, ddyw - ls * (Vx[2] - dyw)],
                    [dphx - ls * (px - phx), ddphx - ls * (Vx[3] - dphx)],
                    [dphy - ls * (py - phy), ddphy - ls * (Vx[4] - dphy)],
                    [dz - ls * (pz - phz), ddz - ls * (Vx[5] - dz)],
                ]
            )
            Jb, Jl = J[:, bv], J[:, self._lv[j]]
            rhs = VAs - Jb @ VA
            rhs[:, 1] -= Jd
            sol = dgesv(Jl, rhs)[2]
            vr[self._lv[j]] = sol[:, 0]
            ar[self._lv[j]] = sol[:, 1]

        # ---- torques: τ = Φᵀ(M q̈_r + C q̇ + G) − K_D s, the stance ankles and all bounded
        # inverse dynamics of the reference motion: M q̈_r + C q̇ − τ_g (O(n) recursion)
        tau = plant.CalcInverseDynamics(ctx, ar, self._forces)
        tau -= plant.CalcGravityGeneralizedForces(ctx)
        s = x[self._nq :] - vr
        u = self._u
        # contact wrench from the unactuated (base) rows, then the stance legs' torques
        tb = tau[bv]
        lams = [None, None]
        if phase < 0:
            A = np.hstack([Jst[0][0].T, Jst[1][0].T])  # 6 × 12, least-norm wrench split
            lam = A.T @ dgesv(A @ A.T, tb)[2]
            lams = [lam[:6], lam[6:]]
        else:
            lams[phase] = dgesv(Jst[phase][0].T, tb)[2]
        for i in (0, 1):
            lv_i = self._lv[i]
            ti = tau[lv_i] - self._kd * s[lv_i]
            if lams[i] is not None:
                ti -= Jst[i][1].T @ lams[i]
                ti[4:6] = np.minimum(np.maximum(ti[4:6], -self._ankle_max), self._ankle_max)
            u[self._lu[i]] = ti
        av = self._m.arm_v
        if len(av):  # arms held (not welded): PD to the held pose on top of the dynamics
            qa = x[self._m.arm_q]
            u[self._m.arm_u] = (
                tau[av] + p.kp_arm * (self._m.arm_q_target - qa) - p.kd_arm * x[self._nq + av]
            )
        np.minimum(np.maximum(u, -self._u_max, out=u), self._u_max, out=u)
        return u.copy()
