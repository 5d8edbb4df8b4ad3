"""ORCA lines of line-segment obstacles (walls), with RVO2's semantics for two-vertex obstacles.

Used by `crowd/orca.py` (`orca_velocities(..., obstacle_segments=...)`). In RVO2 an obstacle
is a polygon given by its vertices; a polygon of two vertices A, B is a line segment both
of whose sides are blocked: RVO2 stores it as the two edges A → B and B → A, and an agent
looks at an edge only from its right-hand side, so it always deals with the one edge that
faces it. This module reproduces, for such two-vertex obstacles, what RVO2's
``Agent::computeNewVelocity`` does in its obstacle part (both vertices of a two-vertex
obstacle are convex):

* **Range and order.** Agent ``i`` considers a segment only if the distance from its
  centre to the segment is strictly below ``time_horizon_obst · max_speed_i + radius_i``;
  the segments are taken in order of increasing distance (ties by index).
* **Already covered.** A segment whose truncated velocity obstacle lies entirely on the
  forbidden side of an obstacle line built before (both end points, seen through the
  horizon and shifted by the agent's radius) adds no line.
* **Collision.** If the agent's disc already overlaps the segment, the line passes through
  the zero velocity: perpendicular to the direction to the touched end point, or parallel
  to the segment when the foot of the perpendicular lies on it (the agent is asked to move
  away at any speed).
* **Otherwise** the velocity obstacle is the segment swept by the agent's disc, cut off at
  the horizon ``time_horizon_obst``: two cut-off circles (one when the segment is seen
  end-on), the cut-off line between them and two legs. A leg that would point into the
  segment is replaced by the segment's own direction ("foreign" leg). The current velocity
  is projected on the nearest of these boundaries; the line passes through the projection
  and bounds the velocity on the free side. A projection on a foreign leg adds no line.

One deliberate difference: RVO2 ignores a segment when the agent's centre lies exactly on
the segment's supporting line (neither edge has the agent strictly on its right), which
lets an agent walking exactly along a wall's line walk into the wall's end. Here the edge
A → B is used in that case.

RVO2 splits edges that cross each other when it builds its obstacle tree; that changes how
a crossing is represented, not the blocked region, and is not reproduced (each segment is
handled on its own).

Frame and units: the world frame; positions, radii and segment end points in m,
velocities in m/s, times in s. Lines are `orca_lp.Line` tuples
``(direction_x, direction_y, point_x, point_y)`` with the permitted half-plane on the left
of the unit direction. Plain Python floats (the segments an agent considers are few).
"""

from __future__ import annotations

import math

import numpy as np

from emonav_drake.crowd.orca_lp import RVO_EPSILON, Line

__all__ = ["segment_lines"]


def segment_lines(
    agents: np.ndarray,
    pos: np.ndarray,
    vel: np.ndarray,
    rad: np.ndarray,
    vmax: np.ndarray,
    segments: np.ndarray,
    time_horizon_obst: float,
) -> list[list[Line]]:
    """The segment (wall) ORCA lines of every active agent, in RVO2's order.

    Args:
        agents: (n_active,) indices of the active agents.
        pos, vel: (n, 2) agent centres [m] and velocities [m/s], world frame.
        rad, vmax: (n,) ORCA radii [m] and maximum speeds [m/s].
        segments: (W, 2, 2) segment k from ``segments[k, 0]`` to ``segments[k, 1]`` [m],
            each of non-zero length.
        time_horizon_obst: horizon of the obstacle velocity obstacles [s].

    Returns:
        For the k-th active agent, the list of its segment lines (possibly empty).
    """
    inv_t = 1.0 / time_horizon_obst
    order, in_range = _segments_in_range(agents, pos, rad, vmax, segments, time_horizon_obst)
    seg = segments.tolist()
    out: list[list[Line]] = []
    for k, agent in enumerate(agents.tolist()):
        px, py = pos[agent].tolist()
        vx, vy = vel[agent].tolist()
        radius = float(rad[agent])
        lines: list[Line] = []
        for w in order[k, in_range[k]].tolist():
            (ax, ay), (bx, by) = seg[w]
            # RVO2 looks at the edge that has the agent on its right: A → B or B → A.
            if (ax - px) * (by - ay) - (ay - py) * (bx - ax) > 0.0:
                ax, ay, bx, by = bx, by, ax, ay
            line = _segment_line(px, py, vx, vy, radius, inv_t, ax, ay, bx, by, lines)
            if line is not None:
                lines.append(line)
        out.append(lines)
    return out


