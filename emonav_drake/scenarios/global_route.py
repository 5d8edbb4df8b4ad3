"""A route on the known static map: the shortest path around walls and static discs.

The map is what does not move: wall segments and static discs (pedestrians are the local
planner's business). Every obstacle is inflated by the robot's `clearance` (its radius
plus a margin): a disc of radius r becomes one of r + clearance, a wall a capsule of
half-width `clearance`. The route is the shortest polyline from start to goal that stays
out of every inflated obstacle, found on a visibility graph:

* **Nodes**: the start, the goal, and `samples` points around every inflated disc and
  every wall end (a capsule's rounded cap) — the vertices of a polygon circumscribed about
  the inflated circle, pushed out by `NODE_SLACK`, so the polygon's edges stay outside
  it. Nodes inside another inflated obstacle are dropped.
* **Edges**: two nodes are joined when the straight segment between them keeps at least
  the inflated distance from every obstacle (segment-to-segment distance for walls,
  point-to-segment for disc centres); its weight is its length.
* **Search**: Dijkstra (`scipy.sparse.csgraph.dijkstra`) from the start.

The route's corners lie `NODE_SLACK` outside the inflated obstacles, so it is within a
few millimetres of the shortest free path (the polygon approximates the circle: with
16 samples a corner is at most 2 % of the clearance farther out than needed). With no
obstacle between start and goal the route is the straight segment. `NoRouteError` says
why there is none: start or goal inside an inflated obstacle (naming it), or no path.

`lookahead_point` gives the sub-goal a local planner steers to: the point `distance`
along the route beyond the robot's projection onto it.

Pure numpy and scipy; world frame, metres.
"""

from __future__ import annotations

import dataclasses as dc
import math

import numpy as np

from emonav_drake.scenarios.walls import as_segments, point_segment_distances

NODE_SLACK = 1e-3  # [m] nodes lie this far outside the inflated obstacles
EDGE_TOLERANCE = 1e-9  # [m] an edge may graze an inflated obstacle by this much


class NoRouteError(ValueError):
    """No route from start to goal on the map (the message says why)."""


@dc.dataclass(frozen=True)
class StaticMap:
    """The known static world: wall segments (W, 2, 2) and discs (centres (D, 2), radii
    (D,)), world frame [m]."""

    walls: np.ndarray
    centers: np.ndarray
    radii: np.ndarray

    @classmethod
    def of(cls, walls: object = None, centers: object = None, radii: object = None) -> StaticMap:
        """A checked map (`ValueError` on malformed arrays)."""
        c = np.asarray([] if centers is None else centers, dtype=float).reshape(-1, 2)
        r = np.asarray([] if radii is None else radii, dtype=float).reshape(-1)
        if len(c) != len(r):
            raise ValueError(f"{len(c)} disc centres, {len(r)} radii")
        if not (np.isfinite(c).all() and np.isfinite(r).all() and (r > 0).all()):
            raise ValueError("disc centres and radii must be finite, radii > 0")
        return cls(as_segments(walls, "walls"), c, r)


