"""The field's social-navigation metrics of one episode, accumulated walking step by step.

Beside the paper's SR, NT, DT and IDT (`navigation/metrics.py`) an episode record carries the
metrics most social-navigation benchmarks report (definitions, units, thresholds and
sources: `docs/metrics.md`). Everything is sampled once per walking step, at the foot
switch t_k that ends step k, where the paper's metrics are evaluated too; world frame
(x towards the robot's goal, y left), metres, seconds, radians.

* `path_irregularity` [rad/m] (SocNavBench): the robot's turning beyond the least it
  needs to face its goal, per metre walked:
  (Σ_k |wrap(θ_k − θ_{k−1})| − |wrap(β_0 − θ_0)|)⁺ / L, with β_0 the bearing of the goal
  from the start, θ the heading at the foot switches and L the path length. None while
  the robot has not moved.
* `jerk_mean` [m/s³] (Francis et al. 2025, "movement jerk"): the mean magnitude of the
  second difference of the commanded velocity, |V_k − 2V_{k−1} + V_{k−2}| / T², over the
  steps k ≥ 2 of the episode. V_k = u_v,k (cos ψ_k, sin ψ_k) is the velocity command k
  asks for, ψ_k = Σ_{j≤k} u_Δθ,j its heading (the magnitude does not depend on the
  initial heading). None before three commands, or when a step gave no command.
* `min_ped_clearance` [m] (Francis et al. 2025, "minimum distance to human"): the
  smallest surface-to-surface robot–pedestrian distance, ‖p_i − p‖ − r_ped − r_robot
  (≤ 0: touching). None without pedestrians.
* `low_ttc_ratio` [–] (Francis et al. 2025, "time to collision"): the share of steps in
  which some pedestrian's time to collision is below `TTC_THRESHOLD` — the first time at
  which robot and pedestrian discs would touch if both kept their velocities
  (constant-velocity extrapolation; 0 when they already touch).
* `intrusion_ratio` [–] (CrowdNav++ / HEIGHT, Liu et al.: "intrusion time ratio"): the
  share of steps in which the robot is closer than `INTRUSION_DISTANCE` to some
  pedestrian, surface to surface.
* `intrusion_clearance` [m] (the same papers' "social distance during intrusions"): the
  mean over those steps of the smallest surface-to-surface distance; None without one.

`SocialMetrics` keeps a few numbers per episode (no per-step lists), so the Drake
episode monitor can copy it every step. Pedestrians only: static discs and walls do
not count (the paper's DT and IDT cover the discs).
"""

from __future__ import annotations

import dataclasses as dc
import math

import numpy as np

from emonav_drake.crowd.crowd import CrowdSnapshot
from emonav_drake.robot.lip import LipState, wrap_angle

INTRUSION_DISTANCE = 0.25  # [m] surface to surface: CrowdNav++ / HEIGHT's discomfort distance
TTC_THRESHOLD = 3.0  # [s]: beyond it pedestrians hardly react to each other (docs/metrics.md)

# Where each metric's values can lie (None: unbounded); its interval is clipped to it.
SUPPORT: dict[str, tuple[float | None, float | None]] = {
    "path_irregularity": (0.0, None),
    "jerk_mean": (0.0, None),
    "min_ped_clearance": (None, None),
    "low_ttc_ratio": (0.0, 1.0),
    "intrusion_ratio": (0.0, 1.0),
    "intrusion_clearance": (None, INTRUSION_DISTANCE),
}

# The record fields this module fills (`EpisodeRecord`), in table order.
SOCIAL_FIELDS = (
    "path_irregularity",
    "jerk_mean",
    "min_ped_clearance",
    "low_ttc_ratio",
    "intrusion_ratio",
    "intrusion_clearance",
)


