"""Optimal Reciprocal Collision Avoidance (ORCA) for pedestrians, numpy only.

This module reproduces the velocity computation of the RVO2 library (van den Berg, Guy,
Lin and Manocha, "Reciprocal n-body collision avoidance", 2011; RVO2
``Agent::computeNewVelocity``) for a crowd of disc-shaped agents plus static discs.

Frame and units
---------------
Everything is expressed in the planar **world frame**: positions and radii in metres,
velocities and speeds in m/s, time steps and time horizons in seconds.

Semantics (RVO2's)
------------------
* **Synchronous update.** Every agent's new velocity is computed from the same old state
  (positions and current velocities). This module only returns velocities; the caller
  integrates the positions (e.g. ``p += v_new * dt``).
* **Neighbours.** Agent ``i`` considers the other agents ``j`` with ``visible[i, j]`` whose
  centre distance is strictly below ``neighbor_dist``; the ``max_neighbors`` nearest are
  kept (ties broken by index) and their ORCA lines are added in order of increasing
  distance.
* **Agent-agent ORCA line.** The truncated velocity obstacle with time horizon
  ``time_horizon``; the relative velocity is projected on the closest point of its boundary
  (cut-off circle or one of the two legs) giving the correction ``u``, and each agent takes
  half the responsibility: the line passes through ``v_i + u / 2``. If two agents already
  overlap, the cut-off circle of the time step ``dt`` is used instead (RVO2's
  ``invTimeStep`` branch), i.e. the pair is asked to separate within one step.
* **Static discs (obstacles).** A disc is treated as a non-moving agent (velocity 0) with
  horizon ``time_horizon_obst`` and full responsibility (the line passes through
  ``v_i + u``). As in RVO2, agent ``i`` only considers obstacles whose surface is closer than
  ``time_horizon_obst * max_speed_i + radius_i``, sorted by that surface distance. Obstacle
  lines come first in the line list.
* **Line segments (walls).** ``obstacle_segments`` are RVO2's two-vertex obstacles: a
  segment blocked on both sides, with RVO2's range rule, order, "already covered" test,
  legs, foreign legs and collision lines (`crowd/orca_walls.py`), horizon
  ``time_horizon_obst`` and full responsibility. An agent's segment lines come first, then
  its static-disc lines, then its agent lines; segment and disc lines are all obstacle
  lines (hard in ``linearProgram3``). Without segments the computation is exactly the one
  without this option.
* **Linear program.** RVO2's incremental 2-D linear program (``linearProgram1/2``) finds the
  velocity closest to the preferred velocity inside the disc of radius ``max_speed`` that
  satisfies all ORCA half-planes. If it is infeasible, ``linearProgram3`` minimises the
  largest violation of the agent lines while keeping the obstacle lines hard. RVO2's
  epsilon ``1e-5`` is used for parallel-line tests.
* **Visibility / activity.** ``visible[i, j]`` says whether agent ``i`` takes agent ``j``
  into account. Inactive agents (e.g. a robot driven by its own planner) get their given
  velocity back unchanged but still appear as neighbours of the active agents.

Implementation
--------------
This module holds the public API (`OrcaParams`, `orca_velocities`) and the input checks.
All ORCA lines (for every agent and every neighbour / obstacle it considers) are built at
once with vectorised numpy (`crowd/orca_lines.py`: neighbour selection and lines). The
per-agent linear programs are then solved in plain Python on Python floats, which is much
faster than numpy for such tiny problems (`crowd/orca_lp.py`: RVO2's ``linearProgram1/2/3``).
A line is stored as a tuple ``(direction_x, direction_y, point_x, point_y)``; the
permitted half-plane is to the left of the (unit) direction.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from emonav_drake.config_fields import setting
from emonav_drake.crowd.orca_lines import neighbour_table, orca_lines
from emonav_drake.crowd.orca_lp import Line, solve_linear_programs
from emonav_drake.crowd.orca_walls import segment_lines

__all__ = ["OrcaParams", "orca_velocities"]


@dataclass(frozen=True)
class OrcaParams:
    """Parameters shared by all agents.

    Attributes:
        neighbor_dist: Only agents whose centres are closer than this (m) are neighbours.
        max_neighbors: At most this many nearest neighbours are taken into account.
        time_horizon: Time horizon (s) of the agent-agent velocity obstacles.
        time_horizon_obst: Time horizon (s) of the velocity obstacles of static discs.
    """

    neighbor_dist: float = setting(
        10.0,
        "Only agents whose centres are closer than this (m) are neighbours",
        "m",
    )
    max_neighbors: int = setting(10, "At most this many nearest neighbours are taken into account")
    time_horizon: float = setting(
        5.0, "Time horizon (s) of the agent-agent velocity obstacles", "s"
    )
    time_horizon_obst: float = setting(
        5.0,
        "Time horizon (s) of the velocity obstacles of static discs",
        "s",
    )

    def __post_init__(self) -> None:
        if not (math.isfinite(self.neighbor_dist) and self.neighbor_dist >= 0.0):
            raise ValueError(f"neighbor_dist must be finite and >= 0, got {self.neighbor_dist}")
        if isinstance(self.max_neighbors, bool) or not isinstance(
            self.max_neighbors, int | np.integer
        ):
            raise ValueError(f"max_neighbors must be an int, got {self.max_neighbors!r}")
        if self.max_neighbors < 0:
            raise ValueError(f"max_neighbors must be >= 0, got {self.max_neighbors}")
        for name in ("time_horizon", "time_horizon_obst"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0.0):
                raise ValueError(f"{name} must be finite and > 0, got {value}")


def orca_velocities(
    positions: np.ndarray,
    velocities: np.ndarray,
    radii: np.ndarray,
    pref_velocities: np.ndarray,
    max_speeds: np.ndarray,
    dt: float,
    params: OrcaParams = OrcaParams(),  # noqa: B008 - frozen, immutable default
    obstacle_centers: np.ndarray | None = None,
    obstacle_radii: np.ndarray | None = None,
    visible: np.ndarray | None = None,
    active: np.ndarray | None = None,
    check_inputs: bool = True,
    obstacle_segments: np.ndarray | None = None,
) -> np.ndarray:
    """Compute the ORCA velocities of ``n`` agents for one synchronous step.

    Args:
        positions: ``(n, 2)`` agent centres, world frame, m.
        velocities: ``(n, 2)`` current agent velocities, world frame, m/s.
        radii: ``(n,)`` ORCA radii, m (the caller adds any safety margin).
        pref_velocities: ``(n, 2)`` preferred velocities, world frame, m/s.
        max_speeds: ``(n,)`` maximum speeds, m/s.
        dt: Simulation time step, s (used when two agents already overlap).
        params: Neighbourhood and time-horizon parameters.
        obstacle_centers: ``(m, 2)`` centres of static discs, world frame, m (or ``None``).
        obstacle_radii: ``(m,)`` radii of the static discs, m (or ``None``).
        visible: ``(n, n)`` bool; ``visible[i, j]`` is whether agent ``i`` takes agent ``j``
            into account. Default: all ``True`` (the diagonal is always ignored).
        active: ``(n,)`` bool; velocities are only computed for active agents, inactive
            ones get their given velocity back unchanged. Default: all ``True``.
        check_inputs: validate shapes, finiteness and ranges (default). Callers that
            build well-formed float64/bool arrays themselves every step (the crowd) may
            pass ``False``: then every array argument must be given, as the right type
            (``obstacle_segments`` may still be ``None``).
        obstacle_segments: ``(W, 2, 2)`` line segments (walls), world frame, m: segment k
            runs from ``[k, 0]`` to ``[k, 1]``, each of non-zero length, blocked on both
            sides (RVO2's two-vertex obstacles). ``None`` or ``W == 0``: no walls.

    Returns:
        ``(n, 2)`` new velocities, world frame, m/s. Active agents' speeds never exceed
        their ``max_speeds``.

    Raises:
        ValueError: on wrongly shaped, non-finite or out-of-range input.
    """
    if not check_inputs:
        pos, vel, rad, pref, vmax = (positions, velocities, radii, pref_velocities, max_speeds)
        obs_c, obs_r, vis, act = obstacle_centers, obstacle_radii, visible, active
        segs = obstacle_segments
    else:
        segs = _validated_segments(obstacle_segments)
        (pos, vel, rad, pref, vmax, dt, obs_c, obs_r, vis, act) = _validated_inputs(
            positions,
            velocities,
            radii,
            pref_velocities,
            max_speeds,
            dt,
            params,
            obstacle_centers,
            obstacle_radii,
            visible,
            active,
        )
    new_velocities = vel.copy()
    agents = np.flatnonzero(act)
    if agents.size == 0:
        return new_velocities

    table = neighbour_table(agents, pos, rad, vmax, obs_c, obs_r, vis, params)
    lines = orca_lines(table, pos, vel, rad, obs_c, obs_r, dt, params)
    offsets, n_obstacle_lines = table.offsets, table.n_obstacle_lines
    if segs is not None and len(segs):
        walls = segment_lines(agents, pos, vel, rad, vmax, segs, params.time_horizon_obst)
        lines, offsets, n_obstacle_lines = _prepend(walls, lines, offsets, n_obstacle_lines)
    solved = solve_linear_programs(agents, lines, offsets, n_obstacle_lines, pref, vmax)
    new_velocities[agents] = solved
    return new_velocities


def _prepend(
    walls: list[list[Line]], lines: list[Line], offsets: list[int], n_obstacle_lines: list[int]
) -> tuple[list[Line], list[int], list[int]]:
    """Put each agent's segment lines before its other lines; they count as obstacle lines."""
    merged: list[Line] = []
    new_offsets = [0]
    for k, own in enumerate(walls):
        merged.extend(own)
        merged.extend(lines[offsets[k] : offsets[k + 1]])
        new_offsets.append(len(merged))
    counts = [n + len(own) for n, own in zip(n_obstacle_lines, walls, strict=True)]
    return merged, new_offsets, counts


# ---------------------------------------------------------------------------------------------
# Input validation
# ---------------------------------------------------------------------------------------------


def _float_array(name: str, value: object, shape: tuple[int, ...]) -> np.ndarray:
    """Return ``value`` as a finite float64 array of the given shape or raise ValueError."""
    try:
        array = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as error:
        raise ValueError(f"{name} must be a numeric array: {error}") from error
    if array.shape != shape:
        raise ValueError(f"{name} must have shape {shape}, got {array.shape}")
    if not np.all(np.isfinite(array)):
        raise ValueError(f"{name} must be finite (no NaN or inf)")
    return array


def _validated_segments(segments: object) -> np.ndarray | None:
    """``obstacle_segments`` as a finite float64 (W, 2, 2) array of non-zero-length
    segments, or None; ValueError otherwise."""
    if segments is None:
        return None
    segs = np.asarray(segments, dtype=np.float64)
    if segs.size == 0:
        return None
    if segs.ndim != 3 or segs.shape[1:] != (2, 2):
        raise ValueError(f"obstacle_segments must have shape (W, 2, 2), got {segs.shape}")
    segs = _float_array("obstacle_segments", segs, segs.shape)
    length = np.hypot(*(segs[:, 1] - segs[:, 0]).T)
    if np.any(length <= 0.0):
        k = int(np.argmin(length))
        raise ValueError(f"obstacle_segments[{k}] has zero length (both ends {segs[k, 0]})")
    return segs


def _bool_array(name: str, value: object, shape: tuple[int, ...]) -> np.ndarray:
    """Return ``value`` as a bool array of the given shape or raise ValueError."""
    array = np.asarray(value)
    if array.dtype != np.bool_:
        raise ValueError(f"{name} must be a bool array, got dtype {array.dtype}")
    if array.shape != shape:
        raise ValueError(f"{name} must have shape {shape}, got {array.shape}")
    return array


def _validated_inputs(
    positions: np.ndarray,
    velocities: np.ndarray,
    radii: np.ndarray,
    pref_velocities: np.ndarray,
    max_speeds: np.ndarray,
    dt: float,
    params: OrcaParams,
    obstacle_centers: np.ndarray | None,
    obstacle_radii: np.ndarray | None,
    visible: np.ndarray | None,
    active: np.ndarray | None,
) -> tuple:
    """Check shapes, finiteness and ranges; return float64 / bool arrays and defaults."""
    if not isinstance(params, OrcaParams):
        raise ValueError(f"params must be an OrcaParams, got {type(params).__name__}")
    pos = np.asarray(positions, dtype=np.float64)
    if pos.ndim != 2 or pos.shape[1] != 2:
        raise ValueError(f"positions must have shape (n, 2), got {pos.shape}")
    n = pos.shape[0]
    pos = _float_array("positions", pos, (n, 2))
    vel = _float_array("velocities", velocities, (n, 2))
    rad = _float_array("radii", radii, (n,))
    pref = _float_array("pref_velocities", pref_velocities, (n, 2))
    vmax = _float_array("max_speeds", max_speeds, (n,))
    if np.any(rad < 0.0):
        raise ValueError("radii must be >= 0")
    if np.any(vmax < 0.0):
        raise ValueError("max_speeds must be >= 0")
    try:
        dt = float(dt)
    except (TypeError, ValueError) as error:
        raise ValueError(f"dt must be a number: {error}") from error
    if not (math.isfinite(dt) and dt > 0.0):
        raise ValueError(f"dt must be finite and > 0, got {dt}")

    if (obstacle_centers is None) != (obstacle_radii is None):
        raise ValueError("obstacle_centers and obstacle_radii must be given together")
    if obstacle_centers is None:
        obs_c = np.zeros((0, 2))
        obs_r = np.zeros(0)
    else:
        obs_c = np.asarray(obstacle_centers, dtype=np.float64)
        if obs_c.ndim != 2 or obs_c.shape[1] != 2:
            raise ValueError(f"obstacle_centers must have shape (m, 2), got {obs_c.shape}")
        m = obs_c.shape[0]
        obs_c = _float_array("obstacle_centers", obs_c, (m, 2))
        obs_r = _float_array("obstacle_radii", obstacle_radii, (m,))
        if np.any(obs_r < 0.0):
            raise ValueError("obstacle_radii must be >= 0")

    if visible is None:
        vis = np.ones((n, n), dtype=bool)
    else:
        vis = _bool_array("visible", visible, (n, n))
    if active is None:
        act = np.ones(n, dtype=bool)
    else:
        act = _bool_array("active", active, (n,))
    return pos, vel, rad, pref, vmax, dt, obs_c, obs_r, vis, act
