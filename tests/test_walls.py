"""Walls (line segments): ORCA pedestrians respect them, the LiDAR sees them, the robot
collides with them, planners get a disc chain, the LiDAR detector cuts them into pieces.

Frames: world (x towards the robot's goal, y left), metres, seconds.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from emonav_drake.crowd.crowd import Crowd, CrowdSnapshot
from emonav_drake.crowd.orca import OrcaParams, orca_velocities
from emonav_drake.evaluation.failures import failure_cause
from emonav_drake.evaluation.trial_check import check_trial
from emonav_drake.navigation.metrics import EpisodeTracker
from emonav_drake.navigation.observations import observation_frame
from emonav_drake.navigation.reward import evaluate_step
from emonav_drake.params import EmoNavConfig
from emonav_drake.robot.lip import LipState
from emonav_drake.scenarios.scenario import PedestrianSpec, Scenario, WallSpec
from emonav_drake.scenarios.walls import point_segment_distances, wall_discs
from emonav_drake.sensing.crowd_tracker import CrowdTracker
from emonav_drake.sensing.grid_maps import COLLISION_VALUE, DISCOMFORT_VALUE, lgm_frame
from emonav_drake.sensing.lidar import beam_angles, cast_robot_frame, scan_discs
from emonav_drake.sensing.lidar_objects import DetectionParams, detect_objects

CFG = EmoNavConfig()
ANGLES = beam_angles()
# A wall across x = 0 with a door |y| < 0.7, and a corridor |y| < 1 for x in [-3, 3].
DOOR_WALL = np.array([[[0.0, -6.0], [0.0, -0.7]], [[0.0, 0.7], [0.0, 6.0]]])
CORRIDOR = np.array([[[-3.0, 1.0], [3.0, 1.0]], [[-3.0, -1.0], [3.0, -1.0]]])


def _beam(angle: float) -> int:
    """Index of the beam nearest `angle` [rad] from the heading."""
    return int(np.argmin(np.abs(ANGLES - angle)))


def _crosses(p: np.ndarray, q: np.ndarray, seg: np.ndarray) -> np.ndarray:
    """(n,) whether the moves p → q (n, 2) cross the segment seg (2, 2) (proper crossing)."""
    a, b = seg

    def side(u, v, w):
        return (v[..., 0] - u[..., 0]) * (w[..., 1] - u[..., 1]) - (v[..., 1] - u[..., 1]) * (
            w[..., 0] - u[..., 0]
        )

    return (np.sign(side(a, b, p)) * np.sign(side(a, b, q)) < 0) & (
        np.sign(side(p, q, a)) * np.sign(side(p, q, b)) < 0
    )


def _min_wall_distance(points: np.ndarray, walls: np.ndarray) -> float:
    return min(float(point_segment_distances(x, walls).min()) for x in points)


# ------------------------------------------------------------------------------ ORCA


def _random_crowd(rng: np.random.Generator, n: int = 8) -> tuple:
    pos = rng.uniform(-4.0, 4.0, (n, 2))
    vel = rng.uniform(-1.0, 1.0, (n, 2))
    pref = rng.uniform(-1.2, 1.2, (n, 2))
    radii = rng.uniform(0.25, 0.45, n)
    vmax = rng.uniform(0.6, 1.4, n)
    discs = rng.uniform(-4.0, 4.0, (3, 2)), rng.uniform(0.2, 0.5, 3)
    return pos, vel, radii, pref, vmax, discs


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_orca_without_walls_is_bit_identical(seed: int) -> None:
    """No segments, None, an empty array and walls out of every agent's range all give
    exactly the velocities of the call without the option, step after step."""
    rng = np.random.default_rng(seed)
    pos, vel, radii, pref, vmax, (oc, orad) = _random_crowd(rng)
    far = np.array([[[900.0, 900.0], [905.0, 901.0]]])
    for _ in range(30):
        base = orca_velocities(pos, vel, radii, pref, vmax, 0.1, OrcaParams(), oc, orad)
        for segs in (None, np.zeros((0, 2, 2)), far):
            got = orca_velocities(
                pos, vel, radii, pref, vmax, 0.1, OrcaParams(), oc, orad, obstacle_segments=segs
            )
            assert np.array_equal(got, base)
        pos, vel = pos + 0.1 * base, base


def test_orca_wall_ahead_limits_the_approach_to_the_horizon() -> None:
    """A wall 2 m ahead, radius 0.5, horizon 2 s: the velocity towards it is cut to the
    speed that reaches it at the horizon, (2 − 0.5) / 2 = 0.75 m/s (the cut-off line)."""
    wall = np.array([[[-5.0, 2.0], [5.0, 2.0]]])
    params = OrcaParams(time_horizon_obst=2.0)
    v = orca_velocities(
        np.zeros((1, 2)),
        np.array([[0.0, 1.0]]),
        np.array([0.5]),
        np.array([[0.0, 1.0]]),
        np.array([1.0]),
        0.1,
        params,
        obstacle_segments=wall,
    )
    np.testing.assert_allclose(v, [[0.0, 0.75]], atol=1e-12)
    # Out of range (distance 2 >= horizon · speed + radius = 0.6 · 1 + 0.5): no effect.
    v = orca_velocities(
        np.zeros((1, 2)),
        np.array([[0.0, 1.0]]),
        np.array([0.5]),
        np.array([[0.0, 1.0]]),
        np.array([1.0]),
        0.1,
        OrcaParams(time_horizon_obst=0.6),
        obstacle_segments=wall,
    )
    np.testing.assert_array_equal(v, [[0.0, 1.0]])


def test_orca_agent_touching_a_wall_only_moves_along_or_away() -> None:
    """Overlapping the wall (0.2 m < radius 0.3): the line through the zero velocity
    parallel to the wall forbids any velocity towards it, from either side."""
    for side in (1.0, -1.0):
        wall = np.array([[[-5.0, 0.2 * side], [5.0, 0.2 * side]]])
        v = orca_velocities(
            np.zeros((1, 2)),
            np.zeros((1, 2)),
            np.array([0.3]),
            np.array([[0.6, 0.6 * side]]),
            np.array([1.0]),
            0.1,
            obstacle_segments=wall,
        )
        np.testing.assert_allclose(v, [[0.6, 0.0]], atol=1e-12)


def test_orca_agent_on_the_wall_line_stops_at_its_end() -> None:
    """Walking exactly along a wall's line into its end (RVO2 would ignore the wall there,
    `crowd/orca_walls.py`): the agent stops a radius short of it."""
    wall = np.array([[[0.0, 0.0], [5.0, 0.0]]])
    rng = np.random.default_rng(0)
    _, closest, end = _walk(np.array([[-3.0, 0.0]]), np.array([[8.0, 0.0]]), wall, 300, rng)
    assert closest >= 0.3 - 1e-6 and end[0, 0] < 0.0


def test_orca_bad_segments_are_refused() -> None:
    args = (np.zeros((1, 2)), np.zeros((1, 2)), [0.3], np.zeros((1, 2)), [1.0], 0.1)
    with pytest.raises(ValueError, match="obstacle_segments must have shape"):
        orca_velocities(*args, obstacle_segments=np.zeros((2, 4)))
    with pytest.raises(ValueError, match="zero length"):
        orca_velocities(*args, obstacle_segments=[[[1.0, 1.0], [1.0, 1.0]]])
    with pytest.raises(ValueError, match="finite"):
        orca_velocities(*args, obstacle_segments=[[[1.0, 1.0], [math.nan, 1.0]]])


def _walk(pos, goals, walls, steps, rng, radius=0.3, dt=0.1) -> tuple[int, float, np.ndarray]:
    """Integrate ORCA with walls: (wall crossings, smallest centre–wall distance, end)."""
    n = len(pos)
    vel = np.zeros((n, 2))
    radii = np.full(n, radius)
    vmax = rng.uniform(0.8, 1.2, n)
    crossings, closest = 0, math.inf
    for _ in range(steps):
        to_goal = goals - pos
        dist = np.hypot(to_goal[:, 0], to_goal[:, 1])
        speed = np.minimum(vmax, dist / dt)
        pref = to_goal * (speed / np.maximum(dist, 1e-9))[:, None]
        vel = orca_velocities(pos, vel, radii, pref, vmax, dt, obstacle_segments=walls)
        new = pos + dt * vel
        crossings += sum(int(_crosses(pos, new, w).sum()) for w in walls)
        pos = new
        closest = min(closest, _min_wall_distance(pos, walls))
    return crossings, closest, pos


@pytest.mark.slow
def test_orca_pedestrians_pass_the_door_never_the_wall() -> None:
    """Pedestrians whose goals are behind a wall with a door: over 120 s none crosses the
    wall, none comes closer to it than its radius, and they do get through the door."""
    rng = np.random.default_rng(7)
    n = 6
    left = np.column_stack([rng.uniform(-5.0, -1.5, n), rng.uniform(-3.0, 3.0, n)])
    goals = np.column_stack([rng.uniform(1.5, 5.0, n), rng.uniform(-3.0, 3.0, n)])
    crossings, closest, end = _walk(left, goals, DOOR_WALL, 1200, rng)
    assert crossings == 0
    assert closest >= 0.3 - 1e-6
    assert (end[:, 0] > 0.0).sum() >= 2  # through the door, not stuck behind the wall


def test_orca_pedestrians_stay_in_the_corridor() -> None:
    """Pedestrians walking both ways along a corridor 2 m wide never leave it."""
    rng = np.random.default_rng(11)
    start = np.array([[-2.5, -0.4], [-2.0, 0.45], [2.5, 0.3], [2.0, -0.5]])
    goals = np.array([[2.8, 0.5], [2.8, -0.4], [-2.8, -0.5], [-2.8, 0.4]])
    crossings, closest, end = _walk(start, goals, CORRIDOR, 600, rng)
    assert crossings == 0
    assert closest >= 0.3 - 1e-6
    assert np.all(np.abs(end[:, 1]) <= 1.0 - 0.3 + 1e-6)
    assert np.all(np.sign(end[:, 0]) == np.sign(goals[:, 0]))  # they got past each other


def test_crowd_pedestrians_respect_walls() -> None:
    """Through `Crowd.step` (needs the walls passed to ORCA in `crowd/crowd.py`): with the
    robot far away, pedestrians whose straight routes run into a wall with a door, or
    past the door's edge, never cross the wall over 90 s; the latter get through the door."""
    routes = [([-3.0, 2.0], [3.0, 2.2]), ([-3.0, -1.8], [3.0, -2.5])]  # into the wall
    routes += [([-3.0, 1.0], [3.0, 0.3]), ([-3.0, -1.0], [3.0, -0.2])]  # by the door's edge
    peds = [PedestrianSpec(start=a, goal=b, emotion="neutral") for a, b in routes]
    walls = [WallSpec(start=a.tolist(), end=b.tolist()) for a, b in DOOR_WALL]
    scenario = Scenario(pedestrians=peds, obstacles=[], walls=walls)
    crowd = Crowd(scenario, CFG)
    state = crowd.initial_state()
    robot = np.array([50.0, 50.0])
    crossings, through = 0, np.zeros(len(routes), dtype=bool)
    for _ in range(900):
        new = crowd.step(state, robot, np.zeros(2))
        crossings += sum(int(_crosses(state.positions, new.positions, w).sum()) for w in DOOR_WALL)
        through |= (state.positions[:, 0] < 0.0) & (new.positions[:, 0] >= 0.0)
        state = new
    assert crossings == 0
    assert _min_wall_distance(state.positions, DOOR_WALL) >= CFG.crowd.pedestrian_radius - 1e-6
    assert through[2:].all()  # the door is used, not simply blocked