def _segments_in_range(
    agents: np.ndarray,
    pos: np.ndarray,
    rad: np.ndarray,
    vmax: np.ndarray,
    segments: np.ndarray,
    time_horizon_obst: float,
) -> tuple[np.ndarray, np.ndarray]:
    """Per active agent, the segment indices by increasing distance (ties by index) and
    whether each is within RVO2's obstacle range (a prefix of every row)."""
    a = segments[None, :, 0, :]  # (1, W, 2)
    e = segments[None, :, 1, :] - a
    p = pos[agents][:, None, :]  # (n_active, 1, 2)
    s = np.sum((p - a) * e, axis=-1) / np.sum(e * e, axis=-1)
    s = np.clip(s, 0.0, 1.0)
    foot = a + s[..., None] * e
    dist_sq = np.sum((p - foot) ** 2, axis=-1)
    reach = time_horizon_obst * vmax[agents] + rad[agents]
    valid = dist_sq < (reach * reach)[:, None]
    key = np.where(valid, dist_sq, np.inf)
    order = np.argsort(key, axis=1, kind="stable")
    return order, np.take_along_axis(valid, order, axis=1)


def _det(ax: float, ay: float, bx: float, by: float) -> float:
    return ax * by - ay * bx


def _unit(x: float, y: float) -> tuple[float, float]:
    norm = math.sqrt(x * x + y * y)
    return x / norm, y / norm


def _covered(
    r1x: float, r1y: float, r2x: float, r2y: float, radius: float, inv_t: float, lines: list[Line]
) -> bool:
    """RVO2's test: the segment's cut-off velocity obstacle lies behind an earlier line."""
    shift = inv_t * radius
    for dx, dy, lx, ly in lines:
        if (
            _det(inv_t * r1x - lx, inv_t * r1y - ly, dx, dy) - shift >= -RVO_EPSILON
            and _det(inv_t * r2x - lx, inv_t * r2y - ly, dx, dy) - shift >= -RVO_EPSILON
        ):
            return True
    return False


def _legs(rx: float, ry: float, dist_sq: float, radius: float) -> tuple[float, ...]:
    """Left and right leg directions (unit) of the disc of ``radius`` round the end point
    at ``(rx, ry)`` relative to the agent (``dist_sq`` = its squared distance)."""
    leg = math.sqrt(dist_sq - radius * radius)
    return (
        (rx * leg - ry * radius) / dist_sq,
        (rx * radius + ry * leg) / dist_sq,
        (rx * leg + ry * radius) / dist_sq,
        (-rx * radius + ry * leg) / dist_sq,
    )


