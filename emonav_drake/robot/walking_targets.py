"""What the footstep planner asks of the whole-body controller, and its reference motion.

`WalkingTargets` is the typed interface between the ALIP footstep planner (200 Hz) and
the passivity controller (1 kHz): the planner fills one at every update; the controller
only evaluates its reference methods at its own tick. Every gait timing constant lives
in `GaitTiming` (filled from `WalkingParams` and `RobotParams`), so the planner and the
controller cannot disagree on them.

Frames: world W (z up); positions of the ankles (foot frames, on the toe-roll axis) in W
[m]; yaws [rad] about W's z, unwrapped next to the heading targets; ℒ is the ALIP
"momentum velocity" [kg·m²/s] along W's x and y (ℒ_x = L_y, ℒ_y = −L_x about the
stance pivot, = m H v for a CoM at height H).

The reference motion during a step that started at `start_time` (phase time τ = t − t_s):

* torso heading: a quintic from `heading0` to `heading1`, reached at
  `heading_blend`·T (double support: hold `heading1`);
* CoM horizontally: the ALIP trajectory from the step's start state (x_c0, ℒ_0) about
  the stance pivot (double support: between the feet, `stand_com_lead` ahead);
* swing foot: horizontally a quintic from `swing_start` to `swing_target`, reached at
  `swing_finish`·D; vertically `robot.alip.swing_height` (apex `clearance` at D/2, lands
  at D with `touchdown_speed`), D the step's `duration` (T, or a little more after an
  early touchdown: the step then ends at the step clock's next instant); its yaw a
  quintic reached at `swing_yaw_blend`·T.

Scalar Python math on purpose: the controller calls these 1000 times a second and numpy
has a fixed cost per call that dwarfs the arithmetic of a 2-vector.
"""

from __future__ import annotations

import dataclasses as dc
import math

from emonav_drake.robot.alip import alip_predict, quintic_blend, smooth_angle, swing_height

DOUBLE_SUPPORT = -1
LEFT_STANCE = 0
RIGHT_STANCE = 1

Vec2 = tuple[float, float]
Vec3 = tuple[float, float, float]


@dc.dataclass(frozen=True)
class GaitTiming:
    """The gait's time constants and shapes (one owner: `WalkingParams` / `RobotParams`).

    Attributes:
        step_time: T [s].
        gravity: g [m/s²].
        heading_blend: the torso heading reaches its target at this fraction of T.
        swing_yaw_blend: the swing foot's yaw reaches its target at this fraction of T.
        swing_finish: the swing foot reaches its target horizontally at this fraction.
        clearance: swing apex above the landing height [m].
        touchdown_speed: swing foot's downward speed at T [m/s].
        stand_com_lead: standing CoM target ahead of the feet's midpoint [m].
    """

    step_time: float
    gravity: float
    heading_blend: float
    swing_yaw_blend: float
    swing_finish: float
    clearance: float
    touchdown_speed: float
    stand_com_lead: float


@dc.dataclass(frozen=True)
class SwingReference:
    """Swing ankle reference in W: position [m], velocity [m/s], acceleration [m/s²] and
    yaw (angle, rate, acceleration) [rad, rad/s, rad/s²]."""

    position: Vec3
    velocity: Vec3
    acceleration: Vec3
    yaw: Vec3