@dc.dataclass(frozen=True)
class StepMotion:
    """What one walking step did, for the social metrics (world frame, SI units).

    start: the robot (x [m], y [m], θ [rad], v [m/s]) at the foot switch that began the
        step; end: at the foot switch that ends it, where the step is evaluated.
    crowd: the crowd at the end of the step (positions [m], velocities [m/s], radius).
    goal_xy: the robot's goal [m]; robot_radius: r_robot [m].
    command: (u_v [m/s], u_Δθ [rad]) the robot executed during the step, or None when
        the caller does not know it (then `jerk_mean` is not measured).
    """

    start: LipState
    end: LipState
    crowd: CrowdSnapshot
    goal_xy: np.ndarray
    robot_radius: float
    command: np.ndarray | None = None


def times_to_collision(
    rel_positions: np.ndarray, rel_velocities: np.ndarray, contact_distance: float
) -> np.ndarray:
    """Constant-velocity time to collision [s] of each pair, (P,).

    rel_positions (P, 2) [m] and rel_velocities (P, 2) [m/s] are the other agent's minus
    the robot's; the pair collides when the centres are `contact_distance` [m] apart.
    0 where they already are that close; inf where they never get that close.
    """
    p = np.asarray(rel_positions, dtype=float).reshape(-1, 2)
    w = np.asarray(rel_velocities, dtype=float).reshape(-1, 2)
    c = np.einsum("ij,ij->i", p, p) - contact_distance**2
    b = np.einsum("ij,ij->i", p, w)
    a = np.einsum("ij,ij->i", w, w)
    disc = b * b - a * c
    out = np.full(len(p), math.inf)
    closing = (b < 0.0) & (disc >= 0.0) & (a > 0.0)
    out[closing] = (-b[closing] - np.sqrt(disc[closing])) / a[closing]
    out[c <= 0.0] = 0.0
    return out


def _velocity(state: LipState) -> np.ndarray:
    return np.array([state.speed * math.cos(state.heading), state.speed * math.sin(state.heading)])


