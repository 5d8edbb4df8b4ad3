"""Objects in a 2-D LiDAR scan: segmentation into clusters and a circle per cluster.

Everything a robot can see of the crowd is its scan (`sensing/lidar.py`: K beams over 360°,
beam i at ``beam_angles(K)[i]`` from the heading, ``max_range`` = no hit). This module
turns one scan into discs in the world frame (numpy only, deterministic):

1. **Points.** A beam with ``range < max_range`` is a hit; its world point is
   ``robot_xy + range · (cos(heading + angle), sin(heading + angle))``.
2. **Segmentation.** Neighbouring beams (beam K−1 and beam 0 are neighbours too: the scan
   wraps round at 360°) belong to one cluster when both hit and their points are at most
   ``jump_distance + jump_ratio · range`` apart (range = the nearer of the two). A miss or
   a larger jump ends a cluster. The range term lets the gap grow with the beam spacing
   and with the steep range change at a disc's grazing edge (up to about √(2·r·d·Δφ),
   13 cm for a 0.4 m disc at 6 m with Δφ = 2π/1800); an edge beam that jumps more is cut
   off as a cluster of its own and dropped below ``min_points``.
3. **Circle per cluster.** Clusters with fewer than ``min_points`` beams are dropped.
   From ``min_fit_points`` beams on: an algebraic (Kåsa) fit on the centred points gives
   a start, Gauss-Newton steps on the geometric residuals ``|p − c| − r`` refine it
   (at most ``gauss_newton_iterations``, until no step exceeds ``convergence``). The fit
   is accepted when it is finite, its radius lies in ``[min_radius, max_radius]``, its
   RMS residual is at most ``fit_tolerance`` and its centre lies behind the arc as seen
   from the robot (a LiDAR sees the near side of a disc, less than half of its circle).
   Otherwise — too few beams, a nearly straight arc (ill-conditioned), a radius out of
   bounds, a poor fit — the **fallback**: radius ``prior_radius`` (or half the arc's
   chord if that is larger, at most ``max_radius``), centre that far behind the arc's
   middle beam along its line of sight.
   A straight cluster is a **line**, not a circle, and is tested for explicitly: its
   points' scatter matrix has a smaller eigenvalue below 1e-10 of the larger (collinear
   points: no algebraic fit), or a Gauss-Newton normal matrix has a smallest eigenvalue
   below 1e-12 of its largest (nearly collinear points: the best circle grows without
   bound). Such a cluster leaves the refinement at once and takes the fallback (a piece
   of wall shorter than ``wall_min_length``, e.g. cut off by a corner or an occluder;
   longer straight runs are walls, step 4). No linear system is solved unless its matrix
   passed that test.
4. **Walls.** A cluster that holds a long straight run of points (a wall) would otherwise
   become one large fallback circle that slides along the wall as the robot moves. So a
   cluster longer than ``wall_min_length`` (its bounding box's diagonal) is first split
   into straight runs (iterative end-point fit: a run is split at its point farthest from
   the chord between its ends while that point is more than ``wall_tolerance`` off it).
   Each run at least ``wall_min_length`` long (end to end) is a wall: it is cut into
   pieces at fixed places along its line — every ``wall_piece_length`` metres of the
   coordinate ``s = p·d`` of its points p along its direction d (principal axis of the
   points), counted from the world origin — so a piece covers the same stretch of wall
   from one scan to the next and its disc stays put (a still object for the tracker).
   A piece's disc is that whole stretch of the wall line, seen or not: centre at the
   stretch's middle on the line, radius ``wall_piece_length / 2``; it does not move when
   the piece is partly hidden or cut by the range (it may overhang a wall's end by less
   than a piece). The rest of the cluster (consecutive non-wall runs, e.g. a pedestrian next to
   the wall) goes through step 3 as clusters of their own (dropped below
   ``min_points``). Pieces are flagged in `Detections.walls`. A disc's arc is never a
   wall run unless its radius exceeds about ``wall_min_length² / (8·wall_tolerance)``
   (4 m with the defaults), so scans without such objects are detected as before.

All clusters are fitted at once (sums per cluster with ``np.add.reduceat``, batched 3 × 3
solves of the matrices that passed the conditioning test; the refinement stops when every
cluster has converged), so a scan costs O(hits) numpy work and a bounded number of numpy
calls whatever the number of objects.
"""

