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
All ORCA lines (for every agent and every neighbour / obstacle it considers) are built at
once with vectorised numpy. The per-agent linear programs are then solved in plain Python
on Python floats, which is much faster than numpy for such tiny problems. A line is stored
as a tuple ``(direction_x, direction_y, point_x, point_y)``; the permitted half-plane is to
the left of the (unit) direction.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["OrcaParams", "orca_velocities"]

RVO_EPSILON = 1e-5
"""RVO2's tolerance for treating two ORCA lines as parallel."""

Line = tuple[float, float, float, float]
"""An ORCA line ``(direction_x, direction_y, point_x, point_y)``, world frame, m/s."""


@dataclass(frozen=True)
class OrcaParams:
    """Parameters shared by all agents.

    Attributes:
        neighbor_dist: Only agents whose centres are closer than this (m) are neighbours.
        max_neighbors: At most this many nearest neighbours are taken into account.
        time_horizon: Time horizon (s) of the agent-agent velocity obstacles.
        time_horizon_obst: Time horizon (s) of the velocity obstacles of static discs.
    """

    neighbor_dist: float = 10.0
    max_neighbors: int = 10
    time_horizon: float = 5.0
    time_horizon_obst: float = 5.0

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
            pass ``False``: then every array argument must be given, as the right type.

    Returns:
        ``(n, 2)`` new velocities, world frame, m/s. Active agents' speeds never exceed
        their ``max_speeds``.

    Raises:
        ValueError: on wrongly shaped, non-finite or out-of-range input.
    """
    if not check_inputs:
        pos, vel, rad, pref, vmax = (positions, velocities, radii, pref_velocities, max_speeds)
        obs_c, obs_r, vis, act = obstacle_centers, obstacle_radii, visible, active
    else:
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

    table = _neighbour_table(agents, pos, rad, vmax, obs_c, obs_r, vis, params)
    lines = _orca_lines(table, pos, vel, rad, obs_c, obs_r, dt, params)
    solved = _solve_linear_programs(agents, table, lines, pref, vmax)
    new_velocities[agents] = solved
    return new_velocities


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


# ---------------------------------------------------------------------------------------------
# Neighbour selection (vectorised)
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class _NeighbourTable:
    """Flattened, ordered list of (agent, other) pairs for all active agents.

    ``other`` indexes the concatenation [agents, obstacles]: values ``>= n_agents`` are static
    discs. Pairs of one agent are contiguous, obstacles first (by surface distance), then
    agents (by centre distance). ``offsets[k]:offsets[k + 1]`` are the pairs of the k-th
    active agent, of which the first ``n_obstacle_lines[k]`` are obstacle pairs.
    """

    pair_agent: np.ndarray
    pair_other: np.ndarray
    offsets: list[int]
    n_obstacle_lines: list[int]
    n_agents: int


def _nearest_first(distances: np.ndarray, valid: np.ndarray, keep: int) -> tuple:
    """Per row, the column indices of the valid entries sorted by distance (ties by index).

    Returns ``(order, valid_sorted)``, both of shape ``(rows, min(keep, cols))``; the valid
    entries of each row form a prefix.
    """
    key = np.where(valid, distances, np.inf)
    order = np.argsort(key, axis=1, kind="stable")[:, :keep]
    return order, np.take_along_axis(valid, order, axis=1)


def _neighbour_table(
    agents: np.ndarray,
    pos: np.ndarray,
    rad: np.ndarray,
    vmax: np.ndarray,
    obs_c: np.ndarray,
    obs_r: np.ndarray,
    vis: np.ndarray,
    params: OrcaParams,
) -> _NeighbourTable:
    """Select and order the neighbours (agents and static discs) of every active agent."""
    n = pos.shape[0]
    rows = np.arange(agents.size)
    px = pos[:, 0]
    py = pos[:, 1]
    ax = px[agents, None]
    ay = py[agents, None]

    # Agents: centre distance strictly below neighbor_dist, visible, not itself.
    dx = px[None, :] - ax
    dy = py[None, :] - ay
    dist_sq = dx * dx + dy * dy
    valid = vis[agents] & (dist_sq < params.neighbor_dist * params.neighbor_dist)
    valid[rows, agents] = False
    agent_order, agent_valid = _nearest_first(dist_sq, valid, params.max_neighbors)

    # Static discs: surface closer than time_horizon_obst * max_speed + radius (RVO2 range).
    odx = obs_c[None, :, 0] - ax
    ody = obs_c[None, :, 1] - ay
    surface = np.maximum(np.sqrt(odx * odx + ody * ody) - obs_r[None, :], 0.0)
    obst_range = params.time_horizon_obst * vmax[agents] + rad[agents]
    obst_valid = surface < obst_range[:, None]
    obst_order, obst_valid = _nearest_first(surface, obst_valid, obs_r.size)

    others = np.concatenate([obst_order + n, agent_order], axis=1)
    keep = np.concatenate([obst_valid, agent_valid], axis=1)
    counts = keep.sum(axis=1)
    offsets = np.zeros(agents.size + 1, dtype=np.intp)
    np.cumsum(counts, out=offsets[1:])
    return _NeighbourTable(
        pair_agent=np.broadcast_to(agents[:, None], keep.shape)[keep],
        pair_other=others[keep],
        offsets=offsets.tolist(),
        n_obstacle_lines=obst_valid.sum(axis=1).tolist(),
        n_agents=n,
    )


# ---------------------------------------------------------------------------------------------
# ORCA lines (vectorised over all pairs)
# ---------------------------------------------------------------------------------------------


def _orca_lines(
    table: _NeighbourTable,
    pos: np.ndarray,
    vel: np.ndarray,
    rad: np.ndarray,
    obs_c: np.ndarray,
    obs_r: np.ndarray,
    dt: float,
    params: OrcaParams,
) -> list[Line]:
    """Build the ORCA line of every (agent, other) pair of the table, in table order.

    Static discs are handled as agents with zero velocity, horizon ``time_horizon_obst`` and
    full responsibility; agents with horizon ``time_horizon`` and half responsibility.
    """
    a = table.pair_agent
    o = table.pair_other
    is_obstacle = o >= table.n_agents
    all_pos = np.concatenate([pos, obs_c])
    all_vel = np.concatenate([vel, np.zeros_like(obs_c)])
    all_rad = np.concatenate([rad, obs_r])

    # Relative position (other - self) and relative velocity (self - other).
    rpx = all_pos[o, 0] - pos[a, 0]
    rpy = all_pos[o, 1] - pos[a, 1]
    rvx = vel[a, 0] - all_vel[o, 0]
    rvy = vel[a, 1] - all_vel[o, 1]
    dist_sq = rpx * rpx + rpy * rpy
    comb_rad = rad[a] + all_rad[o]
    comb_rad_sq = comb_rad * comb_rad
    inv_horizon = np.where(is_obstacle, 1.0 / params.time_horizon_obst, 1.0 / params.time_horizon)
    responsibility = np.where(is_obstacle, 1.0, 0.5)
    colliding = dist_sq <= comb_rad_sq

    # Vector from the cut-off centre to the relative velocity; when already overlapping the
    # cut-off circle is the one of the time step (RVO2's invTimeStep branch).
    inv_cutoff = np.where(colliding, 1.0 / dt, inv_horizon)
    wx = rvx - inv_cutoff * rpx
    wy = rvy - inv_cutoff * rpy
    w_len_sq = wx * wx + wy * wy
    dot1 = wx * rpx + wy * rpy
    on_circle = colliding | ((dot1 < 0.0) & (dot1 * dot1 > comb_rad_sq * w_len_sq))

    cdx, cdy, cux, cuy = _cutoff_circle_projection(
        wx, wy, w_len_sq, rpx, rpy, comb_rad, inv_cutoff, a < o
    )
    ldx, ldy, lux, luy = _leg_projection(wx, wy, rpx, rpy, rvx, rvy, dist_sq, comb_rad)

    dir_x = np.where(on_circle, cdx, ldx)
    dir_y = np.where(on_circle, cdy, ldy)
    point_x = vel[a, 0] + responsibility * np.where(on_circle, cux, lux)
    point_y = vel[a, 1] + responsibility * np.where(on_circle, cuy, luy)
    return list(
        zip(dir_x.tolist(), dir_y.tolist(), point_x.tolist(), point_y.tolist(), strict=True)
    )


def _cutoff_circle_projection(
    wx: np.ndarray,
    wy: np.ndarray,
    w_len_sq: np.ndarray,
    rpx: np.ndarray,
    rpy: np.ndarray,
    comb_rad: np.ndarray,
    inv_cutoff: np.ndarray,
    self_first: np.ndarray,
) -> tuple:
    """Line direction and correction ``u`` when projecting on the cut-off circle.

    ``w`` is the vector from the cut-off centre to the relative velocity. In the degenerate
    case ``w == 0`` (only reachable when overlapping) the unit vector pointing away from the
    other is used; if the centres coincide too, ``+x`` for the lower index and ``-x`` for the
    higher one.
    """
    w_len = np.sqrt(w_len_sq)
    degenerate = w_len == 0.0
    w_len_safe = np.where(degenerate, 1.0, w_len)
    ux = wx / w_len_safe
    uy = wy / w_len_safe
    if np.any(degenerate):
        ux, uy = _degenerate_unit(ux, uy, degenerate, rpx, rpy, self_first)
    scale = comb_rad * inv_cutoff - w_len
    return uy, -ux, scale * ux, scale * uy


def _degenerate_unit(
    ux: np.ndarray,
    uy: np.ndarray,
    degenerate: np.ndarray,
    rpx: np.ndarray,
    rpy: np.ndarray,
    self_first: np.ndarray,
) -> tuple:
    """Replace the undefined unit vector of ``w == 0`` pairs (see _cutoff_circle_projection)."""
    ux = ux.copy()
    uy = uy.copy()
    for k in np.flatnonzero(degenerate).tolist():
        x, y = _fallback_unit(rpx[k].item(), rpy[k].item(), bool(self_first[k]))
        ux[k] = x
        uy[k] = y
    return ux, uy


def _fallback_unit(rpx: float, rpy: float, self_first: bool) -> tuple[float, float]:
    """Unit vector pointing away from the other (``-rp``), or ``+-x`` if the centres coincide."""
    dist = math.sqrt(rpx * rpx + rpy * rpy)
    if dist > 0.0:
        return -rpx / dist, -rpy / dist
    return (1.0, 0.0) if self_first else (-1.0, 0.0)


def _leg_projection(
    wx: np.ndarray,
    wy: np.ndarray,
    rpx: np.ndarray,
    rpy: np.ndarray,
    rvx: np.ndarray,
    rvy: np.ndarray,
    dist_sq: np.ndarray,
    comb_rad: np.ndarray,
) -> tuple:
    """Line direction and correction ``u`` when projecting on the left or right leg.

    Only meaningful for non-overlapping pairs; other entries are finite garbage.
    """
    dist_sq_safe = np.where(dist_sq > 0.0, dist_sq, 1.0)
    leg = np.sqrt(np.maximum(dist_sq - comb_rad * comb_rad, 0.0))
    left = rpx * wy - rpy * wx > 0.0
    left_x = (rpx * leg - rpy * comb_rad) / dist_sq_safe
    left_y = (rpx * comb_rad + rpy * leg) / dist_sq_safe
    right_x = -((rpx * leg + rpy * comb_rad) / dist_sq_safe)
    right_y = -((-rpx * comb_rad + rpy * leg) / dist_sq_safe)
    dir_x = np.where(left, left_x, right_x)
    dir_y = np.where(left, left_y, right_y)
    dot2 = rvx * dir_x + rvy * dir_y
    return dir_x, dir_y, dot2 * dir_x - rvx, dot2 * dir_y - rvy


# ---------------------------------------------------------------------------------------------
# Linear programs (pure Python on floats, RVO2's linearProgram1/2/3)
# ---------------------------------------------------------------------------------------------


def _solve_linear_programs(
    agents: np.ndarray,
    table: _NeighbourTable,
    lines: list[Line],
    pref: np.ndarray,
    vmax: np.ndarray,
) -> list[tuple[float, float]]:
    """Run LP2 (and the LP3 fallback) for every active agent; return the new velocities."""
    pref_list = pref[agents].tolist()
    vmax_list = vmax[agents].tolist()
    offsets = table.offsets
    results = []
    for k, ((opt_x, opt_y), radius) in enumerate(zip(pref_list, vmax_list, strict=True)):
        agent_lines = lines[offsets[k] : offsets[k + 1]]
        fail, rx, ry = _linear_program2(agent_lines, radius, opt_x, opt_y, False)
        if fail < len(agent_lines):
            rx, ry = _linear_program3(agent_lines, table.n_obstacle_lines[k], fail, radius, rx, ry)
        results.append(_clamp_speed(rx, ry, radius))
    return results


def _clamp_speed(vx: float, vy: float, max_speed: float) -> tuple[float, float]:
    """Scale ``(vx, vy)`` down to ``max_speed`` if rounding pushed it marginally above."""
    speed_sq = vx * vx + vy * vy
    if speed_sq > max_speed * max_speed:
        scale = max_speed / math.sqrt(speed_sq)
        return vx * scale, vy * scale
    return vx, vy


def _linear_program1(
    lines: list[Line],
    line_no: int,
    radius: float,
    opt_x: float,
    opt_y: float,
    direction_opt: bool,
) -> tuple[float, float] | None:
    """Optimise on line ``line_no`` subject to lines ``0..line_no-1`` and the speed circle.

    Returns the optimum on the line, or ``None`` if that line segment is empty.
    """
    ldx, ldy, lpx, lpy = lines[line_no]
    dot = lpx * ldx + lpy * ldy
    discriminant = dot * dot + radius * radius - (lpx * lpx + lpy * lpy)
    if discriminant < 0.0:
        return None  # the speed circle fully invalidates this line
    sqrt_disc = math.sqrt(discriminant)
    t_left = -dot - sqrt_disc
    t_right = -dot + sqrt_disc
    for i in range(line_no):
        idx, idy, ipx, ipy = lines[i]
        denominator = ldx * idy - ldy * idx
        numerator = idx * (lpy - ipy) - idy * (lpx - ipx)
        if abs(denominator) <= RVO_EPSILON:
            if numerator < 0.0:
                return None  # (almost) parallel and on the forbidden side
            continue
        t = numerator / denominator
        if denominator >= 0.0:
            if t < t_right:
                t_right = t  # line i bounds this line on the right
        elif t > t_left:
            t_left = t  # line i bounds this line on the left
        if t_left > t_right:
            return None
    if direction_opt:
        t = t_right if opt_x * ldx + opt_y * ldy > 0.0 else t_left
    else:
        t = ldx * (opt_x - lpx) + ldy * (opt_y - lpy)
        if t < t_left:
            t = t_left
        elif t > t_right:
            t = t_right
    return lpx + t * ldx, lpy + t * ldy


def _linear_program2(
    lines: list[Line],
    radius: float,
    opt_x: float,
    opt_y: float,
    direction_opt: bool,
) -> tuple[int, float, float]:
    """Incremental 2-D LP inside the speed circle of ``radius``.

    With ``direction_opt`` the (unit) ``opt`` is a direction to go furthest in; otherwise the
    point closest to ``opt`` is sought. Returns ``(fail, x, y)``: ``fail == len(lines)`` on
    success, else the index of the first line that could not be satisfied, with ``(x, y)``
    the result before that line.
    """
    if direction_opt:
        rx = opt_x * radius
        ry = opt_y * radius
    elif opt_x * opt_x + opt_y * opt_y > radius * radius:
        norm = math.sqrt(opt_x * opt_x + opt_y * opt_y)
        rx = opt_x / norm * radius
        ry = opt_y / norm * radius
    else:
        rx = opt_x
        ry = opt_y
    for i, (ldx, ldy, lpx, lpy) in enumerate(lines):
        if ldx * (lpy - ry) - ldy * (lpx - rx) > 0.0:  # result violates line i
            optimum = _linear_program1(lines, i, radius, opt_x, opt_y, direction_opt)
            if optimum is None:
                return i, rx, ry
            rx, ry = optimum
    return len(lines), rx, ry


def _linear_program3(
    lines: list[Line],
    n_obstacle_lines: int,
    begin_line: int,
    radius: float,
    rx: float,
    ry: float,
) -> tuple[float, float]:
    """Fallback when LP2 fails: minimise the largest violation of the agent lines.

    The first ``n_obstacle_lines`` lines (obstacles) stay hard constraints. ``(rx, ry)`` is
    LP2's partial result, ``begin_line`` the line where LP2 failed.
    """
    distance = 0.0
    for i in range(begin_line, len(lines)):
        idx, idy, ipx, ipy = lines[i]
        if idx * (ipy - ry) - idy * (ipx - rx) <= distance:
            continue
        projected = lines[:n_obstacle_lines]
        for j in range(n_obstacle_lines, i):
            jdx, jdy, jpx, jpy = lines[j]
            determinant = idx * jdy - idy * jdx
            if abs(determinant) <= RVO_EPSILON:
                if idx * jdx + idy * jdy > 0.0:
                    continue  # parallel, same direction
                px = 0.5 * (ipx + jpx)
                py = 0.5 * (ipy + jpy)
            else:
                s = (jdx * (ipy - jpy) - jdy * (ipx - jpx)) / determinant
                px = ipx + s * idx
                py = ipy + s * idy
            ddx = jdx - idx
            ddy = jdy - idy
            norm = math.sqrt(ddx * ddx + ddy * ddy)
            projected.append((ddx / norm, ddy / norm, px, py))
        fail, nx, ny = _linear_program2(projected, radius, -idy, idx, True)
        if fail == len(projected):
            rx, ry = nx, ny  # else keep the previous result (floating-point trouble)
        distance = idx * (ipy - ry) - idy * (ipx - rx)
    return rx, ry
