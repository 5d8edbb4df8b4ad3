"""`AlipFootstepPlanner`: walking phase, ALIP foot placement, swing and torso targets.

Input ports:
    state (nq + nv): the Digit plant state (q, v).
    command (2): (u_v [m/s], u_Δθ [rad]) of the walking step in progress (in the
        navigation diagram: the navigation planner's held command; in the walking
        diagram: `WalkingCommandSource`). Taken up for step k at the first update after
        the step clock's instant t_k (see "Step clock" below). Out-of-bound commands are
        clipped with a warning (`navigation.lip_world.check_command`); NaN raises
        `CommandError`.
Output ports:
    targets (abstract `robot.walking_targets.WalkingTargets`): the current step's targets
        the whole-body controller tracks, world frame W (phase, step start time, stance
        ankle, swing start/target, swing yaw, torso heading, the ALIP state at the step
        start, H, m and the gait timing).
    next_step (1): how many steps have started (the command source's index).
    step_log (N_LOG): what happened at the last switch, for tracking analysis: time,
        CoM x, y, torso yaw, sagittal CoM speed, the command of the new step, the
        heading target, the ALIP end-of-step prediction made at
        `prediction_fraction`·T vs the measured end state (x_c and ℒ, sagittal and
        lateral, heading frame), and the new swing foot's yaw at lift-off and its target:
        18 values t, com_x, com_y, torso_yaw, v_sagittal, u_v, u_Δθ, heading target,
        predicted (x_s, x_l, ℒ_s, ℒ_l), measured (x_s, x_l, ℒ_s, ℒ_l), swing yaw
        (start, target). `LOG_*` below index it.

Discrete state (private layout), updated by a periodic unrestricted update every
`walking.planner_period` (default 20 ms, 50 Hz). Each update: detect touchdown (swing
ankle at the ground within the last (1 − `early_touchdown`)·T of the step, or the step's
end reached) and switch stance; otherwise take up the step's command once it is there
and re-plan the swing target with the ALIP law of `robot.alip` (sagittal ℒ_des = m H
v_des, lateral ±½ m H W ℓ tanh(ℓT/2), clamped to the step limits of `WalkingParams`),
frozen in the last (1 − `target_freeze_fraction`)·T for a clean landing. The pivot is
the stance ankle's ground projection; L is measured about it with
`CalcSpatialMomentumInWorldAboutPoint`. T and g come from `RobotParams`.

Step clock. Steps are locked to the instants t_k = `stand_time` + (k − 1)·T (k ≥ 1; in the
navigation diagram `stand_time` = T, so these are the navigation planner's instants kT):
step k is planned to end at t_{k+1}. A touchdown up to (1 − `early_touchdown`)·T early
switches stance at once, and the new step then lasts until t_{k+1} (its `duration` is
T plus the lead), so early touchdowns never accumulate: every switch lies in
[t_k − (1 − early_touchdown)·T, t_k]. (Without the lock the swing foot, which lands at
T with a downward speed, touched one update early on most steps and the switches drifted
ahead of the planner's clock by 5 ms a step: 0.145 s after 48 steps.)

In-step commands. Every update of one instant reads the pre-update state, so the switch
at (or just before) t_k sees the command held before t_k. The step therefore starts with
the previous speed and no turn, and takes up its own command — the one held at the first
update strictly after t_k: u_k, computed by the navigation planner at t_k from the state
at t_k — one update later (t_k + `planner_period`: 20 ms, 5 % of the step, at the default
50 Hz). The heading target, the swing foot's yaw target and the speed of the foot
placement are re-targeted then; the torso and swing-yaw references are quintics that have
barely left their start by then, so the re-targeting is smooth. Step k thus walks u_k, as
the LIP does; the speed still reaches u_v at the end of the next step (the ALIP's own lag).
"""

from __future__ import annotations

import logging
import math

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import BasicVector, Context, LeafSystem, State

from emonav_drake.navigation.lip_world import check_command
from emonav_drake.params import RobotParams, WalkingParams
from emonav_drake.robot.alip import (
    alip_predict,
    foot_placement,
    lateral_momentum_target,
)
from emonav_drake.robot.lip import wrap_angle
from emonav_drake.robot.walking_targets import DOUBLE_SUPPORT, GaitTiming, WalkingTargets
from emonav_drake.systems.digit_plant import ANKLE_TO_SOLE, DigitModel

log = logging.getLogger(__name__)

# step_log layout (public: the walking run and the notebooks read it)
LOG_TIME = 0
LOG_COM = slice(1, 3)
LOG_YAW = 3
LOG_SPEED = 4
LOG_COMMAND = slice(5, 7)
LOG_HEADING_TARGET = 7
LOG_PREDICTED = slice(8, 12)
LOG_MEASURED = slice(12, 16)
LOG_SWING_YAW = slice(16, 18)
N_LOG = 18

