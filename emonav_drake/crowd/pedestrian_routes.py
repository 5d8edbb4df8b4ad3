"""What a pedestrian wants to do next: routes, standing and groups, for the crowd's ORCA step.

The paper's pedestrian walks start → goal → start … at the crowd's preferred speed; the
crowd (`crowd/crowd.py`) computes its preferred velocity with vectorised numpy, and this
module leaves it alone (a *plain* pedestrian). The scenario families need more, given per
pedestrian in `scenarios/scenario_spec.py::PedestrianSpec`:

* a **route** start → waypoints → goal, walked back in reverse at the goal (a waypoint on
  the way counts as passed within `WAYPOINT_TOLERANCE`, the route's ends within the
  crowd's goal tolerance);
* **standing**: for good at the goal (`at_goal: stand`), for `stand_time` at each end of
  the route, and for `start_delay` before walking at all (a standing pedestrian's
  preferred velocity is zero; ORCA may still nudge it aside);
* a **group**: the first listed member leads, every other member (a *follower*) heads for
  its slot, the leader's position plus the follower's start offset from the leader's start
  (world frame, the formation translates with the leader), at the leader's velocity plus a
  correction of `FORMATION_GAIN` × (slot − position), no faster than `FOLLOWER_SPEEDUP` × its
  own speed.

`RoutePlan` holds what does not change in an episode; the changing part lives in the
crowd's state (`targets`, `backwards`, `waits`). Times are counted in crowd periods `dt`.
World frame, metres, seconds, m/s.
"""

from __future__ import annotations

import dataclasses as dc
import math

import numpy as np

FORMATION_GAIN = 1.0  # [1/s]: a follower 0.5 m off its slot walks 0.5 m/s faster towards it
FOLLOWER_SPEEDUP = 1.5  # a follower may walk this much faster than its speed to keep up
WAYPOINT_TOLERANCE = 0.5  # [m]: a waypoint on the way counts as passed this close
WAIT_FOREVER = -1  # `waits` value of a pedestrian that stands for good