from __future__ import annotations

import dataclasses as dc
import math

import numpy as np

from emonav_drake.config_fields import setting
from emonav_drake.sensing.lidar import as_point, beam_table


@dc.dataclass(frozen=True)
class DetectionParams:
    """Segmentation and circle fitting of `detect_objects` (metres, beams)."""

    jump_distance: float = setting(
        0.1,
        "points farther apart start a new cluster (plus jump_ratio times the nearer range)",
        "m",
    )
    jump_ratio: float = setting(
        0.01, "added to jump_distance: this times the nearer of the two ranges", "m/m"
    )
    min_points: int = setting(
        5, "clusters with fewer beams are dropped (slivers: no reliable centre)"
    )
    min_fit_points: int = setting(5, "fewer beams: no fit, the fallback circle")
    min_radius: float = setting(0.1, "smallest accepted fitted radius", "m")
    max_radius: float = setting(0.7, "largest accepted fitted radius", "m")
    prior_radius: float = setting(0.3, "fallback radius (a pedestrian's)", "m")
    fit_tolerance: float = setting(0.03, "largest accepted RMS residual of a fit", "m")
    gauss_newton_iterations: int = setting(
        10, "most geometric refinement steps after the algebraic fit"
    )
    convergence: float = setting(1e-06, "refinement stops once no centre or radius moves more", "m")
    wall_min_length: float = setting(
        1.0, "a straight run of points at least this long is a wall", "m"
    )
    wall_tolerance: float = setting(
        0.03, "a straight run's points lie within this of its chord", "m"
    )
    wall_piece_length: float = setting(0.5, "walls are reported as pieces this long", "m")
    legs: bool = setting(
        False,
        "people as legs (sensing/leg_detection.py; on for a sensor that sees legs): clusters are "
        "legs, paired into people; a well-fitted disc larger than a leg is a fixed object",
    )
    max_missing_beams: int = setting(0, "beams lost inside a cluster that do not end it")
    despeckle: bool = setting(
        False,
        "a lone return between two neighbours that agree with each other (within the jump limit) "
        "and not with it is a speckle (a spurious return): taken as a lost beam",
    )
    leg_min_points: int = setting(3, "a leg cluster has at least this many beams")
    leg_max_width: float = setting(0.25, "a cluster at most this wide (end to end) is one leg", "m")
    leg_notch: float = setting(0.03, "a wider cluster with a dip this deep is two legs", "m")
    leg_radius: float = setting(0.07, "a leg's centre lies this far behind its points", "m")
    leg_pair_distance: float = setting(0.55, "two legs at most this far apart are one person", "m")

    def validate(self) -> DetectionParams:
        """Raise ValueError naming the field if a value is out of range; returns self."""
        for name in (
            "jump_distance",
            "min_radius",
            "max_radius",
            "prior_radius",
            "wall_min_length",
            "wall_tolerance",
            "wall_piece_length",
        ):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0.0):
                raise ValueError(f"DetectionParams.{name} must be finite and > 0, got {v!r}")
        for name in ("leg_max_width", "leg_radius", "leg_pair_distance"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0.0):
                raise ValueError(f"DetectionParams.{name} must be finite and > 0, got {v!r}")
        for name in ("jump_ratio", "fit_tolerance", "convergence", "leg_notch"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v >= 0.0):
                raise ValueError(f"DetectionParams.{name} must be finite and >= 0, got {v!r}")
        for name, low in (
            ("min_points", 1),
            ("min_fit_points", 3),
            ("gauss_newton_iterations", 0),
            ("max_missing_beams", 0),
            ("leg_min_points", 2),
        ):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int) or v < low:
                raise ValueError(f"DetectionParams.{name} must be an int >= {low}, got {v!r}")
        if self.min_radius > self.max_radius:
            raise ValueError(
                f"DetectionParams.min_radius ({self.min_radius}) must not exceed "
                f"max_radius ({self.max_radius})"
            )
        if not self.min_radius <= self.prior_radius <= self.max_radius:
            raise ValueError(
                f"DetectionParams.prior_radius ({self.prior_radius}) must lie in "
                f"[min_radius, max_radius] = [{self.min_radius}, {self.max_radius}]"
            )
        if not self.wall_piece_length <= 2.0 * self.max_radius:
            raise ValueError(
                f"DetectionParams.wall_piece_length ({self.wall_piece_length}) must not "
                f"exceed 2 * max_radius ({2.0 * self.max_radius}): a piece's disc is bounded"
            )
        return self


