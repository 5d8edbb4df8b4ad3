"""Simulated LiDAR, LGM / OGM frames, frame stack and the paper's resolution comparison."""

from __future__ import annotations

import math

import numpy as np
import pytest

from benchmarks.reference.lgm_reference import ranges_per_beam
from emonav_drake.sensing.grid_maps import FrameStack, lgm_frame, lgm_from_ranges, ogm_from_ranges
from emonav_drake.sensing.grid_resolution import (
    lgm_cell_area,
    lgm_mean_resolution,
    lgm_resolution,
    lgm_ring_cell_counts,
    ogm_cells_touched_by_disc,
    ogm_resolution,
    ogm_ring_cell_counts,
    ogm_ring_circle_cell_counts,
    resolution_crossing_rings,
)
from emonav_drake.sensing.lidar import (
    AUTHORS_BEAM_STEP,
    beam_angles,
    beam_step,
    beam_table,
    scan_discs,
)

K, M, L, RMIN = 1800, 100, 6.0, 0.27
STEP = 0.003490659  # the authors' beam angle step at K = 1800


def polar(distance: float, bearing_deg: float) -> list[list[float]]:
    """One disc centre at ``distance`` and ``bearing`` from a robot at the origin, heading 0."""
    b = math.radians(bearing_deg)
    return [[distance * math.cos(b), distance * math.sin(b)]]


def cells(grid: np.ndarray, value: int) -> set[tuple[int, int]]:
    return {(int(r), int(c)) for r, c in np.argwhere(grid == value)}


def disc_ranges_by_hand(distance: float, radius: float, bearing_deg: float) -> np.ndarray:
    """Closed-form ranges to one disc, θ the beam's angle to the centre's bearing.

    Origin outside (d > r): entry point d·cos θ − √(r² − d² sin² θ) where |d sin θ| ≤ r and
    cos θ > 0. Origin inside (d < r): every beam, exit point d·cos θ + √(r² − d² sin² θ).
    """
    theta = beam_angles(K) - math.radians(bearing_deg)
    perp = distance * np.sin(theta)
    along = distance * np.cos(theta)
    ranges = np.full(K, L)
    if distance < radius:
        ranges = along + np.sqrt(radius**2 - perp**2)
    else:
        hit = (np.abs(perp) <= radius) & (along > 0)
        ranges[hit] = along[hit] - np.sqrt(radius**2 - perp[hit] ** 2)
    return np.clip(ranges, RMIN, L)


# --------------------------------------------------------------------------- beams


def test_beam_angles_follow_the_authors_convention():
    a = beam_angles()
    assert a.shape == (K,)
    # The authors' constant, not 2π/1800 = 0.0034906585…, and exactly so.
    assert AUTHORS_BEAM_STEP == STEP == beam_step(K) != 2.0 * math.pi / K
    assert a[900] - a[899] == STEP
    assert a[0] == -899.5 * STEP and a[-1] == 899.5 * STEP
    assert a[899] == -0.5 * STEP and a[900] == 0.5 * STEP
    assert np.allclose(np.diff(a), STEP, rtol=0.0, atol=1e-15)
    assert a[0] == pytest.approx(math.radians(-179.9), abs=1e-6)  # just behind, on the right
    assert a[-1] == pytest.approx(math.radians(179.9), abs=1e-6)
    # The 1800 rounded steps overshoot 2π by 8.9e-7 rad: the seam gap is that much narrower.
    assert 2.0 * math.pi - (a[-1] - a[0]) == pytest.approx(STEP - 8.93e-7, abs=1e-9)
    # beam_table holds the same angles and math.cos/math.sin of each, read-only.
    angles, cos, sin = beam_table(K)
    assert np.array_equal(angles, a) and not angles.flags.writeable
    assert cos[123] == math.cos((123 - 899.5) * STEP) and sin[7] == math.sin((7 - 899.5) * STEP)