# ------------------------------------------------------------------------------ LiDAR


def test_a_wall_stops_lidar_rays() -> None:
    """A wall 2 m ahead (|y| ≤ 1) in front of a disc 4 m ahead: the beams that cross the
    wall read its range 2 / cos(angle), not the disc behind it; the wall is seen from both
    sides; beams past its ends still reach the disc beside it."""
    wall = [[[2.0, -1.0], [2.0, 1.0]]]
    discs = [[4.0, 0.0], [4.0, 2.5]], [0.3, 0.3]
    ranges = scan_discs((0.0, 0.0), 0.0, *discs, segments=wall)
    alone = scan_discs((0.0, 0.0), 0.0, *discs)
    ahead = _beam(0.0)
    assert alone[ahead] == pytest.approx(4.0 - 0.3, abs=1e-3)
    inside = np.abs(np.tan(ANGLES)) * 2.0 < 0.99
    inside &= np.cos(ANGLES) > 0.0
    np.testing.assert_allclose(ranges[inside], 2.0 / np.cos(ANGLES[inside]), rtol=1e-12)
    side = _beam(math.atan2(2.5, 4.0))  # the disc beside the wall
    assert ranges[side] == alone[side] < 6.0
    back = scan_discs((4.0, 0.5), math.pi, [], [], segments=wall)
    assert back[_beam(0.0)] == pytest.approx(2.0, abs=1e-3)