@dc.dataclass(frozen=True)
class Detections:
    """The discs found in one scan, world frame."""

    centers: np.ndarray  # (K, 2) disc centres [m]
    radii: np.ndarray  # (K,) disc radii [m]
    points: np.ndarray  # (K,) number of beams in each disc's cluster
    walls: np.ndarray | None = None  # (K,) bool: a piece of a wall (None: no piece is)

    def __post_init__(self) -> None:
        if self.walls is None:
            object.__setattr__(self, "walls", np.zeros(len(self.radii), dtype=bool))

    def __len__(self) -> int:
        return int(self.radii.shape[0])

    @staticmethod
    def empty() -> Detections:
        """No detection."""
        return Detections(np.zeros((0, 2)), np.zeros(0), np.zeros(0, dtype=np.int64))


def detect_objects(
    ranges: np.ndarray,
    robot_xy: np.ndarray,
    heading: float,
    max_range: float,
    params: DetectionParams = DetectionParams(),
) -> Detections:
    """The discs in one LiDAR scan (module docstring for the method).

    Args:
        ranges: (K,) ranges [m] of the K beams of `sensing.lidar` (``beam_angles(K)``);
            ``max_range`` (or more) = no hit.
        robot_xy: LiDAR position (2,) in the world frame [m].
        heading: robot heading in the world frame [rad], CCW from +x.
        max_range: the scan's maximum range [m].
        params: segmentation and fit parameters.

    Returns:
        `Detections`, ordered by the beam index of each cluster's (or wall piece's) first
        beam (a cluster across the seam behind the robot counts from its first beam
        before the seam).
    """
    r, (ox, oy), heading, max_range = checked_scan(ranges, robot_xy, heading, max_range, params)
    if params.legs:
        raise ValueError(
            "DetectionParams.legs: people as legs are detected by "
            "sensing/leg_detection.py::detect_scan, not detect_objects"
        )
    seg = segment_scan(r, (ox, oy), heading, max_range, params)
    if seg is None:
        return Detections.empty()
    px, py, beams, order, starts, counts = seg
    big = counts >= params.min_points
    if not big.any():
        return Detections.empty()
    # Drop small clusters: rebuild the concatenation of the kept ones.
    sel = np.repeat(big, counts)
    order = order[sel]
    counts = counts[big]
    starts = np.concatenate(([0], np.cumsum(counts)[:-1]))
    split = _split_walls(px[order], py[order], starts, counts, params)
    if split is None:  # no wall: every cluster is a disc
        centers, radii = _fit_circles(px[order], py[order], starts, counts, (ox, oy), params)
        first_beam = beams[order[starts]]
        walls = np.zeros(counts.size, dtype=bool)
    else:
        keep, counts, piece_c, piece_r, piece_n, piece_first = split
        order_c = order[keep]
        starts = (np.cumsum(counts) - counts).astype(np.intp)
        centers, radii = np.zeros((0, 2)), np.zeros(0)
        if counts.size:
            centers, radii = _fit_circles(
                px[order_c], py[order_c], starts, counts, (ox, oy), params
            )
        first_beam = np.concatenate([beams[order_c[starts]], beams[order[piece_first]]])
        centers = np.vstack([centers, piece_c])
        radii = np.concatenate([radii, piece_r])
        walls = np.concatenate([np.zeros(counts.size, dtype=bool), np.ones(piece_r.size, bool)])
        counts = np.concatenate([counts, piece_n])
    # Report clusters by their first beam index (deterministic and independent of `first`).
    idx = np.argsort(first_beam, kind="stable")
    return Detections(centers[idx], radii[idx], counts[idx].astype(np.int64), walls[idx])


