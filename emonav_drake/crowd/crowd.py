"""Pedestrians with emotions and static discs: the crowd of the paper's world (§IV-B).

Pedestrians walk start → goal at the preferred speed with ORCA (RVO2 semantics, see
`orca.py`) and turn round at their goal. Static discs are ORCA obstacles. The robot is
an ORCA neighbour that a pedestrian takes into account **only when the pedestrian is
faster than the robot** (the paper's visibility rule); the robot's own velocity is never
changed by ORCA.

`Crowd` holds what does not change during an episode (radii, discs, emotion schedules,
parameters); `CrowdState` is the changing part. `Crowd.step` is a pure function from
one state to the next (one period `dt`), so Drake can keep the state in a context and
the Gymnasium environment in an attribute, with identical results.

World frame, metres, seconds, m/s. Emotion codes: HAPPY 0, NEUTRAL 1, NEGATIVE 2.
"""

from __future__ import annotations

import dataclasses as dc
import math

import numpy as np

from emonav_drake.crowd.orca import OrcaParams, orca_velocities
from emonav_drake.crowd.pedestrian_legs import gait_offsets, gait_phase
from emonav_drake.crowd.pedestrian_pose import facing_headings, start_to_goal_headings
from emonav_drake.crowd.pedestrian_routes import RoutePlan
from emonav_drake.params import EMOTION_NAMES, EmoNavConfig
from emonav_drake.scenarios.scenario import Scenario
from emonav_drake.scenarios.scenario_spec import discs_in_place
from emonav_drake.scenarios.walls import wall_discs


@dc.dataclass(frozen=True)
class CrowdState:
    """The changing part of the crowd after `substep` periods of `dt`."""

    positions: np.ndarray  # (P, 2) pedestrian centres, world [m]
    velocities: np.ndarray  # (P, 2) world [m/s]
    goals: np.ndarray  # (P, 2) current goal of each pedestrian [m]
    origins: np.ndarray  # (P, 2) the other end of each pedestrian's route [m]
    emotions: np.ndarray  # (P,) int emotion codes in force now
    substep: int  # number of crowd periods since the episode began
    # Route progress of the pedestrians that are not the paper's plain walkers
    # (`crowd/pedestrian_routes.py`): index of `goals` in the route, walking it back,
    # periods left standing (−1: for good). None in states saved before routes existed.
    targets: np.ndarray | None = None  # (P,) int
    backwards: np.ndarray | None = None  # (P,) bool
    waits: np.ndarray | None = None  # (P,) int
    # (P,) distance each pedestrian has walked since the start [m] (its gait's odometer,
    # `crowd/pedestrian_legs.py`). None in states saved before it existed: 0.
    walked: np.ndarray | None = None

    def to_plain(self) -> dict:
        """The state as plain data (copies of the arrays; `from_plain` reads it back)."""
        return {f.name: _copy(getattr(self, f.name)) for f in dc.fields(self)}

    @classmethod
    def from_plain(cls, d: dict) -> CrowdState:
        """Inverse of `to_plain`; `ValueError` on missing fields or wrong shapes."""
        p = np.shape(d["positions"])
        if len(p) != 2 or p[1] != 2:
            raise ValueError(f"crowd positions have shape {p}, expected (P, 2)")
        for name in ("velocities", "goals", "origins"):
            if np.shape(d[name]) != p:
                raise ValueError(f"crowd {name} have shape {np.shape(d[name])}, expected {p}")
        if np.shape(d["emotions"]) != p[:1]:
            raise ValueError(f"crowd emotions have shape {np.shape(d['emotions'])}")
        for name in ("targets", "backwards", "waits", "walked"):
            if d.get(name) is not None and np.shape(d[name]) != p[:1]:
                raise ValueError(f"crowd {name} have shape {np.shape(d[name])}, expected {p[:1]}")
        return cls(**{f.name: _copy(d.get(f.name)) for f in dc.fields(cls)})