# private discrete-state layout
_PHASE = 0  # DOUBLE_SUPPORT, LEFT_STANCE or RIGHT_STANCE
_START = 1  # step start time [s]
_STANCE = slice(2, 5)  # stance ankle, W [m]
_SW0 = slice(5, 8)  # swing ankle at lift-off [m]
_SW1 = slice(8, 11)  # swing ankle target [m]
_SWYAW0, _SWYAW1 = 11, 12  # swing foot yaw at lift-off and target [rad]
_HEAD0, _HEAD1 = 13, 14  # torso heading at the step start and target [rad]
_XC0 = slice(15, 17)  # CoM − stance pivot at the step start, W xy [m]
_LV0 = slice(17, 19)  # ℒ at the step start, W axes [kg·m²/s]
_COUNT = 19  # steps started
_INTEGRAL = 20  # speed integrator [m/s]
_CMD = slice(21, 23)  # command of the step in progress
_COM_SWITCH = slice(23, 25)  # CoM xy at the last switch
_PRED = slice(25, 29)  # the prediction of the end (x_s, x_l, ℒ_s, ℒ_l)
_PREDICTED = 29  # 1 once this step's prediction is stored
_CLIPPED = 30  # clipped commands so far
_END = 31  # the step's planned end: the next instant of the step clock [s]
_ADOPTED = 32  # 1 once the step's own command is taken up
_LOG = slice(33, 33 + N_LOG)
_N_STATE = 33 + N_LOG


def _yaw(R: np.ndarray) -> float:
    return math.atan2(R[1, 0], R[0, 0])


def gait_timing(params: WalkingParams, robot: RobotParams) -> GaitTiming:
    """The gait constants the planner hands to the controller with every target."""
    return GaitTiming(
        step_time=robot.step_time,
        gravity=robot.gravity,
        heading_blend=params.heading_blend_fraction,
        swing_yaw_blend=params.swing_yaw_blend_fraction,
        swing_finish=params.swing_finish_fraction,
        clearance=params.clearance,
        touchdown_speed=params.touchdown_speed,
        stand_com_lead=params.stand_com_lead,
    )