def test_lidar_without_walls_is_bit_identical() -> None:
    rng = np.random.default_rng(3)
    for _ in range(20):
        centers = rng.uniform(-5.0, 5.0, (6, 2))
        radii = rng.uniform(0.1, 1.0, 6)
        origin, heading = rng.uniform(-2.0, 2.0, 2), float(rng.uniform(-3.0, 3.0))
        base = scan_discs(origin, heading, centers, radii)
        for segs in (None, np.zeros((0, 2, 2))):
            assert np.array_equal(scan_discs(origin, heading, centers, radii, segments=segs), base)
        margins = rng.uniform(0.0, 0.5, 6)
        grid = lgm_frame(origin, heading, centers, radii, margins)
        assert np.array_equal(
            lgm_frame(origin, heading, centers, radii, margins, segments=np.zeros((0, 2, 2))), grid
        )


def test_wall_band_in_the_inflated_scan() -> None:
    """With a half-width the wall is a band: entry point outside it, exit point inside,
    and the half circle round its end."""
    k = len(ANGLES)
    left, ahead, right = _beam(math.pi / 2), _beam(0.0), _beam(-math.pi / 2)
    empty = np.zeros(0)

    def cast(walls, h):
        walls = np.asarray(walls, float)
        return cast_robot_frame(
            empty, empty, np.zeros((1, 0)), k, 6.0, 0.0, segments=walls,
            segment_half_widths=np.full((1, len(walls)), h),
        )[0]  # fmt: skip

    out = cast([[[-5.0, 1.0], [5.0, 1.0]]], 0.2)
    assert out[left] == pytest.approx(0.8, abs=1e-5)
    inside = cast([[[-5.0, 0.1], [5.0, 0.1]]], 0.2)  # the LiDAR inside the band
    assert inside[left] == pytest.approx(0.3, abs=1e-5)
    assert inside[right] == pytest.approx(0.1, abs=1e-5)
    end = cast([[[1.0, 0.0], [3.0, 0.0]]], 0.2)  # end-on: the half circle round (1, 0)
    assert end[ahead] == pytest.approx(0.8, abs=1e-5)
    # Zero width: beams ±0.1° off a wall's line miss it; a slanted wall is hit where crossed.
    assert cast([[[1.0, 0.0], [3.0, 0.0]]], 0.0)[ahead] == 6.0
    assert cast([[[1.0, -0.5], [3.0, 0.5]]], 0.0)[ahead] == pytest.approx(2.0, abs=0.01)