def _segment_line(
    px: float,
    py: float,
    vx: float,
    vy: float,
    radius: float,
    inv_t: float,
    ax: float,
    ay: float,
    bx: float,
    by: float,
    lines: list[Line],
) -> Line | None:
    """The ORCA line of the edge A → B (agent on its right) or None (covered / foreign)."""
    r1x, r1y = ax - px, ay - py
    r2x, r2y = bx - px, by - py
    if _covered(r1x, r1y, r2x, r2y, radius, inv_t, lines):
        return None
    dist_sq1 = r1x * r1x + r1y * r1y
    dist_sq2 = r2x * r2x + r2y * r2y
    radius_sq = radius * radius
    ox, oy = bx - ax, by - ay
    s = (-r1x * ox - r1y * oy) / (ox * ox + oy * oy)
    fx, fy = -r1x - s * ox, -r1y - s * oy
    dist_sq_line = fx * fx + fy * fy
    dx, dy = _unit(ox, oy)  # direction of A (A → B); B's is the opposite

    # The agent's disc overlaps the segment: a line through the zero velocity.
    if s < 0.0 and dist_sq1 <= radius_sq:
        ux, uy = _unit(-r1y, r1x)
        return ux, uy, 0.0, 0.0
    if s > 1.0 and dist_sq2 <= radius_sq:
        # RVO2's extra test det(r2, direction of B) >= 0 always holds for a segment seen
        # from the right of A → B.
        ux, uy = _unit(-r2y, r2x)
        return ux, uy, 0.0, 0.0
    if 0.0 <= s <= 1.0 and dist_sq_line <= radius_sq:
        return -dx, -dy, 0.0, 0.0

    # No collision: the legs. Seen end-on, one end point alone defines the obstacle.
    if s < 0.0 and dist_sq_line <= radius_sq:
        single = True
        c1x, c1y, c2x, c2y = r1x, r1y, r1x, r1y
        d1x, d1y, d2x, d2y = dx, dy, dx, dy  # both "vertices" are A
        llx, lly, rlx, rly = _legs(r1x, r1y, dist_sq1, radius)
    elif s > 1.0 and dist_sq_line <= radius_sq:
        single = True
        c1x, c1y, c2x, c2y = r2x, r2y, r2x, r2y
        d1x, d1y, d2x, d2y = -dx, -dy, -dx, -dy  # both "vertices" are B
        llx, lly, rlx, rly = _legs(r2x, r2y, dist_sq2, radius)
    else:
        single = False
        c1x, c1y, c2x, c2y = r1x, r1y, r2x, r2y
        d1x, d1y, d2x, d2y = dx, dy, -dx, -dy
        llx, lly, _, _ = _legs(r1x, r1y, dist_sq1, radius)
        _, _, rlx, rly = _legs(r2x, r2y, dist_sq2, radius)

    # A leg pointing into the segment is replaced by the segment's direction (foreign).
    left_foreign = _det(llx, lly, d1x, d1y) >= 0.0
    if left_foreign:
        llx, lly = d1x, d1y
    right_foreign = _det(rlx, rly, d2x, d2y) <= 0.0
    if right_foreign:
        rlx, rly = d2x, d2y

    # Cut-off centres (end points seen through the horizon) and the projections.
    lcx, lcy = inv_t * c1x, inv_t * c1y
    rcx, rcy = inv_t * c2x, inv_t * c2y
    cvx, cvy = rcx - lcx, rcy - lcy
    wlx, wly = vx - lcx, vy - lcy
    wrx, wry = vx - rcx, vy - rcy
    t = 0.5 if single else (wlx * cvx + wly * cvy) / (cvx * cvx + cvy * cvy)
    t_left = wlx * llx + wly * lly
    t_right = wrx * rlx + wry * rly
    shift = radius * inv_t

    if (t < 0.0 and t_left < 0.0) or (single and t_left < 0.0 and t_right < 0.0):
        ux, uy = _unit(wlx, wly)  # the left cut-off circle
        return uy, -ux, lcx + shift * ux, lcy + shift * uy
    if t > 1.0 and t_right < 0.0:
        ux, uy = _unit(wrx, wry)  # the right cut-off circle
        return uy, -ux, rcx + shift * ux, rcy + shift * uy

    inf = math.inf
    if t < 0.0 or t > 1.0 or single:
        dist_cut = inf
    else:
        ex, ey = wlx - t * cvx, wly - t * cvy
        dist_cut = ex * ex + ey * ey
    if t_left < 0.0:
        dist_left = inf
    else:
        ex, ey = wlx - t_left * llx, wly - t_left * lly
        dist_left = ex * ex + ey * ey
    if t_right < 0.0:
        dist_right = inf
    else:
        ex, ey = wrx - t_right * rlx, wry - t_right * rly
        dist_right = ex * ex + ey * ey

    if dist_cut <= dist_left and dist_cut <= dist_right:
        lx, ly = -d1x, -d1y  # the cut-off line
        return lx, ly, lcx + shift * -ly, lcy + shift * lx
    if dist_left <= dist_right:
        if left_foreign:
            return None
        return llx, lly, lcx + shift * -lly, lcy + shift * llx
    if right_foreign:
        return None
    lx, ly = -rlx, -rly
    return lx, ly, rcx + shift * -ly, rcy + shift * lx