def checked_scan(
    ranges: np.ndarray,
    robot_xy: np.ndarray,
    heading: float,
    max_range: float,
    params: DetectionParams,
) -> tuple[np.ndarray, tuple[float, float], float, float]:
    """The inputs of a detector, checked: (ranges (K,) float64, (x, y), heading,
    max_range); ValueError naming what is wrong (`detect_objects` for the meaning)."""
    r = np.asarray(ranges, dtype=np.float64)
    if r.ndim != 1 or r.size == 0:
        raise ValueError(f"ranges must have shape (K,) with K >= 1, got {r.shape}")
    if np.isnan(r).any() or (r < 0.0).any():
        raise ValueError("ranges must be >= 0 (no NaN)")
    params.validate()
    ox, oy = as_point(robot_xy, "robot_xy")
    heading, max_range = float(heading), float(max_range)
    if not (math.isfinite(heading) and math.isfinite(max_range) and max_range > 0.0):
        raise ValueError(
            f"heading and max_range must be finite (max_range > 0): {heading}, {max_range}"
        )
    return r, (ox, oy), heading, max_range


def segment_scan(
    r: np.ndarray,
    origin: tuple[float, float],
    heading: float,
    max_range: float,
    params: DetectionParams,
) -> tuple[np.ndarray, ...] | None:
    """Steps 1-2 of the module docstring: the hits' world points and their clusters.

    Returns None without a hit, else ``(px, py, beams, order, starts, counts)``: the
    world points (m,) [m] and beam indices (m,) of the hits in beam order, and the
    clusters laid end to end — ``order[starts[j] : starts[j] + counts[j]]`` are the hits
    of cluster j, in beam order. Two hits are neighbours when at most
    ``params.max_missing_beams`` beams between them were lost.
    """
    ox, oy = origin
    k = r.size
    if params.despeckle and k >= 3:
        r = _despeckled(r, max_range, params)
    beams = np.flatnonzero(r < max_range)  # the hits, in beam order
    m = beams.size
    if m == 0:
        return None

    # World points of the hits: the robot-frame beam directions rotated by the heading.
    _, cos_b, sin_b = beam_table(k)
    ch, sh = math.cos(heading), math.sin(heading)
    rh, cb, sb = r[beams], cos_b[beams], sin_b[beams]
    px = ox + rh * (ch * cb - sh * sb)
    py = oy + rh * (sh * cb + ch * sb)

    # link[j]: hit j and the next hit (mod m) are neighbouring beams in one cluster.
    nxt = np.arange(1, m + 1)
    nxt[-1] = 0
    step = (beams[nxt] - beams) % k  # 0 for a single hit: no neighbour of itself
    adjacent = (step >= 1) & (step <= 1 + params.max_missing_beams)
    gap = np.hypot(px[nxt] - px, py[nxt] - py)
    limit = params.jump_distance + params.jump_ratio * np.minimum(rh, rh[nxt])
    link = adjacent & (gap <= limit)
    if link.all():  # one closed ring round the robot (e.g. inside a disc)
        order = np.arange(m)
        starts = np.zeros(1, dtype=np.intp)
    else:
        # Start right after the first break, so no cluster straddles the array's end; a
        # cluster starts wherever its predecessor does not link to it.
        first = int(np.argmin(link)) + 1
        order = (np.arange(m) + first) % m
        starts = np.flatnonzero(~np.concatenate(([False], link[order][:-1])))
    counts = np.diff(np.append(starts, order.size))
    return px, py, beams, order, starts, counts


