"""ORCA's neighbour selection and ORCA lines, vectorised with numpy (`crowd/orca.py`).

For every active agent, `neighbour_table` selects and orders what it takes into account,
with RVO2's rules: the other visible agents whose centre distance is strictly below
``neighbor_dist``, at most ``max_neighbors`` nearest (ties by index), and the static discs
whose surface is closer than ``time_horizon_obst · max_speed + radius``, sorted by that
surface distance; obstacle pairs come first. `orca_lines` then builds the ORCA line of
every (agent, other) pair at once: the truncated velocity obstacle's closest boundary point
(cut-off circle or leg) gives the correction u, taken half by each agent (agents, horizon
``time_horizon``) or fully (static discs: zero velocity, horizon ``time_horizon_obst``);
overlapping pairs use the cut-off circle of the time step ``dt``.

Frame and units: the world frame; positions and radii in m, velocities in m/s, times in s.
Lines are `orca_lp.Line` tuples ``(direction_x, direction_y, point_x, point_y)``, the
permitted half-plane to the left of the unit direction.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from emonav_drake.crowd.orca_lp import Line


class OrcaSettings(Protocol):
    """The neighbourhood and horizon settings read here (`orca.OrcaParams` has them)."""

    @property
    def neighbor_dist(self) -> float: ...  # m

    @property
    def max_neighbors(self) -> int: ...

    @property
    def time_horizon(self) -> float: ...  # s

    @property
    def time_horizon_obst(self) -> float: ...  # s


@dataclass(frozen=True)
class NeighbourTable:
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


def neighbour_table(
    agents: np.ndarray,
    pos: np.ndarray,
    rad: np.ndarray,
    vmax: np.ndarray,
    obs_c: np.ndarray,
    obs_r: np.ndarray,
    vis: np.ndarray,
    params: OrcaSettings,
) -> NeighbourTable:
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
    return NeighbourTable(
        pair_agent=np.broadcast_to(agents[:, None], keep.shape)[keep],
        pair_other=others[keep],
        offsets=offsets.tolist(),
        n_obstacle_lines=obst_valid.sum(axis=1).tolist(),
        n_agents=n,
    )


# ---------------------------------------------------------------------------------------------
# ORCA lines (vectorised over all pairs)
# ---------------------------------------------------------------------------------------------


def orca_lines(
    table: NeighbourTable,
    pos: np.ndarray,
    vel: np.ndarray,
    rad: np.ndarray,
    obs_c: np.ndarray,
    obs_r: np.ndarray,
    dt: float,
    params: OrcaSettings,
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