def _copy(v: object) -> object:
    return v.copy() if isinstance(v, np.ndarray) else v


@dc.dataclass(frozen=True)
class CrowdSnapshot:
    """Everything a planner or sensor may know about the crowd at one instant."""

    positions: np.ndarray  # (P, 2) [m]
    velocities: np.ndarray  # (P, 2) [m/s]
    radius: float  # pedestrian radius [m]
    emotions: np.ndarray  # (P,) int codes
    discomfort: np.ndarray  # (P,) discomfort distance of each pedestrian now [m]
    static_centers: np.ndarray  # (S, 2) [m]
    static_radii: np.ndarray  # (S,) [m]
    static_discomfort: float  # d_static [m]
    # (W, 2, 2) walls: segment k runs from wall_segments[k, 0] to wall_segments[k, 1] [m]
    wall_segments: np.ndarray = dc.field(default_factory=lambda: np.zeros((0, 2, 2)))
    # (P,) gait phase of each pedestrian [rad] (`crowd/pedestrian_legs.py`); None: all 0
    gait_phase: np.ndarray | None = None
    # (P,) yaw each pedestrian faces [rad], world frame: its walking direction, standing
    # towards its current goal; None: its velocity's direction (0 at rest)
    facing: np.ndarray | None = None
    time: float = 0.0  # since the episode began [s] (crowd periods · dt): the scan's time
    seed: int = 0  # the scenario's seed: with `time`, what the LiDAR's noise is drawn from


