"""`AlipFootstepPlanner`: walking phase, ALIP foot placement, swing and torso targets.

Input ports:
    state (nq + nv): the Digit plant state (q, v).
    command (2): (u_v [m/s], u_Δθ [rad]) for the step that starts at the next foot switch
        (`WalkingCommandSource`). Out-of-bound commands are clipped with a warning
        (`core.navigation.check_command`); NaN raises `CommandError`.
Output ports:
    targets (N_TARGETS): the walking targets the whole-body controller tracks, world
        frame W; layout in the `T_*` index constants below (phase, step start time,
        stance ankle, swing start/target, swing yaw, torso heading, the LIP state at the
        step start for the horizontal CoM reference).
    next_step (1): how many steps have started (the command source's index).
    step_log (N_LOG): what happened at the last switch, for tracking analysis: time,
        CoM x, y, torso yaw, sagittal CoM speed, the command of the new step, the
        heading target, and the ALIP end-of-step prediction made at mid-step vs the
        measured end state (x_c and ℒ, sagittal and lateral, heading frame): 16 values
        t, com_x, com_y, torso_yaw, v_sagittal, u_v, u_Δθ, heading target, predicted
        (x_s, x_l, ℒ_s, ℒ_l), measured (x_s, x_l, ℒ_s, ℒ_l).

Discrete state = targets ‖ internals, updated by a periodic unrestricted update every
`params.planner_period` (default 5 ms). Each update: detect touchdown (swing ankle at the
ground after `early_touchdown`·T, or T elapsed) and switch stance; otherwise re-plan the
swing target with the ALIP law of `core.alip` (sagittal ℒ_des = m H v_des, lateral
±½ m H W ℓ tanh(ℓT/2), clamped as in DESIGN.md §3.4b). The pivot is the stance ankle's
ground projection; L is measured about it with `CalcSpatialMomentumInWorldAboutPoint`.
"""

from __future__ import annotations

import logging
import math

import numpy as np
from pydrake.systems.framework import BasicVector, Context, LeafSystem, State

from emonav_drake.core.alip import (
    alip_predict,
    foot_placement,
    lateral_momentum_target,
)
from emonav_drake.core.lip import wrap_angle
from emonav_drake.core.navigation import check_command
from emonav_drake.params import RobotParams, WalkingParams
from emonav_drake.systems.digit_plant import ANKLE_TO_SOLE, DigitModel

log = logging.getLogger(__name__)

# targets layout
T_PHASE = 0  # -1 double support (standing), 0 left stance, 1 right stance
T_START = 1  # step start time [s]
T_STANCE = slice(2, 5)  # stance ankle position, world [m]
T_SW0 = slice(5, 8)  # swing ankle at lift-off [m]
T_SW1 = slice(8, 11)  # swing ankle target (ALIP) [m]
T_SWYAW0, T_SWYAW1 = 11, 12  # swing foot yaw at lift-off and target [rad]
T_HEAD0, T_HEAD1 = 13, 14  # torso heading at the step start and its target [rad]
T_XC0 = slice(15, 17)  # CoM − stance pivot at the step start, world xy [m]
T_LV0 = slice(17, 19)  # ℒ at the step start, world axes (= m H v) [kg·m²/s]
T_HEIGHT = 19  # ALIP height H used [m]
N_TARGETS = 20
# internals
I_COUNT = 20  # steps started
I_INTEGRAL = 21  # speed integrator [m/s]
I_CMD = slice(22, 24)  # command of the step in progress
I_COM_SWITCH = slice(24, 26)  # CoM xy at the last switch
I_PRED = slice(26, 30)  # mid-step prediction of the end (x_s, x_l, ℒ_s, ℒ_l)
I_PREDICTED = 30  # 1 once this step's prediction is stored
I_CLIPPED = 31  # clipped commands so far
I_LOG = slice(32, 48)
N_LOG = 16
N_STATE = 48


def _yaw(R: np.ndarray) -> float:
    return math.atan2(R[1, 0], R[0, 0])