@dc.dataclass(frozen=True)
class RoutePlan:
    """The fixed part of every pedestrian's behaviour (P pedestrians).

    Attributes:
        routes: per pedestrian, (K, 2) points start, waypoints…, goal [m] (K ≥ 2).
        speeds: (P,) preferred speed [m/s].
        max_speeds: (P,) ORCA maximum speed [m/s] (a follower's is larger than its speed).
        stand_at_goal: (P,) bool, stands for good at its goal.
        stand_substeps: (P,) int, periods standing at each end of the route.
        delay_substeps: (P,) int, periods standing at the start.
        leaders: (P,) int, index of the pedestrian's group leader; −1 if it leads or walks alone.
        offsets: (P, 2) a follower's slot relative to its leader [m].
        plain: (P,) bool, the paper's pedestrian (start ↔ goal, no standing, no group).
    """

    routes: tuple[np.ndarray, ...]
    speeds: np.ndarray
    max_speeds: np.ndarray
    stand_at_goal: np.ndarray
    stand_substeps: np.ndarray
    delay_substeps: np.ndarray
    leaders: np.ndarray
    offsets: np.ndarray
    plain: np.ndarray

    @classmethod
    def from_specs(cls, pedestrians: list, default_speed: float, dt: float) -> RoutePlan:
        """The plan of `scenarios/scenario_spec.py::PedestrianSpec`s; `default_speed` [m/s] for a
        pedestrian without a speed, `dt` [s] the crowd's period."""
        p = len(pedestrians)
        routes = tuple(
            np.array([s.start, *s.waypoints, s.goal], dtype=float).reshape(-1, 2)
            for s in pedestrians
        )
        speeds = np.array(
            [default_speed if s.speed is None else float(s.speed) for s in pedestrians], dtype=float
        )
        leaders = np.full(p, -1, dtype=np.int64)
        offsets = np.zeros((p, 2))
        first_of_group: dict[int, int] = {}
        for i, s in enumerate(pedestrians):
            if s.group < 0:
                continue
            lead = first_of_group.setdefault(s.group, i)
            if lead != i:
                leaders[i] = lead
                offsets[i] = np.subtract(s.start, pedestrians[lead].start)
        followers = leaders >= 0
        max_speeds = np.where(followers, FOLLOWER_SPEEDUP * speeds, speeds)

        def periods(seconds: float) -> int:
            return int(round(seconds / dt))

        stand_at_goal = np.array([s.at_goal == "stand" for s in pedestrians], dtype=bool)
        stand_substeps = np.array([periods(s.stand_time) for s in pedestrians], dtype=np.int64)
        delay_substeps = np.array([periods(s.start_delay) for s in pedestrians], dtype=np.int64)
        has_waypoints = np.array([len(s.waypoints) > 0 for s in pedestrians], dtype=bool)
        plain = ~(
            followers | stand_at_goal | (stand_substeps > 0) | (delay_substeps > 0) | has_waypoints
        )
        return cls(
            routes=routes,
            speeds=speeds,
            max_speeds=max_speeds,
            stand_at_goal=stand_at_goal,
            stand_substeps=stand_substeps,
            delay_substeps=delay_substeps,
            leaders=leaders,
            offsets=offsets,
            plain=plain,
        )

    def same_group(self) -> np.ndarray:
        """(P, P) bool: pedestrians i and j walk in the same group (i ≠ j)."""
        head = np.where(self.leaders >= 0, self.leaders, np.arange(len(self.leaders)))
        led = np.isin(np.arange(len(head)), self.leaders) | (self.leaders >= 0)
        same = (head[:, None] == head[None, :]) & led[:, None] & led[None, :]
        np.fill_diagonal(same, False)
        return same

    def first_targets(self) -> np.ndarray:
        """(P, 2) the first point each pedestrian heads for (its goal, or first waypoint)."""
        return np.array([r[1] for r in self.routes], dtype=float).reshape(-1, 2)

    def advance(
        self,
        positions: np.ndarray,
        goals: np.ndarray,
        origins: np.ndarray,
        targets: np.ndarray,
        backwards: np.ndarray,
        waits: np.ndarray,
        goal_tolerance: float,
    ) -> np.ndarray:
        """Move every non-plain leader or lone walker along its route, in place.

        Updates `goals` (the point it heads for), `origins` (the point it came from),
        `targets` (index of `goals` in its route), `backwards` and `waits` (periods left
        standing, `WAIT_FOREVER` for good) for one period; returns the (P,) bool mask of
        the pedestrians standing in this period.
        """
        standing = np.zeros(len(positions), dtype=bool)
        for i in np.flatnonzero(~self.plain & (self.leaders < 0)):
            end = targets[i] in (0, len(self.routes[i]) - 1)
            near = goal_tolerance if end else WAYPOINT_TOLERANCE  # corners are cut
            if waits[i] == 0 and math.dist(positions[i], goals[i]) < near:
                self._arrive(i, goals, origins, targets, backwards, waits)
            if waits[i] != 0:
                standing[i] = True
                if waits[i] > 0:
                    waits[i] -= 1
        return standing

    def _arrive(self, i, goals, origins, targets, backwards, waits) -> None:  # noqa: ANN001
        """Pedestrian `i` reached `goals[i]`: stand, turn round or head for the next point."""
        route, last = self.routes[i], len(self.routes[i]) - 1
        if not backwards[i] and targets[i] == last:
            if self.stand_at_goal[i]:
                waits[i] = WAIT_FOREVER
                return
            backwards[i] = True
            waits[i] = self.stand_substeps[i]
        elif backwards[i] and targets[i] == 0:
            backwards[i] = False
            waits[i] = self.stand_substeps[i]
        step = -1 if backwards[i] else 1
        origins[i] = route[targets[i]]
        targets[i] += step
        goals[i] = route[targets[i]]

    def follower_velocities(
        self, positions: np.ndarray, velocities: np.ndarray, pref: np.ndarray
    ) -> None:
        """Set each follower's preferred velocity in `pref` (in place): towards its slot
        beside the leader, no faster than its maximum speed (m/s, world frame)."""
        for i in np.flatnonzero(self.leaders >= 0):
            lead = self.leaders[i]
            slot = positions[lead] + self.offsets[i]
            v = velocities[lead] + FORMATION_GAIN * (slot - positions[i])
            speed = math.hypot(v[0], v[1])
            if speed > self.max_speeds[i]:
                v = v * (self.max_speeds[i] / speed)
            pref[i] = v