class AlipFootstepPlanner(LeafSystem):
    """ALIP footstep planner (see the module docstring).

    Args:
        model: the Digit plant and its index maps.
        params: gait, clamps and rates (`WalkingParams`).
        robot: the step time T, gravity g and the command bounds (ū_v, ū_Δθ).
        height: ALIP height H [m] (the standing CoM height of the plant).

    The initial heading and feet are read from the plant state at initialization.
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
        self._T = robot.step_time
        self._g = robot.gravity
        self._mass = model.total_mass
        self._H = height
        self._timing = gait_timing(params, robot)
        self._feet = model.foot_bodies
        init = np.zeros(_N_STATE)
        init[_PHASE] = DOUBLE_SUPPORT
        self._xd = self.DeclareDiscreteState(init)
        nx = self._plant.num_positions() + self._plant.num_velocities()
        self._state_in = self.DeclareVectorInputPort("state", nx)
        self._cmd_in = self.DeclareVectorInputPort("command", 2)
        self.DeclareAbstractOutputPort(
            "targets",
            lambda: AbstractValue.Make(self._targets_from(init)),
            self._calc_targets,
            {self.xd_ticket()},
        )
        self.DeclareVectorOutputPort("next_step", 1, self._calc_next_step, {self.xd_ticket()})
        self.DeclareVectorOutputPort("step_log", N_LOG, self._calc_step_log, {self.xd_ticket()})
        self.DeclareInitializationUnrestrictedUpdateEvent(self._initialize)
        self.DeclarePeriodicUnrestrictedUpdateEvent(params.planner_period, 0.0, self._update)

    @property
    def height(self) -> float:
        """The ALIP height H [m]."""
        return self._H

    # ---- outputs -------------------------------------------------------------------
    def _targets_from(self, x: np.ndarray) -> WalkingTargets:
        v = x.tolist()
        return WalkingTargets(
            phase=int(v[_PHASE]),
            start_time=v[_START],
            duration=max(v[_END] - v[_START], 1e-6) if v[_PHASE] != DOUBLE_SUPPORT else self._T,
            stance=tuple(v[_STANCE]),
            swing_start=tuple(v[_SW0]),
            swing_target=tuple(v[_SW1]),
            swing_yaw_start=v[_SWYAW0],
            swing_yaw_target=v[_SWYAW1],
            heading_start=v[_HEAD0],
            heading_target=v[_HEAD1],
            xc0=tuple(v[_XC0]),
            momentum0=tuple(v[_LV0]),
            height=self._H,
            mass=self._mass,
            timing=self._timing,
        )

    def _calc_targets(self, context: Context, output: AbstractValue) -> None:
        output.set_value(self._targets_from(context.get_discrete_state(self._xd).get_value()))

    def _calc_next_step(self, context: Context, output: BasicVector) -> None:
        output.SetAtIndex(0, context.get_discrete_state(self._xd).get_value()[_COUNT])

    def _calc_step_log(self, context: Context, output: BasicVector) -> None:
        output.SetFromVector(context.get_discrete_state(self._xd).get_value()[_LOG])

    def clipped_commands(self, context: Context) -> int:
        """How many commands were clipped so far (from this system's `context`)."""
        return int(context.get_discrete_state(self._xd).get_value()[_CLIPPED])

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
        x[_PHASE] = DOUBLE_SUPPORT
        x[_STANCE] = p0
        x[_SW0] = x[_SW1] = p1
        com = self._plant.CalcCenterOfMassPositionInWorld(self._ctx)
        x[_COM_SWITCH] = com[:2]
        R_WT = self._plant.EvalBodyPoseInWorld(self._ctx, self._model.torso_body).rotation()
        x[_HEAD0] = x[_HEAD1] = _yaw(R_WT.matrix())
        state.get_mutable_discrete_state(self._xd).set_value(x)

    def _momentum(self, pivot: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """CoM − pivot (world xy), ℒ in world axes (ℒ_x = L_y, ℒ_y = −L_x), and the CoM."""
        com = self._plant.CalcCenterOfMassPositionInWorld(self._ctx)
        L = self._plant.CalcSpatialMomentumInWorldAboutPoint(self._ctx, pivot).rotational()
        return com[:2] - pivot[:2], np.array([L[1], -L[0]]), com

    def _update(self, context: Context, state: State) -> None:
        x = context.get_discrete_state(self._xd).get_value().copy()
        t = context.get_time()
        p = self._p
        T = self._T
        self._set_plant(context)
        phase = int(x[_PHASE])
        if phase == DOUBLE_SUPPORT:
            if t + 1e-9 >= p.stand_time:
                self._start_step(x, t, stance=0, first=True, context=context)
                state.get_mutable_discrete_state(self._xd).set_value(x)
            return
        swing = 1 - phase
        remaining = x[_END] - t
        p_sw, _ = self._ankle(swing)
        touched = (
            remaining <= (1.0 - p.early_touchdown) * T + 1e-9
            and p_sw[2] <= ANKLE_TO_SOLE + p.touchdown_tolerance
        )
        if touched or remaining <= 1e-9:
            self._start_step(x, t, stance=swing, first=False, context=context)
        else:
            if not x[_ADOPTED] and t > x[_END] - T + 1e-9:
                self._take_command(x, t, context)
            self._plan_foot(x, remaining)
        state.get_mutable_discrete_state(self._xd).set_value(x)

    def _frame(self, heading: float) -> tuple[np.ndarray, np.ndarray]:
        c, s = math.cos(heading), math.sin(heading)
        return np.array([c, s]), np.array([-s, c])

    def _plan_foot(self, x: np.ndarray, remaining: float) -> None:
        """Re-plan the swing target from the measured ALIP state (`remaining`: time to the
        step's planned end [s])."""
        p = self._p
        T = self._T
        stance = int(x[_PHASE])
        pivot = np.array([x[_STANCE][0], x[_STANCE][1], 0.0])
        xc_w, lv_w, _ = self._momentum(pivot)
        es, el = self._frame(x[_HEAD1])
        xc = np.array([xc_w @ es, xc_w @ el])
        lv = np.array([lv_w @ es, lv_w @ el])
        mH = self._mass * self._H
        v_des = x[_CMD][0] + x[_INTEGRAL]
        next_right = stance == 0  # the swing foot (right when left stands) is next
        target = np.array(
            [
                mH * v_des,
                lateral_momentum_target(p.step_width, next_right, self._mass, self._H, T, self._g),
            ]
        )
        if not x[_PREDICTED] and remaining <= (1.0 - p.prediction_fraction) * T + 1e-9:
            xe, le = alip_predict(xc, lv, remaining, self._mass, self._H, self._g)
            x[_PRED] = np.concatenate([xe, le])
            x[_PREDICTED] = 1.0
        if remaining < (1.0 - p.target_freeze_fraction) * T - 1e-9:
            return  # freeze the target for a clean landing
        step = foot_placement(xc, lv, remaining, target, self._mass, self._H, T, self._g)
        s = float(np.clip(step[0], -p.max_step_length, p.max_step_length))
        lat = float(step[1])
        if next_right:
            lat = float(np.clip(lat, -p.lateral_step_max, -p.lateral_step_min))
        else:
            lat = float(np.clip(lat, p.lateral_step_min, p.lateral_step_max))
        xy = pivot[:2] + s * es + lat * el
        x[_SW1] = [xy[0], xy[1], ANKLE_TO_SOLE]

    def _start_step(
        self, x: np.ndarray, t: float, stance: int, first: bool, context: Context
    ) -> None:
        """Foot switch: the swing foot becomes the stance foot; the new step is planned to
        end at the step clock's next instant."""
        p = self._p
        swing = 1 - stance
        p_st, _ = self._ankle(stance)
        p_sw, yaw_sw = self._ankle(swing)
        pivot = np.array([p_st[0], p_st[1], 0.0])
        xc_w, lv_w, com = self._momentum(pivot)
        # measured end of the previous step about its pivot (heading frame of that step)
        es_old, el_old = self._frame(x[_HEAD1])
        old_pivot = np.array([x[_STANCE][0], x[_STANCE][1], 0.0])
        xc_o, lv_o, _ = self._momentum(old_pivot)
        xc_end = np.array([xc_o @ es_old, xc_o @ el_old])
        lv_end = np.array([lv_o @ es_old, lv_o @ el_old])
        dt = t - x[_START]
        if not first and dt > 0.5 * self._T:
            v_mean = float((com[:2] - x[_COM_SWITCH]) @ es_old) / dt
            if x[_COUNT] >= 2:
                err = x[_CMD][0] - v_mean
                lim = p.speed_integral_limit
                x[_INTEGRAL] = float(np.clip(x[_INTEGRAL] + p.speed_integral_gain * err, -lim, lim))
        # until its own command arrives after the step clock's instant (`_take_command`),
        # the step keeps the previous speed (zero before the first step) and does not turn
        u = np.array([x[_CMD][0], 0.0])
        R_WT = self._plant.EvalBodyPoseInWorld(self._ctx, self._model.torso_body).rotation()
        head_old = x[_HEAD1]
        # Heading targets accumulate the commands (unwrapped); measured yaws are wrapped to
        # (−π, π]. Unwrap them next to the targets, or past ±π the swing foot and the torso
        # would be sent the long way round (a ~2π twist).
        torso_yaw = head_old + wrap_angle(_yaw(R_WT.matrix()) - head_old)
        v_com = self._plant.CalcCenterOfMassTranslationalVelocityInWorld(self._ctx)
        head_new = head_old + float(u[1])
        swing_yaw0 = head_old + wrap_angle(yaw_sw - head_old)
        # step log: the switch just reached and the command for the step that starts
        pred = x[_PRED] if x[_PREDICTED] else np.full(4, np.nan)
        x[_LOG] = [
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
            swing_yaw0,
            head_new,
        ]
        x[_PHASE] = float(stance)
        x[_START] = t
        # the step clock: the first step ends T after stand_time, each next one T later
        x[_END] = (p.stand_time if first else x[_END]) + self._T
        x[_ADOPTED] = 0.0
        x[_STANCE] = p_st
        x[_SW0] = p_sw
        x[_SW1] = p_sw
        x[_SWYAW0] = swing_yaw0
        x[_SWYAW1] = head_new
        x[_HEAD0] = torso_yaw if first else head_old
        x[_HEAD1] = head_new
        x[_XC0] = xc_w
        x[_LV0] = lv_w
        x[_CMD] = u
        x[_COM_SWITCH] = com[:2]
        x[_PREDICTED] = 0.0
        x[_COUNT] += 1
        self._plan_foot(x, x[_END] - t)

    def _take_command(self, x: np.ndarray, t: float, context: Context) -> None:
        """The step's own command (held since the step clock's instant): re-target the
        heading, the swing foot's yaw and the foot placement's speed of the step."""
        raw = self._cmd_in.Eval(context)
        u, clipped = check_command(raw, self._robot, clip=True)
        if clipped:
            x[_CLIPPED] += 1
            log.warning(
                "AlipFootstepPlanner: command %s out of bounds at t = %.3f s, clipped to %s",
                np.asarray(raw).tolist(),
                t,
                u.tolist(),
            )
        head_new = x[_HEAD1] - x[_CMD][1] + float(u[1])  # the previous target + u_Δθ
        x[_CMD] = u
        x[_HEAD1] = x[_SWYAW1] = head_new
        x[_ADOPTED] = 1.0
        step_log = x[_LOG]  # a view: the step's log entry, now with its own command
        step_log[LOG_COMMAND] = u
        step_log[LOG_HEADING_TARGET] = step_log[LOG_SWING_YAW.stop - 1] = head_new