def test_other_beam_counts_keep_two_pi_over_k():
    for k in (1, 4, 360, 900, 3600):
        assert beam_step(k) == 2.0 * math.pi / k
        a = beam_angles(k)
        assert np.array_equal(a, (np.arange(k) - (k - 1) / 2) * (2.0 * math.pi / k))
    assert beam_angles(4).tolist() == pytest.approx(
        [-0.75 * math.pi, -0.25 * math.pi, 0.25 * math.pi, 0.75 * math.pi]
    )
    with pytest.raises(ValueError):
        beam_step(0)


def test_single_disc_straight_ahead_hits_the_hand_computed_beams_and_cells():
    ranges = scan_discs((0.0, 0.0), 0.0, polar(2.0, 0.0), [0.3])
    # Central beams at ±0.1°: 2 cos − √(0.09 − (2 sin)²) ≈ 1.7.
    assert ranges[899] == pytest.approx(1.7, abs=1e-4) and ranges[900] == ranges[899]
    half_width = math.degrees(math.asin(0.3 / 2.0))  # 8.63° → |i − 899.5| ≤ 43.1
    hit = np.flatnonzero(ranges < L)
    assert hit.min() == math.ceil(899.5 - half_width / 0.2) == 857
    assert hit.max() == math.floor(899.5 + half_width / 0.2) == 942
    np.testing.assert_allclose(ranges, disc_ranges_by_hand(2.0, 0.3, 0.0), atol=1e-12)

    grid = lgm_frame((0.0, 0.0), 0.0, polar(2.0, 0.0), [0.3], [0.0])
    expected = {(i // 18, min(int(ranges[i] / 0.06), 99)) for i in hit}
    assert cells(grid, 255) == expected
    assert {r for r, _ in expected} == {857 // 18, 48, 49, 50, 51, 942 // 18} == set(range(47, 53))
    # Rows 49 and 50 hold beams 882–899 and 900–917: nearest column ⌊1.7/0.06⌋ = 28.
    for row in (49, 50):
        assert min(c for r, c in expected if r == row) == 28
    assert cells(grid, 127) == set()  # zero margin: the inflated scan is the real one
    assert np.count_nonzero(grid) == len(expected)


def test_disc_on_the_left_lands_three_quarters_up_the_rows():
    ranges = scan_discs((0.0, 0.0), 0.0, polar(2.0, 90.0), [0.3])
    # +90° is between beams 1349 and 1350 (899.5 + 450) → rows 74 and 75; with the rounded
    # step the two are 4e-7 rad off symmetric, so their ranges agree to ~1e-8 m only.
    assert ranges[1349] == pytest.approx(1.7, abs=1e-4)
    assert ranges[1350] == pytest.approx(ranges[1349], abs=1e-7)
    grid = lgm_frame((0.0, 0.0), 0.0, polar(2.0, 90.0), [0.3], [0.0])
    rows = {r for r, _ in cells(grid, 255)}
    assert rows == set(range(1307 // 18, 1392 // 18 + 1)) == set(range(72, 78))
    assert {c for r, c in cells(grid, 255) if r in (74, 75)} >= {28}


def test_disc_behind_right_is_row_zero_and_the_seam_wraps():
    grid = lgm_frame((0.0, 0.0), 0.0, polar(3.0, -178.0), [0.05], [0.0])
    assert cells(grid, 255) == {(0, 49)}  # beams 5–14, range 2.95 m
    behind = lgm_frame((0.0, 0.0), 0.0, polar(3.0, 180.0), [0.3], [0.0])
    assert {r for r, _ in cells(behind, 255)} == {0, 1, 98, 99}


def test_world_frame_pose_only_changes_the_view():
    """Moving and turning robot and disc together leaves the frame unchanged."""
    heading = 2.5
    origin = np.array([1.3, -0.7])
    world = origin + 2.0 * np.array([math.cos(heading + 0.4), math.sin(heading + 0.4)])
    a = lgm_frame(origin, heading, [world], [0.3], [0.35])
    b = lgm_frame((0.0, 0.0), 0.0, [[2.0 * math.cos(0.4), 2.0 * math.sin(0.4)]], [0.3], [0.35])
    assert np.count_nonzero(a == 255) > 0
    assert np.abs(a.astype(int) - b.astype(int)).sum() <= 2 * 255  # round-off at one edge


# --------------------------------------------------------------------------- discomfort


def test_discomfort_cells_grow_with_the_emotion_distance_and_lie_nearer():
    counts = []
    collision = None
    for margin in (0.2, 0.35, 0.5):
        grid = lgm_frame((0.0, 0.0), 0.0, polar(2.0, 30.0), [0.3], [margin])
        counts.append(np.count_nonzero(grid == 127))
        if collision is None:
            collision = cells(grid, 255)
        assert cells(grid, 255) == collision  # the real scan does not depend on the margin
        for row in {r for r, _ in collision}:
            near = [c for r, c in cells(grid, 127) if r == row]
            far = [c for r, c in collision if r == row]
            assert near and max(near) < min(far)
    assert counts[0] < counts[1] < counts[2]


def test_discomfort_never_overwrites_collision():
    # Two pedestrians: the second's discomfort ring passes over the first's body.
    centers = [[2.0, 0.0], [2.6, 0.0]]
    grid = lgm_frame((0.0, 0.0), 0.0, centers, [0.3, 0.3], [0.5, 0.5])
    hit = scan_discs((0.0, 0.0), 0.0, centers, [0.3, 0.3])
    assert cells(grid, 255) == {(i // 18, int(hit[i] / 0.06)) for i in np.flatnonzero(hit < L)}


# --------------------------------------------------------------------------- clipping


def test_inside_a_discomfort_disc_every_beam_shows_where_it_leaves_the_zone():
    """Robot at the origin heading +x, pedestrian (0.3 m) at (0.5, 0) with a 0.5 m
    discomfort distance: the robot is 0.2 m outside the body, inside the 0.8 m zone."""
    centre, body, margin = [[0.5, 0.0]], [0.3], [0.5]
    exit_ranges = scan_discs((0.0, 0.0), 0.0, centre, [0.8])
    # Exit distance b + √(r² − d² + b²), b = 0.5 cos θ: ahead 0.5 + 0.8, behind 0.8 − 0.5,
    # sideways √(0.8² − 0.5²). Beams 899/900 are ∓0.1° off ahead, 0/1799 ∓0.1° off behind,
    # 1349/1350 straddle +90° and 449/450 −90°.
    assert exit_ranges[899] == pytest.approx(1.3, abs=1e-5) and exit_ranges[900] == exit_ranges[899]
    assert exit_ranges[0] == pytest.approx(0.3, abs=1e-5) and exit_ranges[1799] == exit_ranges[0]
    side = math.sqrt(0.8**2 - 0.5**2)
    assert side == pytest.approx(0.6245, abs=1e-4)
    for pair in ((1349, 1350), (449, 450)):
        assert exit_ranges[list(pair)].mean() == pytest.approx(side, abs=1e-5)
    np.testing.assert_allclose(exit_ranges, disc_ranges_by_hand(0.5, 0.8, 0.0), atol=1e-12)
    assert exit_ranges.min() > RMIN and exit_ranges.max() < L  # no beam clipped

    grid = lgm_frame((0.0, 0.0), 0.0, centre, body, margin)
    body_ranges = scan_discs((0.0, 0.0), 0.0, centre, body)
    collision = {(i // 18, int(body_ranges[i] / 0.06)) for i in np.flatnonzero(body_ranges < L)}
    assert cells(grid, 255) == collision
    exit_cells = {(i // 18, int(exit_ranges[i] / 0.06)) for i in range(K)}
    assert cells(grid, 127) == exit_cells - collision
    # Ahead ⌊1.3/0.06⌋ = 21, behind ⌊0.3/0.06⌋ = 5, sideways ⌊0.6245/0.06⌋ = 10.
    assert {(49, 21), (50, 21), (0, 5), (99, 5), (74, 10), (75, 10), (24, 10), (25, 10)} <= (
        cells(grid, 127)
    )
    # Every row shows the exit contour, none the old full ring at ⌊0.27/0.06⌋ = 4.
    assert {r for r, _ in cells(grid, 127)} == set(range(M))
    assert min(c for _, c in cells(grid, 127)) == 5
    assert not (grid[:, 4] == 127).any()
    # The contour is an ellipse-like curve: farthest ahead, nearest behind.
    far = {r: max(c for rr, c in cells(grid, 127) if rr == r) for r in range(M)}
    assert max(far.values()) == far[49] == far[50] == 21 and far[0] == far[99] == 5


def test_concentric_disc_gives_a_full_ring_at_its_radius():
    ranges = scan_discs((1.0, -2.0), 0.7, [[1.0, -2.0]], [0.3])
    assert np.all(ranges == 0.3)  # b = 0: the exit root is √(r²) exactly
    grid = lgm_frame((1.0, -2.0), 0.7, [[1.0, -2.0]], [0.3], [0.2])
    assert cells(grid, 255) == {(row, 5) for row in range(M)}  # ⌊0.3/0.06⌋ = 5
    assert cells(grid, 127) == {(row, 8) for row in range(M)}  # ⌊0.5/0.06⌋ = 8


def test_inside_a_disc_the_range_is_still_the_minimum_over_discs():
    zone = ([0.5, 0.0], 0.8)  # contains the origin; exits 1.3 ahead, 0.6245 sideways
    ahead = ([1.0, 0.0], 0.2)  # entry at 0.8 ahead: nearer than the zone's exit
    left = ([0.0, 1.0], 0.2)  # entry at 0.8 on the left: farther than the exit (0.6245)
    other_zone = ([-0.2, 0.0], 0.6)  # contains the origin too; exits 0.4 ahead, 0.8 behind,
    # √(0.6² − 0.2²) = 0.5657 sideways
    discs = [zone, ahead, left, other_zone]
    ranges = scan_discs((0.0, 0.0), 0.0, [c for c, _ in discs], [r for _, r in discs])
    alone = [scan_discs((0.0, 0.0), 0.0, [c], [r]) for c, r in discs]
    assert np.array_equal(ranges, np.minimum.reduce(alone))
    assert ranges[899] == pytest.approx(0.4, abs=1e-5)  # the second zone's exit wins ahead
    assert ranges[0] == pytest.approx(0.3, abs=1e-5)  # the first zone's exit wins behind
    # Left: the nearer of the two exits wins; the disc on the left is farther than both.
    assert ranges[1349] == alone[3][1349] < alone[0][1349] < alone[2][1349] < L
    assert ranges[1349] == pytest.approx(math.sqrt(0.6**2 - 0.2**2), abs=2e-3)
    two = scan_discs((0.0, 0.0), 0.0, [zone[0], ahead[0]], [zone[1], ahead[1]])
    assert two[899] == pytest.approx(0.8, abs=1e-5)  # ahead: the nearer disc's entry wins
    assert two[0] == pytest.approx(0.3, abs=1e-5)
    # In the LGM: pedestrian body 0.3 + margin 0.5 (the zone) and the small disc ahead.
    grid = lgm_frame((0.0, 0.0), 0.0, [zone[0], ahead[0]], [0.3, 0.2], [0.5, 0.0])
    body = scan_discs((0.0, 0.0), 0.0, [zone[0], ahead[0]], [0.3, 0.2])
    collision = {(i // 18, int(body[i] / 0.06)) for i in np.flatnonzero(body < L)}
    assert cells(grid, 255) == collision
    assert cells(grid, 127) == {(i // 18, int(two[i] / 0.06)) for i in range(K)} - collision
    assert (49, 13) in cells(grid, 127) and (49, 21) not in cells(grid, 127)  # 0.8, not 1.3


def test_exit_beyond_max_range_returns_max_range():
    ranges = scan_discs((0.0, 0.0), 0.0, [[1.0, 0.0]], [5.5])  # exits: 6.5 ahead, 4.5 behind
    assert ranges[899] == ranges[900] == L
    assert ranges[0] == pytest.approx(4.5, abs=1e-5)
    np.testing.assert_allclose(ranges, disc_ranges_by_hand(1.0, 5.5, 0.0), atol=1e-12)
    assert np.all(scan_discs((0.0, 0.0), 0.0, [[0.2, 0.1]], [6.5]) == L)  # exits all > 6 m
    assert not lgm_frame((0.0, 0.0), 0.0, [[0.2, 0.1]], [6.5], [0.0]).any()


def test_origin_on_the_circle_keeps_the_smallest_positive_root():
    """d = r: the roots are 0 and 2b; 0 is not ahead of the LiDAR, so beams into the disc
    (b > 0) hit it at 2b where they leave it, the others miss."""
    ranges = scan_discs((0.0, 0.0), 0.0, [[0.3, 0.0]], [0.3])  # d² == r² exactly
    b = 0.3 * beam_table(K)[1]
    expected = np.where(b > 0.0, np.clip(2.0 * b, RMIN, L), L)
    np.testing.assert_allclose(ranges, expected, atol=1e-12)
    assert ranges[899] == pytest.approx(0.6, abs=1e-6)
    assert ranges[450] == RMIN and ranges[449] == L  # −89.9°: 2b ≈ 1e-3 m; −90.1°: behind
    assert np.all(ranges[:450] == L) and np.all(ranges[1350:] == L)


def test_near_hit_is_raised_to_min_range():
    ranges = scan_discs((0.0, 0.0), 0.0, polar(0.4, 0.0), [0.3])  # surface 0.1 m ahead
    assert ranges[899] == ranges[900] == RMIN
    assert ranges.min() == RMIN


def test_no_disc_gives_max_range_and_an_empty_map():
    ranges = scan_discs((1.0, 2.0), 0.3, np.zeros((0, 2)), [])
    assert ranges.shape == (K,) and np.all(ranges == L)
    for kind in ("lgm", "ogm"):
        grid = lgm_frame((1.0, 2.0), 0.3, [], [], [], kind=kind)
        assert grid.shape == (M, M) and grid.dtype == np.uint8 and not grid.any()


def test_hits_at_or_beyond_max_range_draw_nothing():
    ranges = scan_discs((0.0, 0.0), 0.0, polar(6.5, 10.0), [0.3])  # surface at 6.2 m
    assert np.all(ranges == L)
    assert not lgm_frame((0.0, 0.0), 0.0, polar(6.5, 10.0), [0.3], [0.0]).any()
    # Its discomfort margin reaches inside 6 m: only 127 cells, in the outer rings.
    grid = lgm_frame((0.0, 0.0), 0.0, polar(6.5, 10.0), [0.3], [0.5])
    assert cells(grid, 255) == set() and {c for _, c in cells(grid, 127)} <= {95, 96, 97, 98, 99}
    # A hand-made range exactly at max_range marks nothing either.
    edge = np.full(K, L)
    edge[0] = L - 1e-9
    assert cells(lgm_from_ranges(edge, np.full(K, L)), 255) == {(0, 99)}


# --------------------------------------------------------------------------- OGM


def test_ogm_single_disc_lands_at_the_hand_computed_cells():
    grid = lgm_frame((0.0, 0.0), 0.0, polar(2.0, 0.0), [0.3], [0.0], kind="ogm")
    # Beams 899/900: x ≈ 1.7, y ≈ ∓0.003 → row ⌊7.7/0.12⌋ = 64, columns 50 and 49.
    assert grid[64, 49] == 255 and grid[64, 50] == 255
    ranges = disc_ranges_by_hand(2.0, 0.3, 0.0)
    a = beam_angles(K)
    hit = ranges < L
    x, y = ranges[hit] * np.cos(a[hit]), ranges[hit] * np.sin(a[hit])
    rows = np.floor((x + L) / 0.12).astype(int)
    cols = np.floor((L - y) / 0.12).astype(int)
    assert cells(grid, 255) == set(zip(rows.tolist(), cols.tolist(), strict=True))
    # Left of the robot is a smaller column, ahead a larger row.
    left = lgm_frame((0.0, 0.0), 0.0, polar(2.0, 90.0), [0.3], [0.0], kind="ogm")
    assert {r for r, _ in cells(left, 255)} <= set(range(47, 53))
    # Hits have y from 1.70 (⌊4.30/0.12⌋ = 35) to ≈ 1.91 at the last beam before grazing (34).
    assert {c for _, c in cells(left, 255)} == {34, 35}


def test_ogm_from_ranges_clips_to_the_map_and_keeps_255():
    hit = np.full(K, L)
    inflated = np.full(K, L)
    hit[900] = 5.999  # x ≈ 5.999 → row 99
    inflated[900] = 5.0
    inflated[0] = 5.999  # just behind: x ≈ −5.999 → row 0
    grid = ogm_from_ranges(hit, inflated)
    assert grid[99, 49] == 255 and grid[0, 50] == 127
    assert np.count_nonzero(grid) == 3


# --------------------------------------------------------------------------- resolution


def test_paper_ring_one_example_lgm_100_cells_ogm_4():
    assert lgm_ring_cell_counts()[0] == 100
    assert ogm_cells_touched_by_disc(L / M) == 4
    assert ogm_ring_cell_counts()[0] == 4
    # Count the same geometrically: sample the ring-1 disc densely, map with the OGM indices.
    rng = np.random.default_rng(0)
    rho = (L / M) * np.sqrt(rng.uniform(0.0, 1.0, 200_000))
    phi = rng.uniform(-math.pi, math.pi, rho.size)
    x, y = rho * np.cos(phi), rho * np.sin(phi)
    rows = np.clip(np.floor((x + L) / (2 * L / M)), 0, M - 1)
    cols = np.clip(np.floor((L - y) / (2 * L / M)), 0, M - 1)
    assert len(set(zip(rows.tolist(), cols.tolist(), strict=True))) == 4


def test_eq2_and_the_mean_resolutions():
    assert lgm_resolution(1) == pytest.approx(K * M**2 / (math.pi * L**2))
    assert lgm_resolution(1) == pytest.approx(159_154.943, rel=1e-8)
    assert lgm_resolution(100) == pytest.approx(159_154.943 / 199, rel=1e-8)
    for ring in (1, 13, 50, 100):  # Eq. 2 = (K/M beams) / (cell area)
        assert lgm_resolution(ring) * lgm_cell_area(ring) == pytest.approx(K / M)
    # The rings tile the disc of radius L.
    assert sum(M * lgm_cell_area(i) for i in range(1, M + 1)) == pytest.approx(math.pi * L**2)
    assert ogm_resolution() == pytest.approx((100 / 12) ** 2)
    assert lgm_mean_resolution() == pytest.approx(M**2 / (math.pi * L**2))
    assert lgm_mean_resolution() > ogm_resolution()
    with pytest.raises(ValueError):
        lgm_resolution(0)


def test_crossing_ring_under_each_reading_of_the_paper():
    """The paper claims the OGM is denser for i > 13; only half-size OGM cells give that."""
    crossings = resolution_crossing_rings()
    assert crossings == {
        "cell_density": 65,  # 2i − 1 > 4M/π
        "eq2_vs_ogm_resolution": None,  # would need 2i − 1 > 4K/π, beyond ring 100
        "cells_overlapping_ring": 21,  # first above 100 at ring 19, for good from 21
        "cells_crossed_by_mid_circle": 27,  # 8⌊(2i − 1)/4⌋ + 4 > 100
        "cells_crossed_by_mid_circle_half_cell": 14,  # 8(i − ½) > 100 ⇔ i > 13
    }
    overlap = ogm_ring_cell_counts()
    assert overlap[18] > 100 and overlap[19] <= 100  # rings 19 and 20
    mid = ogm_ring_circle_cell_counts()
    assert mid.tolist() == [8 * ((2 * i - 1) // 4) + 4 for i in range(1, M + 1)]
    half = ogm_ring_circle_cell_counts(cell_size=L / M)
    assert half[12] == 100 and half[13] == 108


# --------------------------------------------------------------------------- frame stack


def test_frame_stack_reset_and_push():
    stack = FrameStack(9, 100)
    frames = [np.full((M, M), v, dtype=np.uint8) for v in range(1, 12)]
    s = stack.reset(frames[0])
    assert s.shape == (9, M, M) and s.dtype == np.uint8
    assert np.all(s == 1)
    for v in range(1, 4):
        s = stack.push(frames[v])
    assert s[:, 0, 0].tolist() == [1, 1, 1, 1, 1, 1, 2, 3, 4]  # oldest first, newest last
    for v in range(4, 11):
        s = stack.push(frames[v])
    assert s[:, 0, 0].tolist() == [3, 4, 5, 6, 7, 8, 9, 10, 11]
    s[:] = 0  # a copy: the stack is not changed
    assert stack.array[-1, 0, 0] == 11
    with pytest.raises(ValueError):
        stack.push(np.zeros((M, M), dtype=np.float32))
    with pytest.raises(ValueError):
        stack.push(np.zeros((M, M + 1), dtype=np.uint8))


# --------------------------------------------------------------------------- reference


def frame_per_beam(
    origin, heading, centers, radii, margins, num_beams=K, grid_size=M, kind="lgm"
) -> np.ndarray:
    """Per-beam grid frame from `ranges_per_beam`: 255 real hits, then 127 where not 255."""
    centers = np.asarray(centers, dtype=float).reshape(-1, 2)
    inflated = [float(r) + float(m) for r, m in zip(radii, margins, strict=True)]
    hit = ranges_per_beam(origin, heading, centers, radii, num_beams)
    infl = ranges_per_beam(origin, heading, centers, inflated, num_beams)
    step = 0.003490659 if num_beams == 1800 else 2.0 * math.pi / num_beams
    grid = np.zeros((grid_size, grid_size), dtype=np.uint8)
    for value, ranges in ((255, hit), (127, infl)):
        for i, rng in enumerate(ranges):
            if rng >= L:
                continue
            if kind == "lgm":
                row = i // (num_beams // grid_size)
                col = min(int(rng / (L / grid_size)), grid_size - 1)
            else:
                angle = (i - (num_beams - 1) / 2) * step
                x, y = rng * math.cos(angle), rng * math.sin(angle)
                cell = 2.0 * L / grid_size
                row = min(max(math.floor((x + L) / cell), 0), grid_size - 1)
                col = min(max(math.floor((L - y) / cell), 0), grid_size - 1)
            if value == 127 and grid[row, col] == 255:
                continue
            grid[row, col] = value
    return grid


def random_scene(rng: np.random.Generator):
    origin = rng.uniform(-5.0, 5.0, 2)
    heading = rng.uniform(-math.pi, math.pi)
    n = int(rng.integers(0, 9))
    distance = rng.choice(
        [rng.uniform(0.0, 1.2), rng.uniform(0.5, 6.0), rng.uniform(5.5, 7.5)], size=n
    )
    bearing = np.where(
        rng.uniform(size=n) < 0.3,
        math.pi + rng.normal(0.0, 0.05, n),  # straddling the seam behind the robot
        rng.uniform(-math.pi, math.pi, n),
    )
    centers = (
        origin + np.c_[distance * np.cos(heading + bearing), distance * np.sin(heading + bearing)]
    )
    radii = rng.uniform(0.1, 0.6, n)
    margins = rng.choice([0.0, 0.2, 0.35, 0.5], size=n)
    return origin, heading, centers, radii, margins


def test_fast_frame_equals_the_per_beam_reference_on_random_scenes():
    rng = np.random.default_rng(2024)
    for trial in range(70):
        scene = random_scene(rng)
        kind = "ogm" if trial % 5 == 4 else "lgm"
        fast = lgm_frame(*scene, kind=kind)
        ref = frame_per_beam(*scene, kind=kind)
        assert np.array_equal(fast, ref), f"trial {trial} ({kind}) differs"


def test_fast_frame_equals_reference_for_edge_cases():
    cases = [
        ([[0.3, 0.0]], [0.3], [0.2]),  # origin on the circle; inside the inflated disc
        ([[0.55, 0.0]], [0.3], [0.25]),  # origin on the inflated circle
        ([[0.5, 0.0]], [0.3], [0.5]),  # inside the discomfort zone only
        ([[0.1, 0.05]], [0.3], [0.2]),  # inside both
        ([[0.0, 0.0]], [0.3], [0.2]),  # concentric
        ([[0.5, 0.0], [1.0, 0.0], [-0.2, 0.0]], [0.3, 0.2, 0.3], [0.5, 0.0, 0.3]),  # mixed
        ([[1.0, 0.0]], [5.5], [0.0]),  # inside, some exits beyond max range
        ([[6.3, 0.0]], [0.3], [0.0]),  # nearest surface exactly at max range
        ([[-2.0, 0.0], [-2.0, 1e-3]], [0.3, 0.3], [0.5, 0.2]),  # overlapping, behind
        ([[0.31, 0.0]], [0.3], [0.0]),  # 1 cm away: nearly 180° wide
        ([[-0.31, 1e-4]], [0.3], [0.1]),  # same, behind across the seam; inside inflated
    ]
    for centers, radii, margins in cases:
        for kind in ("lgm", "ogm"):
            fast = lgm_frame((0.0, 0.0), 0.0, centers, radii, margins, kind=kind)
            ref = frame_per_beam((0.0, 0.0), 0.0, centers, radii, margins, kind=kind)
            assert np.array_equal(fast, ref), (centers, kind)
    # The scans themselves, bit for bit, also for a beam count other than 1800.
    for centers, radii, _ in cases:
        for k in (1800, 360):
            fast = scan_discs((0.0, 0.0), 0.0, centers, radii, num_beams=k)
            assert fast.tolist() == ranges_per_beam((0.0, 0.0), 0.0, centers, radii, k)


# --------------------------------------------------------------------------- validation


def test_bad_inputs_raise_value_error():
    ok = dict(centers=[[2.0, 0.0]], radii=[0.3], margins=[0.2])
    with pytest.raises(ValueError, match="origin_xy"):
        lgm_frame((math.nan, 0.0), 0.0, **ok)
    with pytest.raises(ValueError, match="heading"):
        lgm_frame((0.0, 0.0), math.inf, **ok)
    with pytest.raises(ValueError, match="radii"):
        lgm_frame((0.0, 0.0), 0.0, [[2.0, 0.0]], [0.3, 0.3], [0.2])
    with pytest.raises(ValueError, match="margins"):
        lgm_frame((0.0, 0.0), 0.0, [[2.0, 0.0]], [0.3], [0.2, 0.1])
    with pytest.raises(ValueError, match="centers"):
        lgm_frame((0.0, 0.0), 0.0, [[2.0, 0.0, 1.0]], [0.3], [0.2])
    with pytest.raises(ValueError, match="divisible"):
        lgm_frame((0.0, 0.0), 0.0, **ok, num_beams=1000, grid_size=300)
    with pytest.raises(ValueError, match="kind"):
        lgm_frame((0.0, 0.0), 0.0, **ok, kind="pie")
    with pytest.raises(ValueError, match="radii"):
        scan_discs((0.0, 0.0), 0.0, [[1.0, 0.0]], [math.nan])
    with pytest.raises(ValueError, match="beams"):
        lgm_from_ranges(np.full(K, L), np.full(K - 1, L))
    with pytest.raises(ValueError, match="finite"):
        lgm_from_ranges(np.full(K, math.nan), np.full(K, L))
    with pytest.raises(ValueError, match="divisible"):
        lgm_from_ranges(np.full(1000, L), np.full(1000, L), grid_size=300)
    with pytest.raises(ValueError, match="out"):
        lgm_frame((0.0, 0.0), 0.0, **ok, out=np.zeros((M, M), dtype=np.int32))


def test_out_argument_is_filled_in_place():
    out = np.full((M, M), 7, dtype=np.uint8)
    grid = lgm_frame((0.0, 0.0), 0.0, polar(2.0, 0.0), [0.3], [0.2], out=out)
    assert grid is out
    assert np.array_equal(out, lgm_frame((0.0, 0.0), 0.0, polar(2.0, 0.0), [0.3], [0.2]))


# --------------------------------------------------------------------------- figure


@pytest.mark.slow
def test_grid_map_figure_writes_a_png(tmp_path):
    from emonav_drake.evaluation.grid_map_figure import render_grid_map_figure

    path = render_grid_map_figure(
        tmp_path / "fig" / "grid_maps.png",
        (-1.0, 0.2),
        0.3,
        [[0.5, 0.8], [1.5, -1.0], [-1.0, -1.5]],
        [0.3, 0.3, 0.4],
        [0.2, 0.5, 0.2],
        [1, 1, 0],
        goal_xy=(4.0, 0.0),
    )
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 10_000