def test_observations_see_walls() -> None:
    """The policy's scan and grid map show a wall (255 at it, 127 in its band)."""
    snap = CrowdSnapshot(
        positions=np.zeros((0, 2)),
        velocities=np.zeros((0, 2)),
        radius=0.3,
        emotions=np.zeros(0, dtype=int),
        discomfort=np.zeros(0),
        static_centers=np.zeros((0, 2)),
        static_radii=np.zeros(0),
        static_discomfort=0.2,
        wall_segments=np.array([[[3.0, -2.0], [3.0, 2.0]]]),
    )
    robot = LipState(0.0, 0.0, 0.0, 0.0)
    scan = observation_frame(robot, snap, CFG, "scan")
    assert scan[_beam(0.0)] == pytest.approx(3.0, abs=1e-3)
    lgm = observation_frame(robot, snap, CFG, "lgm")
    li = CFG.lidar
    sector = li.grid_size // 2
    ring = li.max_range / li.grid_size
    assert lgm[sector, int(3.0 / ring)] == COLLISION_VALUE
    assert lgm[sector, int(2.8 / ring)] == DISCOMFORT_VALUE


def test_lidar_system_scans_walls() -> None:
    """The diagram's `LidarGridMapBuilder` (scan port and map stack) sees the crowd's walls."""
    from pydrake.common.value import AbstractValue

    from emonav_drake.systems.lidar_grid_map_builder import LidarGridMapBuilder

    snap = _snapshot([[[3.0, -2.0], [3.0, 2.0]]])
    system = LidarGridMapBuilder(CFG, "scan")
    ctx = system.CreateDefaultContext()
    system.GetInputPort("robot_state").FixValue(ctx, np.zeros(4))
    system.GetInputPort("crowd").FixValue(ctx, AbstractValue.Make(snap))
    scan = system.GetOutputPort("scan").Eval(ctx)
    assert scan[_beam(0.0)] == pytest.approx(3.0, abs=1e-3)
    stack = system.GetOutputPort("lgm_stack").Eval(ctx)
    assert stack[-1, _beam(0.0)] == pytest.approx(3.0, abs=1e-3)