def _despeckled(r: np.ndarray, max_range: float, params: DetectionParams) -> np.ndarray:
    """`r` with every speckle set to `max_range` (`DetectionParams.despeckle`): a hit whose
    two neighbours are hits within the jump limit of each other, both farther than it
    by more than the jump limit or both nearer. Ranges compared along the beams [m]."""
    prev_r, next_r = np.roll(r, 1), np.roll(r, -1)
    limit = params.jump_distance + params.jump_ratio * np.minimum(prev_r, next_r)
    hits = (r < max_range) & (prev_r < max_range) & (next_r < max_range)
    agree = np.abs(prev_r - next_r) <= limit
    off = np.minimum(np.abs(r - prev_r), np.abs(r - next_r)) > limit
    out = r.copy()
    out[hits & agree & off] = max_range
    return out


# A cluster is a line, not a circle, when the smaller eigenvalue of its points' scatter
# matrix is below this fraction of the larger one (collinear to about 1e-5 of its length) …
_LINE_RATIO = 1e-10
# … or when a Gauss-Newton normal matrix's smallest eigenvalue falls below this fraction of
# its largest (the circle through nearly collinear points grows without bound; a solve
# would be meaningless or singular). A disc's arc the detector accepts stays far above
# (5 beams 1 cm apart on a 0.7 m disc: about 7e-9).
_GN_RCOND = 1e-12


def _well_conditioned(a: np.ndarray, skip: np.ndarray) -> np.ndarray:
    """Which of the symmetric positive semi-definite matrices `a` (C, 3, 3) are finite and
    well-conditioned (smallest eigenvalue > ``_GN_RCOND`` · largest); `skip` (C,) bool:
    matrices not to test (reported False)."""
    good = ~skip & np.isfinite(a).all(axis=(1, 2))
    out = np.zeros(a.shape[0], dtype=bool)
    if good.any():
        lam = np.linalg.eigvalsh(a[good])  # ascending, per matrix
        out[good] = lam[:, 0] > _GN_RCOND * lam[:, -1]
    return out


def _fit_circles(
    x: np.ndarray,
    y: np.ndarray,
    starts: np.ndarray,
    counts: np.ndarray,
    origin: tuple[float, float],
    p: DetectionParams,
) -> tuple[np.ndarray, np.ndarray]:
    """Circles (centres (C, 2), radii (C,)) of C clusters laid end to end in `x`, `y`
    (cluster j = ``[starts[j], starts[j] + counts[j])``), fitted as the module docstring
    says; `origin` is the LiDAR position."""
    centers, radii, _ = fit_circles(x, y, starts, counts, origin, p)
    return centers, radii