def _segment_distances(
    p0: np.ndarray, p1: np.ndarray, q0: np.ndarray, q1: np.ndarray
) -> np.ndarray:
    """Distances between segments p (E, 2) → (E, 2) and q (W, 2): (E, W) [m]."""
    d1 = (p1 - p0)[:, None, :]  # (E, 1, 2)
    d2 = (q1 - q0)[None, :, :]  # (1, W, 2)
    r = p0[:, None, :] - q0[None, :, :]  # (E, W, 2)
    a = np.sum(d1 * d1, axis=2)
    e = np.sum(d2 * d2, axis=2)
    f = np.sum(d2 * r, axis=2)
    c = np.sum(d1 * r, axis=2)
    b = np.sum(d1 * d2, axis=2)
    denom = a * e - b * b
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.where(denom > 1e-15, np.clip((b * f - c * e) / denom, 0.0, 1.0), 0.0)
        s = np.where(a > 1e-15, s, 0.0)
        t = np.where(e > 1e-15, (b * s + f) / e, 0.0)
    t_clipped = np.clip(t, 0.0, 1.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.where(
            t == t_clipped, s, np.where(a > 1e-15, np.clip((b * t_clipped - c) / a, 0.0, 1.0), 0.0)
        )
    closest = r + d1 * s[..., None] - d2 * t_clipped[..., None]
    return np.hypot(closest[..., 0], closest[..., 1])


def _point_to_segments(points: np.ndarray, segments: np.ndarray) -> np.ndarray:
    """(N, W) distances from points (N, 2) to segments (W, 2, 2)."""
    if len(segments) == 0:
        return np.zeros((len(points), 0))
    return np.stack([point_segment_distances(p, segments) for p in points])


def clearance_violations(points: np.ndarray, static_map: StaticMap, clearance: float) -> list[str]:
    """The inflated obstacles (by name: "wall i", "disc i") each point (N, 2) lies in."""
    out = []
    for p in np.asarray(points, dtype=float).reshape(-1, 2):
        wall = point_segment_distances(p, static_map.walls) if len(static_map.walls) else []
        disc = np.hypot(*(static_map.centers - p).T) - static_map.radii
        names = [f"wall {i}" for i, d in enumerate(wall) if d < clearance]
        names += [f"disc {i}" for i, d in enumerate(np.atleast_1d(disc)) if d < clearance]
        out.append(", ".join(names))
    return out


def _nodes(static_map: StaticMap, clearance: float, samples: int) -> np.ndarray:
    """The polygon vertices around every inflated disc and wall end (module docstring)."""
    angles = 2.0 * math.pi * np.arange(samples) / samples
    ring = np.stack([np.cos(angles), np.sin(angles)], axis=1) / math.cos(math.pi / samples)
    pts = []
    for c, r in zip(static_map.centers, static_map.radii, strict=True):
        pts.append(c + (r + clearance + NODE_SLACK) * ring)
    for w in static_map.walls:
        for end in w:
            pts.append(end + (clearance + NODE_SLACK) * ring)
    return np.concatenate(pts) if pts else np.zeros((0, 2))


def _free(points: np.ndarray, static_map: StaticMap, clearance: float) -> np.ndarray:
    """(N,) whether each point is outside every inflated obstacle."""
    ok = np.ones(len(points), dtype=bool)
    if len(static_map.walls):
        ok &= (_point_to_segments(points, static_map.walls) >= clearance).all(axis=1)
    if len(static_map.radii):
        gap = np.hypot(
            points[:, None, 0] - static_map.centers[None, :, 0],
            points[:, None, 1] - static_map.centers[None, :, 1],
        )
        ok &= (gap >= static_map.radii[None, :] + clearance).all(axis=1)
    return ok


def _visible(a: np.ndarray, b: np.ndarray, static_map: StaticMap, clearance: float) -> np.ndarray:
    """(E,) whether each segment a[e] → b[e] keeps its distance from every obstacle."""
    ok = np.ones(len(a), dtype=bool)
    if len(static_map.walls):
        d = _segment_distances(a, b, static_map.walls[:, 0], static_map.walls[:, 1])
        ok &= (d >= clearance - EDGE_TOLERANCE).all(axis=1)
    if len(static_map.radii):
        e = b - a
        rel = static_map.centers[None, :, :] - a[:, None, :]  # (E, D, 2)
        length2 = np.maximum(np.sum(e * e, axis=1), 1e-18)[:, None]
        s = np.clip(np.sum(rel * e[:, None, :], axis=2) / length2, 0.0, 1.0)
        closest = rel - s[..., None] * e[:, None, :]
        gap = np.hypot(closest[..., 0], closest[..., 1])
        ok &= (gap >= static_map.radii[None, :] + clearance - EDGE_TOLERANCE).all(axis=1)
    return ok


def segments_clear(route: np.ndarray, static_map: StaticMap, clearance: float) -> bool:
    """Whether every segment of the polyline `route` (K, 2) [m] keeps `clearance` [m] from
    every obstacle of the map (a single point: whether it does)."""
    r = np.asarray(route, dtype=float).reshape(-1, 2)
    if len(r) == 1:
        return _free(r, static_map, clearance)[0]
    return bool(_visible(r[:-1], r[1:], static_map, clearance).all())


def plan_route(
    start: object,
    goal: object,
    static_map: StaticMap,
    clearance: float,
    samples: int = 16,
) -> np.ndarray:
    """The shortest route (K, 2) [m] from `start` to `goal` around the inflated map
    (module docstring); `NoRouteError` when there is none."""
    if not clearance > 0:
        raise ValueError(f"clearance = {clearance}: must be > 0")
    if samples < 6:
        raise ValueError(f"samples = {samples}: at least 6")
    s, g = (np.asarray(p, dtype=float).reshape(2) for p in (start, goal))
    for name, p in (("start", s), ("goal", g)):
        (inside,) = clearance_violations(p[None], static_map, clearance)
        if inside:
            raise NoRouteError(
                f"the {name} {p.round(3).tolist()} lies within {clearance:g} m of {inside}"
            )
    if _visible(s[None], g[None], static_map, clearance)[0]:
        return np.stack([s, g])
    nodes = _nodes(static_map, clearance, samples)
    nodes = nodes[_free(nodes, static_map, clearance)]
    pts = np.concatenate([s[None], g[None], nodes])
    n = len(pts)
    i, j = np.triu_indices(n, k=1)
    ok = _visible(pts[i], pts[j], static_map, clearance)
    i, j = i[ok], j[ok]
    length = np.hypot(*(pts[j] - pts[i]).T)
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import dijkstra

    graph = coo_matrix((length, (i, j)), shape=(n, n)).tocsr()
    dist, pred = dijkstra(graph, directed=False, indices=0, return_predecessors=True)
    if not np.isfinite(dist[1]):
        raise NoRouteError(
            f"no route from {s.round(3).tolist()} to {g.round(3).tolist()} with a clearance "
            f"of {clearance:g} m: the walls and obstacles close it off"
        )
    path = [1]
    while path[-1] != 0:
        path.append(int(pred[path[-1]]))
    return pts[path[::-1]]


def route_length(route: np.ndarray) -> float:
    """The polyline's length [m]."""
    r = np.asarray(route, dtype=float).reshape(-1, 2)
    return float(np.hypot(*np.diff(r, axis=0).T).sum()) if len(r) > 1 else 0.0


def lookahead_point(route: np.ndarray, position: object, distance: float) -> np.ndarray:
    """The point `distance` [m] along `route` (K, 2) beyond the point of the route nearest
    `position`; the route's end when less is left."""
    r = np.asarray(route, dtype=float).reshape(-1, 2)
    p = np.asarray(position, dtype=float).reshape(2)
    if len(r) == 1:
        return r[0].copy()
    seg = np.stack([r[:-1], r[1:]], axis=1)
    gaps = point_segment_distances(p, seg)
    k = int(np.argmin(gaps))
    e = seg[k, 1] - seg[k, 0]
    u = float(np.clip(np.dot(p - seg[k, 0], e) / max(np.dot(e, e), 1e-18), 0.0, 1.0))
    left = distance
    here, seg_k = seg[k, 0] + u * e, k
    while seg_k < len(seg):
        end = seg[seg_k, 1]
        step = float(np.hypot(*(end - here)))
        if step >= left:
            return here + (end - here) * (left / step if step > 0 else 0.0)
        left -= step
        here = end
        seg_k += 1
    return r[-1].copy()