def test_tracking_study_counts_a_pedestrian_behind_a_wall_as_occluded() -> None:
    from emonav_drake.evaluation.scan_visibility import OCCLUDED, VISIBLE, visibility

    robot, peds = np.zeros(2), np.array([[3.0, 0.0]])
    args = (robot, 0.0, peds, 0.3, np.zeros((0, 2)), [], CFG)
    assert visibility(*args)[2][0] == VISIBLE
    wall = np.array([[[1.5, -1.0], [1.5, 1.0]]])
    own, vis, cat = visibility(*args, wall_segments=wall)
    assert own[0] > 0 and vis[0] == 0 and cat[0] == OCCLUDED


# ------------------------------------------------------------------------------ reward


def _snapshot(walls) -> CrowdSnapshot:
    return CrowdSnapshot(
        positions=np.array([[3.0, 3.0]]),
        velocities=np.zeros((1, 2)),
        radius=0.3,
        emotions=np.array([1]),
        discomfort=np.array([0.35]),
        static_centers=np.array([[-3.0, 3.0]]),
        static_radii=np.array([0.4]),
        static_discomfort=0.2,
        wall_segments=np.asarray(walls, float).reshape(-1, 2, 2),
    )


def _evaluate(robot, walls):
    return evaluate_step(
        np.asarray(robot, float), np.array([8.0, 0.0]), 9.0, _snapshot(walls), 0.3, 0.2, CFG.reward
    )


def test_robot_collides_with_a_wall() -> None:
    wall = [[[-2.0, 0.25], [2.0, 0.25]]]
    ev = _evaluate([0.0, 0.0], wall)  # centre 0.25 m from the wall <= robot radius 0.3
    assert ev.collision and ev.collided_with == "wall"
    assert ev.reward == pytest.approx(CFG.reward.collision + CFG.reward.progress_gain * 1.0)
    end_on = _evaluate([-2.28, 0.25], wall)  # 0.28 m from the wall's end
    assert end_on.collision and end_on.collided_with == "wall"
    near = _evaluate([0.0, -0.2], wall)  # 0.45 m: in the wall's discomfort zone (0.2 + 0.3)
    assert not near.collision and near.in_discomfort and near.idt == (1, 0, 0, 0)
    progress = CFG.reward.progress_gain * (9.0 - math.hypot(8.0, 0.2))
    assert near.reward == pytest.approx(CFG.reward.discomfort + progress)
    clear = _evaluate([0.0, -0.3], wall)  # 0.55 m: nothing
    assert not clear.collision and not clear.in_discomfort


def test_wall_collision_is_recorded_like_any_collision() -> None:
    """`collided_with` "wall" reaches the episode record, the trial check and the causes."""
    tracker = EpisodeTracker(10, CFG.robot.step_time, seed=0)
    assert tracker.add(_evaluate([0.0, 0.0], [[[-2.0, 0.25], [2.0, 0.25]]]), 0.1) == "collision"
    record = tracker.record.to_json()
    assert record["collided_with"] == "wall"
    assert check_trial({"method": "dwa", "seed": 0, "record": record}) is None
    assert failure_cause(record) == "collision: wall"


def test_far_wall_changes_no_reward() -> None:
    for robot in ([0.0, 0.0], [2.7, 2.9], [-2.5, 3.0]):
        assert _evaluate(robot, [[[90.0, 0.0], [95.0, 0.0]]]) == _evaluate(robot, [])


# ------------------------------------------------------------------------------ disc chain


def test_wall_discs_cover_the_wall() -> None:
    walls = np.array([[[0.0, 0.0], [3.05, 0.0]], [[1.0, 1.0], [1.0, 1.5]]])
    centers, radii = wall_discs(walls, spacing=0.2)
    assert np.all(radii > 0.0) and np.all(radii <= 0.1 + 1e-12)
    for a, b in walls:
        for f in np.linspace(0.0, 1.0, 301):
            p = a + f * (b - a)
            assert np.min(np.hypot(*(centers - p).T) - radii) <= 1e-12
    first = centers[:17]  # wall 0: ⌈3.05 / 0.2⌉ + 1 = 17 discs, touching neighbours
    gaps = np.hypot(*np.diff(first, axis=0).T)
    np.testing.assert_allclose(gaps, 2.0 * radii[:16])
    assert wall_discs(np.zeros((0, 2, 2)))[0].shape == (0, 2)
    with pytest.raises(ValueError, match="spacing"):
        wall_discs(walls, spacing=0.0)