class AlipFootstepPlanner(LeafSystem):
    """ALIP footstep planner (see the module docstring).

    Args:
        model: the Digit plant and its index maps.
        params: gait, clamps and timing (`WalkingParams`).
        robot: command bounds (ū_v, ū_Δθ) and g.
        height: ALIP height H [m] (the standing CoM height of the plant).

    The initial heading is the torso's yaw in the initial plant state.
    """

    def __init__(
        self,
        model: DigitModel,
        params: WalkingParams,
        robot: RobotParams,
        height: float,
    ) -> None:
        super().__init__()
        self._model = model
        self._plant = model.plant
        self._ctx = self._plant.CreateDefaultContext()
        self._p = params
        self._robot = robot
        self._mass = model.total_mass
        self._H = height
        self._g = robot.gravity
        self._feet = model.foot_bodies
        init = np.zeros(N_STATE)
        init[T_PHASE] = -1.0
        init[T_HEIGHT] = height
        self._xd = self.DeclareDiscreteState(init)
        nx = self._plant.num_positions() + self._plant.num_velocities()
        self._state_in = self.DeclareVectorInputPort("state", nx)
        self._cmd_in = self.DeclareVectorInputPort("command", 2)
        self.DeclareVectorOutputPort("targets", N_TARGETS, self._calc_targets, {self.xd_ticket()})
        self.DeclareVectorOutputPort("next_step", 1, self._calc_next_step, {self.xd_ticket()})
        self.DeclareVectorOutputPort("step_log", N_LOG, self._calc_step_log, {self.xd_ticket()})
        self.DeclareInitializationUnrestrictedUpdateEvent(self._initialize)
        self.DeclarePeriodicUnrestrictedUpdateEvent(params.planner_period, 0.0, self._update)

    # ---- outputs -------------------------------------------------------------------
    def _calc_targets(self, context: Context, output: BasicVector) -> None:
        output.SetFromVector(context.get_discrete_state(self._xd).get_value()[:N_TARGETS])

    def _calc_next_step(self, context: Context, output: BasicVector) -> None:
        output.SetAtIndex(0, context.get_discrete_state(self._xd).get_value()[I_COUNT])

    def _calc_step_log(self, context: Context, output: BasicVector) -> None:
        output.SetFromVector(context.get_discrete_state(self._xd).get_value()[I_LOG])

    # ---- updates -------------------------------------------------------------------
    def _set_plant(self, context: Context) -> None:
        self._plant.SetPositionsAndVelocities(self._ctx, self._state_in.Eval(context))

    def _ankle(self, i: int) -> tuple[np.ndarray, float]:
        X = self._plant.EvalBodyPoseInWorld(self._ctx, self._feet[i])
        return X.translation().copy(), _yaw(X.rotation().matrix())

    def _initialize(self, context: Context, state: State) -> None:
        """Standing targets from the initial pose: both ankles and the torso heading."""
        self._set_plant(context)
        x = context.get_discrete_state(self._xd).get_value().copy()
        p0, _ = self._ankle(0)
        p1, _ = self._ankle(1)
        x[T_PHASE] = -1.0
        x[T_STANCE] = p0
        x[T_SW0] = x[T_SW1] = p1
        com = self._plant.CalcCenterOfMassPositionInWorld(self._ctx)
        x[I_COM_SWITCH] = com[:2]
        R_WT = self._plant.EvalBodyPoseInWorld(self._ctx, self._model.torso_body).rotation()
        x[T_HEAD0] = x[T_HEAD1] = _yaw(R_WT.matrix())
        state.get_mutable_discrete_state(self._xd).set_value(x)

    def clipped_commands(self, context: Context) -> int:
        """How many commands were clipped so far (from this system's `context`)."""
        return int(context.get_discrete_state(self._xd).get_value()[I_CLIPPED])

    def _momentum(self, pivot: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """CoM − pivot (world xy), ℒ in world axes (ℒ_x = L_y, ℒ_y = −L_x), and the CoM."""
        com = self._plant.CalcCenterOfMassPositionInWorld(self._ctx)
        L = self._plant.CalcSpatialMomentumInWorldAboutPoint(self._ctx, pivot).rotational()
        return com[:2] - pivot[:2], np.array([L[1], -L[0]]), com

    def _update(self, context: Context, state: State) -> None:
        x = context.get_discrete_state(self._xd).get_value().copy()
        t = context.get_time()
        p = self._p
        self._set_plant(context)
        phase = int(x[T_PHASE])
        if phase < 0:
            if t + 1e-9 >= p.stand_time:
                self._start_step(x, t, stance=0, first=True, context=context)
                state.get_mutable_discrete_state(self._xd).set_value(x)
            return
        swing = 1 - phase
        tp = t - x[T_START]
        p_sw, _ = self._ankle(swing)
        touched = tp >= p.early_touchdown * p.step_time and p_sw[2] <= ANKLE_TO_SOLE + 0.002
        if touched or tp >= p.step_time - 1e-9:
            self._start_step(x, t, stance=swing, first=False, context=context)
        else:
            self._plan_foot(x, tp)
        state.get_mutable_discrete_state(self._xd).set_value(x)

    def _frame(self, heading: float) -> tuple[np.ndarray, np.ndarray]:
        c, s = math.cos(heading), math.sin(heading)
        return np.array([c, s]), np.array([-s, c])

    def _plan_foot(self, x: np.ndarray, tp: float) -> None:
        """Re-plan the swing target from the measured ALIP state."""
        p = self._p
        T = p.step_time
        stance = int(x[T_PHASE])
        pivot = np.array([x[T_STANCE][0], x[T_STANCE][1], 0.0])
        xc_w, lv_w, _ = self._momentum(pivot)
        es, el = self._frame(x[T_HEAD1])
        xc = np.array([xc_w @ es, xc_w @ el])
        lv = np.array([lv_w @ es, lv_w @ el])
        mH = self._mass * self._H
        v_des = x[I_CMD][0] + x[I_INTEGRAL]
        next_right = stance == 0  # the swing foot (right when left stands) is next
        target = np.array(
            [
                mH * v_des,
                lateral_momentum_target(p.step_width, next_right, self._mass, self._H, T, self._g),
            ]
        )
        remaining = T - tp
        if not x[I_PREDICTED] and tp >= 0.5 * T:
            xe, le = alip_predict(xc, lv, remaining, self._mass, self._H, self._g)
            x[I_PRED] = np.concatenate([xe, le])
            x[I_PREDICTED] = 1.0
        if tp > 0.8 * T:
            return  # freeze the target for a clean landing
        step = foot_placement(xc, lv, remaining, target, self._mass, self._H, T, self._g)
        s = float(np.clip(step[0], -p.max_step_length, p.max_step_length))
        lat = float(step[1])
        if next_right:
            lat = float(np.clip(lat, -p.lateral_step_max, -p.lateral_step_min))
        else:
            lat = float(np.clip(lat, p.lateral_step_min, p.lateral_step_max))
        xy = pivot[:2] + s * es + lat * el
        x[T_SW1] = [xy[0], xy[1], ANKLE_TO_SOLE]

    def _start_step(
        self, x: np.ndarray, t: float, stance: int, first: bool, context: Context
    ) -> None:
        """Foot switch: the swing foot becomes the stance foot, read the next command."""
        p = self._p
        swing = 1 - stance
        p_st, _ = self._ankle(stance)
        p_sw, yaw_sw = self._ankle(swing)
        pivot = np.array([p_st[0], p_st[1], 0.0])
        xc_w, lv_w, com = self._momentum(pivot)
        # measured end of the previous step about its pivot (heading frame of that step)
        es_old, el_old = self._frame(x[T_HEAD1])
        old_pivot = np.array([x[T_STANCE][0], x[T_STANCE][1], 0.0])
        xc_o, lv_o, _ = self._momentum(old_pivot)
        xc_end = np.array([xc_o @ es_old, xc_o @ el_old])
        lv_end = np.array([lv_o @ es_old, lv_o @ el_old])
        dt = t - x[T_START]
        if not first and dt > 0.5 * p.step_time:
            v_mean = float((com[:2] - x[I_COM_SWITCH]) @ es_old) / dt
            if x[I_COUNT] >= 2:
                err = x[I_CMD][0] - v_mean
                x[I_INTEGRAL] = float(
                    np.clip(x[I_INTEGRAL] + p.speed_integral_gain * err, -0.15, 0.15)
                )
        raw = self._cmd_in.Eval(context)
        u, clipped = check_command(raw, self._robot, clip=True)
        if clipped:
            x[I_CLIPPED] += 1
            log.warning(
                "AlipFootstepPlanner: command %s out of bounds at t = %.3f s, clipped to %s",
                np.asarray(raw).tolist(),
                t,
                u.tolist(),
            )
        R_WT = self._plant.EvalBodyPoseInWorld(self._ctx, self._model.torso_body).rotation()
        head_old = x[T_HEAD1]
        # Heading targets accumulate the commands (unwrapped); measured yaws are wrapped to
        # (−π, π]. Unwrap them next to the targets, or past ±π the swing foot and the torso
        # would be sent the long way round (a ~2π twist).
        torso_yaw = head_old + wrap_angle(_yaw(R_WT.matrix()) - head_old)
        v_com = self._plant.CalcCenterOfMassTranslationalVelocityInWorld(self._ctx)
        head_new = head_old + float(u[1])
        # step log: the switch just reached and the command for the step that starts
        pred = x[I_PRED] if x[I_PREDICTED] else np.full(4, np.nan)
        x[I_LOG] = [
            t,
            com[0],
            com[1],
            torso_yaw,
            float(v_com[:2] @ es_old),
            u[0],
            u[1],
            head_new,
            *pred,
            *xc_end,
            *lv_end,
        ]
        x[T_PHASE] = float(stance)
        x[T_START] = t
        x[T_STANCE] = p_st
        x[T_SW0] = p_sw
        x[T_SW1] = p_sw
        x[T_SWYAW0] = head_old + wrap_angle(yaw_sw - head_old)
        x[T_SWYAW1] = head_new
        x[T_HEAD0] = torso_yaw if first else head_old
        x[T_HEAD1] = head_new
        x[T_XC0] = xc_w
        x[T_LV0] = lv_w
        x[I_CMD] = u
        x[I_COM_SWITCH] = com[:2]
        x[I_PREDICTED] = 0.0
        x[I_COUNT] += 1
        self._plan_foot(x, 0.0)