def fit_circles(
    x: np.ndarray,
    y: np.ndarray,
    starts: np.ndarray,
    counts: np.ndarray,
    origin: tuple[float, float],
    p: DetectionParams,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """`_fit_circles`, and (C,) bool: which clusters' fits were accepted (the others have
    the fallback circle)."""
    n = counts.astype(np.float64)
    seg = np.repeat(np.arange(counts.size), counts)
    mx = np.add.reduceat(x, starts) / n
    my = np.add.reduceat(y, starts) / n
    u, v = x - mx[seg], y - my[seg]  # centred, for a well-scaled algebraic fit

    # Kåsa: minimise Σ(z + D·u + E·v + F)² with z = u² + v²; Σu = Σv = 0 after centring,
    # so the normal equations decouple into a 2 × 2 system for (D, E) and F = −mean(z).
    z = u * u + v * v
    suu = np.add.reduceat(u * u, starts)
    svv = np.add.reduceat(v * v, starts)
    suv = np.add.reduceat(u * v, starts)
    suz = np.add.reduceat(u * z, starts)
    svz = np.add.reduceat(v * z, starts)
    det = suu * svv - suv * suv
    # Ill-conditioned (a line: collinear points, or a tiny arc): the smaller eigenvalue
    # of the scatter matrix is tiny against the larger one (det / trace² ≈ their ratio).
    trace = suu + svv
    ok = (counts >= p.min_fit_points) & (det > _LINE_RATIO * trace * trace) & (trace > 0.0)
    safe = np.where(ok, det, 1.0)
    d_coef = -(svv * suz - suv * svz) / safe
    e_coef = -(suu * svz - suv * suz) / safe
    f_coef = -np.add.reduceat(z, starts) / n
    cx, cy = -d_coef / 2.0, -e_coef / 2.0  # centre relative to the cluster's mean
    rad = np.sqrt(np.maximum(cx * cx + cy * cy - f_coef, 0.0))

    # Gauss-Newton on the geometric residuals |q − c| − r, in the centred coordinates.
    jac = np.empty((u.size, 4))  # per point: ∂res/∂(cx, cy, r) and the residual
    jac[:, 2] = -1.0
    eye = np.eye(3)
    for _ in range(p.gauss_newton_iterations):
        du, dv = u - cx[seg], v - cy[seg]
        dist = np.maximum(np.hypot(du, dv), 1e-12)
        np.divide(-du, dist, out=jac[:, 0])
        np.divide(-dv, dist, out=jac[:, 1])
        np.subtract(dist, rad[seg], out=jac[:, 3])
        # [JᵀJ | Jᵀres] per cluster in one pass: (C, 3, 4).
        normal = np.add.reduceat(jac[:, :3, None] * jac[:, None, :], starts, axis=0)
        a, rhs = normal[:, :, :3], -normal[:, :, 3:]
        # A normal matrix that is not finite or ill-conditioned: the best circle is
        # running off to an infinite radius (a line); that cluster leaves the refinement.
        ok &= _well_conditioned(a, ~ok)
        a[~ok] = eye  # solve only checked matrices; the others take the fallback anyway
        rhs[~ok] = 0.0
        with np.errstate(all="ignore"):
            step = np.linalg.solve(a, rhs)[:, :, 0]
        cx, cy, rad = cx + step[:, 0], cy + step[:, 1], rad + step[:, 2]
        if not np.abs(step[ok]).max(initial=0.0) > p.convergence:
            break  # converged (also: nothing left to refine)

    du, dv = u - cx[seg], v - cy[seg]
    res = np.hypot(du, dv) - rad[seg]
    rms = np.sqrt(np.add.reduceat(res * res, starts) / n)
    centers = np.stack([cx + mx, cy + my], axis=1)
    # The centre must lie behind the arc: farther from the LiDAR than the arc's mean point.
    ox, oy = origin
    behind = np.hypot(centers[:, 0] - ox, centers[:, 1] - oy) > np.hypot(mx - ox, my - oy)
    with np.errstate(invalid="ignore"):
        ok &= (
            np.isfinite(centers).all(axis=1)
            & np.isfinite(rad)
            & (rad >= p.min_radius)
            & (rad <= p.max_radius)
            & (rms <= p.fit_tolerance)
            & behind
        )
    if ok.all():
        return centers, rad, ok

    # Fallback: the prior radius behind the arc's middle beam, along its line of sight.
    last = starts + counts - 1
    lo, hi = starts + (counts - 1) // 2, starts + counts // 2  # the middle beam(s)
    chord = np.hypot(x[last] - x[starts], y[last] - y[starts])
    fr = np.clip(np.maximum(p.prior_radius, chord / 2.0), p.min_radius, p.max_radius)
    qx, qy = (x[lo] + x[hi]) / 2.0, (y[lo] + y[hi]) / 2.0
    sx, sy = qx - ox, qy - oy
    sn = np.maximum(np.hypot(sx, sy), 1e-12)
    fallback = np.stack([qx + fr * sx / sn, qy + fr * sy / sn], axis=1)
    centers = np.where(ok[:, None], centers, fallback)
    rad = np.where(ok, rad, fr)
    return centers, rad, ok


# ------------------------------------------------------------------------------------- walls


def _split_walls(
    x: np.ndarray, y: np.ndarray, starts: np.ndarray, counts: np.ndarray, p: DetectionParams
) -> tuple | None:
    """Wall pieces of the clusters laid end to end in `x`, `y` (world [m]; module docstring,
    step 4), or None if no cluster holds a wall.

    Returns ``(keep, counts, centres (n, 2), radii (n,), points (n,), first (n,))``: the
    positions in `x` of the points left to the circle fit, cluster after cluster, and
    those clusters' sizes; the pieces' discs, beam counts and first points' positions.
    """
    ends = starts + counts
    lo_x, hi_x = np.minimum.reduceat(x, starts), np.maximum.reduceat(x, starts)
    lo_y, hi_y = np.minimum.reduceat(y, starts), np.maximum.reduceat(y, starts)
    long = np.hypot(hi_x - lo_x, hi_y - lo_y) >= p.wall_min_length
    if not long.any():
        return None
    keep: list[np.ndarray] = []
    kept: list[int] = []
    pieces: list[tuple] = []
    found = False
    for c in range(counts.size):
        a, b = int(starts[c]), int(ends[c])
        runs = _straight_runs(x[a:b], y[a:b], p.wall_tolerance) if long[c] else [(0, b - a - 1)]
        rest: list[int] = []  # positions of the current stretch of non-wall points
        for i, j in runs:
            idx = np.arange(a + i, a + j + 1)
            if math.hypot(x[a + j] - x[a + i], y[a + j] - y[a + i]) < p.wall_min_length:
                rest.extend(idx.tolist())
                continue
            found = True
            _flush(rest, keep, kept, p.min_points)
            rest = []
            pieces.extend(_pieces(x, y, idx, p))
        _flush(rest, keep, kept, p.min_points)
    if not found:
        return None
    c_, r_, n_, f_ = zip(*pieces, strict=True)
    return (
        np.concatenate(keep) if keep else np.zeros(0, dtype=np.intp),
        np.asarray(kept, dtype=np.int64),
        np.asarray(c_, dtype=np.float64).reshape(-1, 2),
        np.asarray(r_, dtype=np.float64),
        np.asarray(n_, dtype=np.int64),
        np.asarray(f_, dtype=np.intp),
    )


def _flush(rest: list[int], keep: list[np.ndarray], kept: list[int], min_points: int) -> None:
    """Keep a stretch of non-wall points as a cluster if it has ``min_points`` beams."""
    if len(rest) >= min_points:
        keep.append(np.asarray(rest, dtype=np.intp))
        kept.append(len(rest))


def _straight_runs(x: np.ndarray, y: np.ndarray, tolerance: float) -> list[tuple[int, int]]:
    """Iterative end-point fit: inclusive index ranges, in order, that partition the
    points, each with every point within `tolerance` [m] of the chord between its ends
    (a split point ends the run before it)."""
    runs = []
    stack = [(0, x.size - 1)]
    while stack:
        i, j = stack.pop()
        if j - i < 2:
            runs.append((i, j))
            continue
        dx, dy = x[j] - x[i], y[j] - y[i]
        chord = math.hypot(dx, dy)
        u, v = x[i : j + 1] - x[i], y[i : j + 1] - y[i]
        if chord > 1e-9:
            off = np.abs(u * dy - v * dx) / chord
        else:  # a closed ring: the farthest point from the start
            off = np.hypot(u, v)
        k = int(np.argmax(off))
        if off[k] <= tolerance:
            runs.append((i, j))
        else:
            stack.append((i + k + 1, j))
            stack.append((i, i + k))
    return sorted(runs)


def _pieces(x: np.ndarray, y: np.ndarray, idx: np.ndarray, p: DetectionParams) -> list[tuple]:
    """The pieces of one wall run (points `idx`): (centre, radius, beams, first point)."""
    px, py = x[idx], y[idx]
    mx, my = float(px.mean()), float(py.mean())
    cov = np.cov(np.vstack([px - mx, py - my]), bias=True)
    _, vec = np.linalg.eigh(cov)
    dx, dy = float(vec[0, 1]), float(vec[1, 1])  # principal axis (unit)
    s = px * dx + py * dy  # coordinate along the wall, from the world origin [m]
    foot = mx * dx + my * dy
    bins = np.floor(s / p.wall_piece_length)
    radius = 0.5 * p.wall_piece_length
    out = []
    for b in np.unique(bins).tolist():
        inside = np.flatnonzero(bins == b)
        mid = (b + 0.5) * p.wall_piece_length - foot  # the piece's middle, from the mean
        out.append(((mx + mid * dx, my + mid * dy), radius, inside.size, int(idx[inside[0]])))
    return out