class SocialMetrics:
    """The social metrics of one episode, one walking step at a time (module docstring).

    Args:
        step_time: T [s], the time between two commands (jerk's finite differences).
        intrusion_distance: the surface-to-surface intrusion threshold [m].
        ttc_threshold: the time-to-collision threshold [s].
    """

    def __init__(
        self,
        step_time: float,
        intrusion_distance: float = INTRUSION_DISTANCE,
        ttc_threshold: float = TTC_THRESHOLD,
    ) -> None:
        if not (math.isfinite(step_time) and step_time > 0):
            raise ValueError(f"step_time = {step_time!r} must be a number > 0 [s]")
        self.step_time = step_time
        self.intrusion_distance = intrusion_distance
        self.ttc_threshold = ttc_threshold
        self.steps = 0
        self.path_length = 0.0  # [m]
        self.rotation = 0.0  # Σ |Δθ| [rad]
        self.least_rotation = 0.0  # |wrap(β_0 − θ_0)| [rad]
        self.commanded = True  # every step so far came with its command
        self.heading = 0.0  # ψ_k of the last command [rad]
        self.velocities: list[list[float]] = []  # V_{k−1}, V_k (at most two) [m/s]
        self.jerk_sum = 0.0  # Σ |J_k| [m/s³]
        self.jerk_count = 0
        self.min_clearance = math.inf  # [m]
        self.low_ttc_steps = 0
        self.intrusion_steps = 0
        self.intrusion_clearance_sum = 0.0  # [m]

    def add(self, m: StepMotion) -> None:
        """Account for one walking step."""
        if self.steps == 0:
            gx, gy = float(m.goal_xy[0]), float(m.goal_xy[1])
            if (gx, gy) != (m.start.x, m.start.y):
                bearing = math.atan2(gy - m.start.y, gx - m.start.x)
                self.least_rotation = abs(wrap_angle(bearing - m.start.heading))
        self.steps += 1
        self.path_length += math.hypot(m.end.x - m.start.x, m.end.y - m.start.y)
        self.rotation += abs(wrap_angle(m.end.heading - m.start.heading))
        self._add_command(m.command)
        crowd = m.crowd
        if len(crowd.positions):
            rel = np.asarray(crowd.positions, dtype=float) - np.array([m.end.x, m.end.y])
            contact = m.robot_radius + crowd.radius
            gap = float(np.min(np.linalg.norm(rel, axis=1))) - contact
            self.min_clearance = min(self.min_clearance, gap)
            if gap < self.intrusion_distance:
                self.intrusion_steps += 1
                self.intrusion_clearance_sum += gap
            rel_v = np.asarray(crowd.velocities, dtype=float) - _velocity(m.end)
            ttc = times_to_collision(rel, rel_v, contact)
            self.low_ttc_steps += int(float(np.min(ttc)) < self.ttc_threshold)

    def _add_command(self, command: np.ndarray | None) -> None:
        if command is None:
            self.commanded = False
        if not self.commanded:
            return
        speed, turn = float(command[0]), float(command[1])
        self.heading += turn
        v = [speed * math.cos(self.heading), speed * math.sin(self.heading)]
        if len(self.velocities) == 2:
            (ax, ay), (bx, by) = self.velocities
            jx = (v[0] - 2.0 * bx + ax) / self.step_time**2
            jy = (v[1] - 2.0 * by + ay) / self.step_time**2
            self.jerk_sum += math.hypot(jx, jy)
            self.jerk_count += 1
        self.velocities = [*self.velocities[-1:], v]

    def values(self) -> dict[str, float | None]:
        """The record fields (`SOCIAL_FIELDS`) after the steps so far."""
        n = self.steps
        irregular = None
        if self.path_length > 0.0:
            irregular = max(self.rotation - self.least_rotation, 0.0) / self.path_length
        return {
            "path_irregularity": irregular,
            "jerk_mean": (
                self.jerk_sum / self.jerk_count if self.commanded and self.jerk_count else None
            ),
            "min_ped_clearance": None if math.isinf(self.min_clearance) else self.min_clearance,
            "low_ttc_ratio": self.low_ttc_steps / n if n else None,
            "intrusion_ratio": self.intrusion_steps / n if n else None,
            "intrusion_clearance": (
                self.intrusion_clearance_sum / self.intrusion_steps
                if self.intrusion_steps
                else None
            ),
        }

    def to_plain(self) -> dict:
        """The accumulator as plain data (Python numbers and lists); `from_plain` reverses."""
        return {k: (list(map(list, v)) if k == "velocities" else v) for k, v in vars(self).items()}

    @classmethod
    def from_plain(cls, d: dict) -> SocialMetrics:
        """A `SocialMetrics` back from `to_plain()` (`ValueError` if a field is missing)."""
        out = cls(float(d["step_time"]))
        missing = sorted(set(vars(out)) - set(d))
        if missing:
            raise ValueError(f"saved social metrics lack {', '.join(missing)}")
        for k in vars(out):
            setattr(out, k, [list(v) for v in d[k]] if k == "velocities" else d[k])
        return out


def check_social_fields(record: dict) -> str | None:
    """What is wrong with the field's metrics in a record's JSON (`EpisodeRecord.to_json`),
    in words; None if each is absent or null (not measured) or a valid value: finite
    numbers, irregularity and jerk >= 0, ratios in [0, 1] that are a whole number of the
    record's `steps`, and a clearance during intrusions exactly when there was one."""
    for name in SOCIAL_FIELDS:
        v = record.get(name)
        if v is None:
            continue
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            return f"record.{name} = {v!r} must be a finite number or null"
        if name in ("path_irregularity", "jerk_mean") and v < 0:
            return f"record.{name} = {v!r} must be >= 0"
        if name.endswith("_ratio"):
            steps = record.get("steps", 0)
            count = v * steps
            if not (0.0 <= v <= 1.0 and abs(count - round(count)) <= 1e-6):
                return (
                    f"record.{name} = {v!r} must be a share of the record's {steps} steps "
                    "(a whole number of steps divided by steps, in [0, 1])"
                )
    ratio, clearance = record.get("intrusion_ratio"), record.get("intrusion_clearance")
    if ratio is not None and (clearance is None) != (ratio == 0):
        return (
            f"record.intrusion_clearance = {clearance!r} with record.intrusion_ratio = "
            f"{ratio!r}: a clearance during intrusions exactly when there was one"
        )
    return None