@dc.dataclass(frozen=True)
class WalkingTargets:
    """The current step's targets (world frame W; see the module docstring).

    Attributes:
        phase: DOUBLE_SUPPORT (standing), LEFT_STANCE or RIGHT_STANCE.
        start_time: when the step started [s].
        duration: how long the step is planned to last [s]: until the next instant of the
            step clock (T when the step started on time, up to 10 % more after an early
            touchdown); the swing foot lands at `start_time + duration`.
        stance: stance ankle position [m].
        swing_start: swing ankle at lift-off [m] (standing: the other ankle).
        swing_target: swing ankle landing target from the ALIP [m].
        swing_yaw_start, swing_yaw_target: swing foot yaw at lift-off and its target [rad].
        heading_start, heading_target: torso heading at the step start and target [rad].
        xc0: CoM − stance pivot at the step start, W's x and y [m].
        momentum0: ℒ at the step start, W's x and y [kg·m²/s].
        height: the ALIP height H [m]; mass: the robot's mass m [kg].
        timing: the gait constants.
    """

    phase: int
    start_time: float
    duration: float
    stance: Vec3
    swing_start: Vec3
    swing_target: Vec3
    swing_yaw_start: float
    swing_yaw_target: float
    heading_start: float
    heading_target: float
    xc0: Vec2
    momentum0: Vec2
    height: float
    mass: float
    timing: GaitTiming

    @property
    def standing(self) -> bool:
        return self.phase == DOUBLE_SUPPORT

    @property
    def swing_leg(self) -> int:
        """0 left, 1 right (the leg that is not the stance leg; undefined standing)."""
        return 1 - self.phase

    def torso_yaw(self, t: float) -> Vec3:
        """Torso heading reference at time t: (yaw, rate, acceleration)."""
        if self.standing:
            return self.heading_target, 0.0, 0.0
        tm = self.timing
        return smooth_angle(
            t - self.start_time,
            tm.heading_blend * tm.step_time,
            self.heading_start,
            self.heading_target,
        )

    def com(self, t: float, yaw: float) -> tuple[Vec2, Vec2]:
        """Horizontal CoM reference at time t: ((x, y) [m], (ẋ, ẏ) [m/s]) in W.

        Standing: between the ankles, `stand_com_lead` ahead along `yaw` (the torso's
        reference heading), at rest. Walking: the ALIP trajectory of this step.
        """
        if self.standing:
            lead = self.timing.stand_com_lead
            return (
                0.5 * (self.stance[0] + self.swing_start[0]) + lead * math.cos(yaw),
                0.5 * (self.stance[1] + self.swing_start[1]) + lead * math.sin(yaw),
            ), (0.0, 0.0)
        tau = max(t - self.start_time, 0.0)
        m, h, g = self.mass, self.height, self.timing.gravity
        ax, lx = alip_predict(self.xc0[0], self.momentum0[0], tau, m, h, g)
        ay, ly = alip_predict(self.xc0[1], self.momentum0[1], tau, m, h, g)
        mh = m * h
        return (self.stance[0] + ax, self.stance[1] + ay), (lx / mh, ly / mh)

    def pendulum_acceleration(self, com_x: float, com_y: float) -> Vec2:
        """The ALIP's own horizontal acceleration (g/H)(c − p_stance) at a CoM [m/s²]
        (zero when standing): the ankle then only corrects the error to the reference."""
        if self.standing:
            return 0.0, 0.0
        w2 = self.timing.gravity / self.height
        return w2 * (com_x - self.stance[0]), w2 * (com_y - self.stance[1])

    def swing(self, t: float) -> SwingReference:
        """Swing ankle reference at time t (walking phases only)."""
        tm = self.timing
        T = tm.step_time
        D = self.duration
        tau = t - self.start_time
        p0, p1 = self.swing_start, self.swing_target
        (px, py), (vx, vy), (ax, ay) = swing_horizontal_xy(
            tau, tm.swing_finish * D, p0[0], p0[1], p1[0], p1[1]
        )
        z, dz, ddz = swing_height(tau, D, p0[2] - p1[2], tm.clearance, tm.touchdown_speed)
        yaw = smooth_angle(tau, tm.swing_yaw_blend * T, self.swing_yaw_start, self.swing_yaw_target)
        return SwingReference((px, py, p1[2] + z), (vx, vy, dz), (ax, ay, ddz), yaw)


def swing_horizontal_xy(
    t: float, duration: float, x0: float, y0: float, x1: float, y1: float
) -> tuple[Vec2, Vec2, Vec2]:
    """Quintic blend from (x0, y0) to (x1, y1) over `duration` [s], then held: position,
    velocity and acceleration at time t (scalar form of `robot.alip.swing_horizontal`)."""
    b, db, ddb = quintic_blend(t / duration)
    dx, dy = x1 - x0, y1 - y0
    k1, k2 = db / duration, ddb / duration**2
    return (x0 + dx * b, y0 + dy * b), (dx * k1, dy * k1), (dx * k2, dy * k2)