# ------------------------------------------------------------------------------ detector


def test_detector_cuts_a_wall_into_fixed_pieces() -> None:
    """A corridor seen from inside: every wall cluster becomes pieces (flagged) on the
    wall line, of bounded radius, that do not move when the robot does; the pedestrian
    stays one disc."""
    params = DetectionParams()
    peds = np.array([[2.0, 0.0]]), [0.3]
    seen = []
    for x in (-2.0, -1.6, -1.1):
        xy = np.array([x, 0.0])
        det = detect_objects(scan_discs(xy, 0.0, *peds, segments=CORRIDOR), xy, 0.0, 6.0, params)
        pieces = det.centers[det.walls]
        assert len(pieces) >= 10
        assert np.all(det.radii <= params.max_radius)
        np.testing.assert_allclose(np.abs(pieces[:, 1]), 1.0, atol=1e-9)
        others = det.centers[~det.walls]
        assert len(others) == 1 and np.hypot(*(others[0] - peds[0][0])) < 0.1
        seen.append({tuple(np.round(c, 9)) for c in pieces if -1.5 < c[0] < 0.5})
    # The stretch x in [-1.5, 0.5] of both walls: the same 2 × 4 pieces from each place.
    assert len(seen[0]) == 8 and seen[0] == seen[1] == seen[2]


def test_detector_unchanged_without_walls() -> None:
    """Scenes of pedestrians and small discs: the wall step finds nothing, the result is
    exactly the one with the wall step switched off."""
    off = DetectionParams(wall_min_length=1e6)
    rng = np.random.default_rng(5)
    for _ in range(30):
        centers = rng.uniform(-5.0, 5.0, (8, 2))
        radii = rng.uniform(0.2, 0.45, 8)
        xy = rng.uniform(-1.0, 1.0, 2)
        ranges = scan_discs(xy, 0.3, centers, radii)
        a = detect_objects(ranges, xy, 0.3, 6.0)
        b = detect_objects(ranges, xy, 0.3, 6.0, off)
        assert not a.walls.any()
        assert np.array_equal(a.centers, b.centers) and np.array_equal(a.radii, b.radii)


def test_tracker_sees_corridor_walls_as_static_objects() -> None:
    """The robot walks 6 s along an empty corridor: once the tracker's still time has
    passed, every confirmed track is a still (static) object of bounded radius."""
    tracker = CrowdTracker()
    dt = CFG.crowd.dt
    for k in range(60):
        t = k * dt
        xy = np.array([-2.5 + 0.5 * t, 0.1])
        tracker.update(
            t, detect_objects(scan_discs(xy, 0.0, [], [], segments=CORRIDOR), xy, 0.0, 6.0)
        )
    tracks = tracker.tracks()
    assert len(tracks) >= 10
    assert all(tracker.is_static(tr) for tr in tracks)
    assert all(tr.radius <= DetectionParams().max_radius for tr in tracks)
    assert _min_wall_distance(np.array([tr.x[:2] for tr in tracks]), CORRIDOR) < 1e-6


def test_tracker_never_reports_a_wall_piece_as_a_pedestrian() -> None:
    """From the first scan on, a track on a wall piece is static: the crowd a planner
    reads from the tracker holds no pedestrian in an empty corridor at any time."""
    tracker = CrowdTracker()
    dt = CFG.crowd.dt
    seen = []
    for k in range(30):
        t = k * dt
        xy = np.array([-2.5 + 0.5 * t, 0.1])
        tracker.update(
            t, detect_objects(scan_discs(xy, 0.0, [], [], segments=CORRIDOR), xy, 0.0, 6.0)
        )
        snap = tracker.snapshot(np.zeros((0, 2)), np.zeros(0, int), np.zeros(3), 0.3, 0.2, 1)
        seen.append((len(snap.positions), len(snap.static_radii)))
    assert all(p == 0 for p, _ in seen)
    assert seen[-1][1] >= 10