class Crowd:
    """The pedestrians and static discs of one scenario.

    Args:
        scenario: start/goal/emotion of each pedestrian and the static discs.
        config: crowd parameters (ORCA, speeds, radii) and discomfort distances.
    """

    def __init__(self, scenario: Scenario, config: EmoNavConfig) -> None:
        c = config.crowd
        self.dt = c.dt
        self.radius = c.pedestrian_radius
        self.preferred_speed = c.preferred_speed
        self.goal_tolerance = c.goal_tolerance
        self.safety_space = c.safety_space
        self.robot_radius = config.robot.radius
        self.orca = OrcaParams(
            neighbor_dist=c.neighbor_dist,
            max_neighbors=c.max_neighbors,
            time_horizon=c.time_horizon,
            time_horizon_obst=c.time_horizon_obst,
        )
        self.emotion_distances = np.asarray(config.reward.emotion_distances())
        self.static_discomfort = config.reward.static_discomfort
        peds = scenario.pedestrians
        self.num_pedestrians = len(peds)
        self.seed = int(scenario.seed)
        self._gait_offsets = gait_offsets(self.seed, self.num_pedestrians)
        self._starts = np.array([p.start for p in peds], dtype=float).reshape(-1, 2)
        self.routes = RoutePlan.from_specs(peds, self.preferred_speed, self.dt)
        self._all_plain = bool(self.routes.plain.all())
        self.static_centers = np.array([o.center for o in scenario.obstacles], dtype=float).reshape(
            -1, 2
        )
        self.static_radii = np.array([o.radius for o in scenario.obstacles], dtype=float)
        # When each disc is put in place [s] (`StaticDiscSpec.appears_at`); before, no one
        # sees or meets it.
        self.static_appear_times = np.array([o.appears_at for o in scenario.obstacles], dtype=float)
        self._all_static_present = not bool((self.static_appear_times > 0).any())
        self.wall_segments = scenario.wall_segments()
        # Emotion schedule: row i = codes of every pedestrian during period i.
        base = np.array([EMOTION_NAMES.index(p.emotion) for p in peds], dtype=np.int64)
        length = max([len(p.emotion_schedule) for p in peds], default=0)
        self._schedule = np.tile(base, (max(length, 1), 1))
        for i, p in enumerate(peds):
            for k, name in enumerate(p.emotion_schedule):
                self._schedule[k, i] = EMOTION_NAMES.index(name)
            if p.emotion_schedule:  # hold the last entry beyond the schedule
                self._schedule[len(p.emotion_schedule) :, i] = self._schedule[
                    len(p.emotion_schedule) - 1, i
                ]
        self._substeps_per_change = max(1, round(scenario.emotion_change_period / self.dt))
        # ORCA arrays for pedestrians + the robot (last), built once.
        n = self.num_pedestrians + 1
        self._radii = np.full(n, self.radius + self.safety_space)
        self._radii[-1] = self.robot_radius + self.safety_space
        self._max_speeds = np.append(self.routes.max_speeds, self.preferred_speed)
        self._active = np.ones(n, dtype=bool)
        self._active[-1] = False
        self._visible = ~np.eye(n, dtype=bool)
        # Members of a group keep their formation instead of avoiding each other.
        self._visible[:-1, :-1] &= ~self.routes.same_group()

    def emotions_at(self, substep: int) -> np.ndarray:
        """Emotion codes in force after `substep` crowd periods."""
        row = min(substep // self._substeps_per_change, len(self._schedule) - 1)
        return self._schedule[row].copy()

    def initial_state(self) -> CrowdState:
        """Pedestrians at rest at their starts."""
        p = self.num_pedestrians
        return CrowdState(
            positions=self._starts.copy(),
            velocities=np.zeros_like(self._starts),
            goals=self.routes.first_targets(),
            origins=self._starts.copy(),
            emotions=self.emotions_at(0),
            substep=0,
            targets=np.ones(p, dtype=np.int64),
            backwards=np.zeros(p, dtype=bool),
            waits=self.routes.delay_substeps.copy(),
            walked=np.zeros(p),
        )

    def step(
        self, state: CrowdState, robot_xy: np.ndarray, robot_velocity: np.ndarray
    ) -> CrowdState:
        """Advance the crowd by one period `dt` (new velocities from the old state)."""
        if self.num_pedestrians == 0:
            return dc.replace(state, substep=state.substep + 1)
        goals, origins = state.goals.copy(), state.origins.copy()
        plain = self.routes.plain
        # The paper's pedestrians turn round at the goal: swap the route's ends.
        to_goal = goals - state.positions
        arrived = plain & (np.hypot(to_goal[:, 0], to_goal[:, 1]) < self.goal_tolerance)
        if arrived.any():
            goals[arrived], origins[arrived] = state.origins[arrived], state.goals[arrived]
        targets, backwards, waits = _route_progress(state)
        standing = None
        if not self._all_plain:
            standing = self.routes.advance(
                state.positions, goals, origins, targets, backwards, waits, self.goal_tolerance
            )
        to_goal = goals - state.positions
        dist = np.hypot(to_goal[:, 0], to_goal[:, 1])
        # Preferred velocity: towards the goal, slowing to arrive exactly in one period.
        speed = np.minimum(self.routes.speeds, dist / self.dt)
        pref = to_goal * (speed / np.maximum(dist, 1e-9))[:, None]
        if standing is not None:
            pref[standing] = 0.0
            self.routes.follower_velocities(state.positions, state.velocities, pref)

        positions = np.vstack([state.positions, robot_xy[None, :]])
        velocities = np.vstack([state.velocities, robot_velocity[None, :]])
        pref_all = np.vstack([pref, robot_velocity[None, :]])
        # The paper's rule: a pedestrian sees the robot only when it is faster than it.
        visible = self._visible.copy()
        ped_speed = np.hypot(state.velocities[:, 0], state.velocities[:, 1])
        visible[:-1, -1] = ped_speed > math.hypot(robot_velocity[0], robot_velocity[1])
        active = self._active
        centers, radii = self.static_discs(state.substep * self.dt)
        if standing is not None and standing.any():
            # A standing pedestrian holds its spot: to the others it is a static disc
            # (they avoid it fully), and ORCA does not move it.
            active = active.copy()
            active[:-1] &= ~standing
            visible[:, :-1] &= ~standing[None, :]
            velocities[:-1][standing] = 0.0
            centers = np.vstack([centers, state.positions[standing]])
            radii = np.concatenate([radii, self._radii[:-1][standing]])
        new_v = orca_velocities(
            positions,
            velocities,
            self._radii,
            pref_all,
            self._max_speeds,
            self.dt,
            self.orca,
            obstacle_centers=centers,
            obstacle_radii=radii,
            obstacle_segments=self.wall_segments,
            visible=visible,
            active=active,
            check_inputs=False,  # arrays built here, float64/bool, shapes fixed per crowd
        )[:-1]
        substep = state.substep + 1
        walked = _walked(state) + np.hypot(new_v[:, 0], new_v[:, 1]) * self.dt
        return CrowdState(
            positions=state.positions + new_v * self.dt,
            velocities=new_v,
            goals=goals,
            origins=origins,
            emotions=self.emotions_at(substep),
            substep=substep,
            targets=targets,
            backwards=backwards,
            waits=waits,
            walked=walked,
        )

    def static_discs(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """The static discs in place at time `t` [s]: centres (S', 2) [m], radii (S',) [m]."""
        if self._all_static_present:
            return self.static_centers, self.static_radii
        here = discs_in_place(self.static_appear_times, t)
        return self.static_centers[here], self.static_radii[here]

    def snapshot(self, state: CrowdState) -> CrowdSnapshot:
        """What sensors and planners may know of the crowd in `state`."""
        centers, radii = self.static_discs(state.substep * self.dt)
        return CrowdSnapshot(
            positions=state.positions,
            velocities=state.velocities,
            radius=self.radius,
            emotions=state.emotions,
            discomfort=self.emotion_distances[state.emotions],
            static_centers=centers,
            static_radii=radii,
            static_discomfort=self.static_discomfort,
            wall_segments=self.wall_segments,
            gait_phase=gait_phase(_walked(state), self._gait_offsets),
            facing=facing_headings(
                state.velocities, start_to_goal_headings(state.positions, state.goals)
            ),
            time=state.substep * self.dt,
            seed=self.seed,
        )


def with_wall_discs(snapshot: CrowdSnapshot) -> CrowdSnapshot:
    """The snapshot with every wall added to the static discs as a chain of small discs
    (`scenarios/walls.py::wall_discs`): what the planners that read discs (DWA, MPC, SARL, RGL)
    are given. Scans, rewards and collisions use the exact segments. Without walls, the
    snapshot itself."""
    if len(snapshot.wall_segments) == 0:
        return snapshot
    centers, radii = wall_discs(snapshot.wall_segments)
    return dc.replace(
        snapshot,
        static_centers=np.vstack([snapshot.static_centers.reshape(-1, 2), centers]),
        static_radii=np.concatenate([snapshot.static_radii, radii]),
    )


def _walked(state: CrowdState) -> np.ndarray:
    """Each pedestrian's walked distance [m] (a state saved before the odometer: 0)."""
    return np.zeros(len(state.positions)) if state.walked is None else state.walked


def _route_progress(state: CrowdState) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Copies of the state's route progress (a state saved before routes: the start's)."""
    p = len(state.positions)
    if state.targets is None:
        return np.ones(p, dtype=np.int64), np.zeros(p, dtype=bool), np.zeros(p, dtype=np.int64)
    return state.targets.copy(), state.backwards.copy(), state.waits.copy()


def obstacle_discs(snapshot: CrowdSnapshot) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """All discs as (centres (n, 2), radii (n,), discomfort margins (n,)): pedestrians first."""
    p = len(snapshot.positions)
    centers = np.vstack([snapshot.positions, snapshot.static_centers]).reshape(-1, 2)
    radii = np.concatenate([np.full(p, snapshot.radius), snapshot.static_radii])
    margins = np.concatenate(
        [snapshot.discomfort, np.full(len(snapshot.static_radii), snapshot.static_discomfort)]
    )
    return centers, radii, margins
