"""Objects detected in the real 1800-beam LiDAR scan, and tracked across scans.

Every scan here is `sensing.lidar.scan_discs`; crowds are the real ORCA `Crowd` where the
pedestrians' motion matters, scripted constant-velocity walks where the test needs an
exact straight line (a crossing, a velocity truth).
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from emonav_drake.crowd.crowd import Crowd
from emonav_drake.params import HAPPY, NEGATIVE, NEUTRAL, EmoNavConfig
from emonav_drake.scenarios.scenario import (
    PedestrianSpec,
    Scenario,
    StaticDiscSpec,
    sample_scenario,
)
from emonav_drake.sensing.crowd_tracker import CrowdTracker, Track, TrackerParams
from emonav_drake.sensing.lidar import scan_discs
from emonav_drake.sensing.lidar_objects import DetectionParams, Detections, detect_objects

CFG = EmoNavConfig()
L = CFG.lidar.max_range
DT = CFG.crowd.dt  # the scan period, 0.1 s
R_PED = CFG.crowd.pedestrian_radius
DISTANCES = np.asarray(CFG.reward.emotion_distances())


def detect(robot_xy, heading: float, centers, radii) -> Detections:
    """The discs `detect_objects` finds in the real scan of `centers`, `radii`."""
    scan = scan_discs(np.asarray(robot_xy, float), heading, centers, radii)
    return detect_objects(scan, np.asarray(robot_xy, float), heading, L)


def nearest(tracks: list[Track], xy) -> tuple[Track | None, float]:
    """The track nearest `xy` and its distance [m] (None, inf without tracks)."""
    best, dist = None, math.inf
    for tr in tracks:
        d = float(np.hypot(*(tr.x[:2] - np.asarray(xy))))
        if d < dist:
            best, dist = tr, d
    return best, dist


def snapshot(tracker: CrowdTracker, positions=None, codes=None):
    """The tracker's crowd with emotion reports (positions, codes); none by default."""
    positions = np.zeros((0, 2)) if positions is None else positions
    codes = np.zeros(0, dtype=int) if codes is None else codes
    return tracker.snapshot(
        positions, codes, DISTANCES, R_PED, CFG.reward.static_discomfort, NEUTRAL
    )


# -- detection -----------------------------------------------------------------------------


@pytest.mark.parametrize(
    "robot_xy, heading",
    [
        ([0.0, 0.0], 0.0),
        ([0.3, -0.2], 1.234),
        ([-0.5, 0.4], -2.9),
        ([0.1, 0.1], math.pi),  # the pedestrian straddles the seam behind the robot
    ],
)
def test_two_discs_and_a_pedestrian_give_three_exact_circles(robot_xy, heading):
    centers = np.array([[2.5, 1.0], [-1.2, -3.1], [-3.0, 0.05]])  # disc, disc, pedestrian
    radii = np.array([0.23, 0.38, R_PED])
    det = detect(robot_xy, heading, centers, radii)
    assert len(det.radii) == 3 and det.centers.shape == (3, 2) and det.points.shape == (3,)
    for c, r in zip(centers, radii, strict=True):
        j = int(np.argmin(np.hypot(*(det.centers - c).T)))
        assert np.hypot(*(det.centers[j] - c)) < 0.03
        assert abs(det.radii[j] - r) < 0.03
        assert det.points[j] >= DetectionParams().min_points


def test_seam_cluster_is_one_object():
    # A disc right behind the robot covers beams on both sides of the seam (beam 1799 and
    # beam 0): one detection, not two half-discs.
    centers, radii = np.array([[-2.0, 0.0]]), np.array([0.4])
    scan = scan_discs(np.zeros(2), 0.0, centers, radii)
    assert scan[0] < L and scan[-1] < L  # really across the seam
    det = detect_objects(scan, np.zeros(2), 0.0, L)
    assert len(det.radii) == 1
    assert np.hypot(*(det.centers[0] - centers[0])) < 0.03
    assert det.points[0] == int((scan < L).sum())


def test_partly_hidden_disc_is_still_found_and_slivers_are_dropped():
    # A pedestrian at 4 m half hidden behind a near disc: its visible arc still gives its
    # circle. A sliver of fewer than `min_points` beams gives nothing.
    robot = np.zeros(2)
    occluder = np.array([[2.0, 0.0]])
    ped = np.array([[4.0, 0.45]])
    det = detect(robot, 0.0, np.vstack([occluder, ped]), [0.3, R_PED])
    assert len(det.radii) == 2
    j = int(np.argmin(np.hypot(*(det.centers - ped[0]).T)))
    assert np.hypot(*(det.centers[j] - ped[0])) < 0.03
    assert det.points[j] < 80  # partly hidden: the full pedestrian shows ~85 beams
    sliver = np.array([[4.0, 0.34]])  # only a few beams of it pass the occluder
    scan = scan_discs(robot, 0.0, np.vstack([occluder, sliver]), [0.3, R_PED])
    own = scan_discs(robot, 0.0, sliver, [R_PED])
    visible = int(((own < L) & (own == scan)).sum())
    assert 0 < visible < DetectionParams().min_points
    assert len(detect_objects(scan, robot, 0.0, L).radii) == 1


# -- tracking ------------------------------------------------------------------------------


def occlusion_crowd() -> tuple[Crowd, Scenario]:
    """One pedestrian walking (ORCA) along x = 4 m behind a disc at (2, 0) seen from the
    origin: hidden from the robot for about a second on each pass."""
    sc = Scenario(
        pedestrians=[PedestrianSpec(start=[4.0, -3.0], goal=[4.0, 3.0], emotion="negative")],
        obstacles=[StaticDiscSpec(center=[2.0, 0.0], radius=0.36)],
        robot_start=[0.0, 0.0],
        robot_goal=[-3.0, 0.0],
        robot_heading=0.0,
    )
    return Crowd(sc, CFG), sc


def test_track_survives_a_one_second_occlusion_behind_a_disc():
    crowd, _ = occlusion_crowd()
    state = crowd.initial_state()
    robot = np.zeros(2)
    tracker = CrowdTracker()
    ids_seen, hidden_scans, coasting_ok = [], 0, True
    for k in range(70):  # 7 s: the pedestrian passes behind the disc once
        state = crowd.step(state, robot, np.zeros(2))
        centers = np.vstack([state.positions, crowd.static_centers])
        radii = np.concatenate([[R_PED], crowd.static_radii])
        det = detect(robot, 0.0, centers, radii)
        tracker.update((k + 1) * DT, det)
        ped = state.positions[0]
        _, det_dist = (None, np.hypot(*(det.centers - ped).T).min(initial=math.inf))
        tr, dist = nearest(tracker.tracks(), ped)
        if det_dist > 0.1:  # hidden: no detection of it in this scan
            hidden_scans += 1
            coasting_ok &= tr is not None and dist < 0.3 and tr.misses > 0
        elif tr is not None and dist < 0.05:
            ids_seen.append(tr.id)
    assert 10 <= hidden_scans <= 12  # 1 s (10 scans) or a little more behind the disc
    assert coasting_ok  # a confirmed track waited at the predicted spot all along
    assert len(set(ids_seen)) == 1 and len(ids_seen) > 40  # the same id before and after
    # The disc is one track too; nothing else was confirmed.
    assert len(tracker.tracks()) == 2


def test_hidden_track_is_dropped_after_its_coast_limit():
    # A pedestrian walks behind the disc and stays there (it stops, hidden).
    params = TrackerParams()
    robot = np.zeros(2)
    tracker = CrowdTracker(params)
    disc = np.array([[2.0, 0.0]])
    ped_id, last_seen = None, None
    for k in range(60):
        t = k * DT
        ped = np.array([4.0, min(-2.5 + t, 0.0)])  # 1 m/s towards y = 0, then stands
        det = detect(robot, 0.0, np.vstack([disc, ped]), [0.45, R_PED])
        tracker.update(t, det)
        visible = np.hypot(*(det.centers - ped).T).min(initial=math.inf) < 0.05
        if visible:
            tr, _ = nearest(tracker.tracks(), ped)
            if tr is not None:
                ped_id, last_seen = tr.id, t
        alive = ped_id in [tr.id for tr in tracker.tracks()]
        if last_seen is not None and not visible:
            assert alive == (t - last_seen <= params.max_coast + 1e-9), t
    assert ped_id is not None and last_seen is not None and last_seen < 3.0
    assert ped_id not in [tr.id for tr in tracker.all_tracks()]
    assert len(tracker.tracks()) == 1  # only the disc is left


@pytest.mark.parametrize(
    "a0, va, b0, vb, t_end",
    [
        # The near one passes in front of the far one as seen from the robot.
        ([2.5, -3.0], [0.0, 1.0], [4.5, 3.0], [0.0, -1.0], 6.0),
        # Paths crossing at 90° at (3, 0), one second apart (0.71 m apart at the closest).
        (
            [1.5, -1.5],
            [1 / math.sqrt(2), 1 / math.sqrt(2)],
            [4.5, -2.0],
            [-1 / 2**0.5, 1 / 2**0.5],
            5.0,
        ),
    ],
    ids=["in_front", "x_crossing"],
)
def test_identities_kept_through_a_crossing(a0, va, b0, vb, t_end):
    robot = np.zeros(2)
    tracker = CrowdTracker()
    walks = [(np.array(a0), np.array(va)), (np.array(b0), np.array(vb))]
    ids: list[list[int]] = [[], []]
    steps = round(t_end / DT)
    for k in range(steps + 1):
        t = k * DT
        peds = np.array([p + v * t for p, v in walks])
        tracker.update(t, detect(robot, 0.3, peds, [R_PED, R_PED]))
        for i, p in enumerate(peds):
            tr, dist = nearest(tracker.tracks(), p)
            if tr is not None and dist < 0.3:
                ids[i].append(tr.id)
    assert len(set(ids[0])) == 1 and len(set(ids[1])) == 1
    assert ids[0][0] != ids[1][0]
    assert len(ids[0]) >= steps - 3 and len(ids[1]) >= steps - 3  # tracked all along
    assert len(tracker.tracks()) == 2


def test_still_disc_becomes_static_and_walking_pedestrian_never_does():
    params = TrackerParams()
    sc = Scenario(
        pedestrians=[PedestrianSpec(start=[1.0, 2.0], goal=[1.0, -2.0], emotion="happy")],
        obstacles=[StaticDiscSpec(center=[-2.0, 1.5], radius=0.25)],
        robot_start=[0.0, 0.0],
        robot_goal=[-3.0, -1.0],
    )
    crowd = Crowd(sc, CFG)
    state = crowd.initial_state()
    robot = np.array(sc.robot_start)
    tracker = CrowdTracker(params)
    for k in range(150):  # 15 s: the pedestrian turns round at its goals
        t = k * DT
        centers = np.vstack([state.positions, crowd.static_centers])
        radii = np.concatenate([[R_PED], crowd.static_radii])
        tracker.update(t, detect(robot, 0.0, centers, radii))
        snap = snapshot(tracker, state.positions, state.emotions)
        disc_track, _ = nearest(tracker.all_tracks(), crowd.static_centers[0])
        assert disc_track.still_since == 0.0  # seen still from the first scan on
        # Static once still for `still_duration` (2 s), a pedestrian before.
        is_static = t >= params.still_duration - 1e-9
        assert len(snap.static_centers) == int(is_static), t
        if is_static:
            assert np.hypot(*(snap.static_centers[0] - crowd.static_centers[0])) < 0.03
            assert abs(snap.static_radii[0] - 0.25) < 0.03
        elif k >= params.confirm_hits - 1:  # confirmed, still a pedestrian for now
            assert len(snap.positions) == 2
        if k >= 3:  # the walker: a moving pedestrian with its emotion, never static
            j = int(np.argmin(np.hypot(*(snap.positions - state.positions[0]).T)))
            assert np.hypot(*(snap.positions[j] - state.positions[0])) < 0.1, t
            assert snap.emotions[j] == HAPPY and snap.discomfort[j] == DISTANCES[HAPPY]
            assert snap.radius == R_PED
        state = crowd.step(state, robot, np.zeros(2))


def test_snapshot_emotion_association_gate():
    tracker = CrowdTracker()
    robot = np.zeros(2)
    for k in range(5):
        peds = np.array([[2.0, 0.5 * k * DT], [-2.0, 1.0]])
        tracker.update(k * DT, detect(robot, 0.0, peds, [R_PED, R_PED]))
    # A report near the first pedestrian only, another one far from everything.
    snap = snapshot(tracker, np.array([[2.1, 0.3], [0.0, -3.0]]), np.array([NEGATIVE, HAPPY]))
    first = int(np.argmin(np.hypot(*(snap.positions - [2.0, 0.2]).T)))
    assert snap.emotions[first] == NEGATIVE and snap.discomfort[first] == DISTANCES[NEGATIVE]
    assert snap.emotions[1 - first] == NEUTRAL and snap.discomfort[1 - first] == DISTANCES[NEUTRAL]
    assert snapshot(tracker).emotions.tolist() == [NEUTRAL, NEUTRAL]


def test_velocity_within_a_tenth_after_one_second_of_a_straight_walk():
    robot, heading = np.array([0.5, -0.5]), 2.0
    start, velocity = np.array([-1.0, 2.5]), np.array([0.8, -0.6])  # 1 m/s
    tracker = CrowdTracker()
    for k in range(11):  # scans at 0, 0.1, …, 1.0 s
        tracker.update(k * DT, detect(robot, heading, [start + velocity * k * DT], [R_PED]))
    (tr,) = tracker.tracks()
    assert np.hypot(*(tr.x[2:] - velocity)) < 0.1
    assert np.hypot(*(tr.x[:2] - (start + velocity))) < 0.03


def test_tentative_track_dies_at_its_first_miss():
    tracker = CrowdTracker()
    robot = np.zeros(2)
    disc = np.array([[2.0, 1.0]])
    tracker.update(0.0, detect(robot, 0.0, [[-2.0, -2.0]], [0.3]))  # seen once only
    for k in range(1, 6):
        tracker.update(k * DT, detect(robot, 0.0, disc, [0.3]))
    assert [tr.id for tr in tracker.all_tracks()] == [1]
    assert [tr.id for tr in tracker.tracks()] == [1]


def _run_crowd(tracker: CrowdTracker, seed: int, steps: range) -> list[dict]:
    """Track the real crowd of `sample_scenario(seed)` seen from the robot's start;
    the tracker's state_dict after each scan."""
    sc = sample_scenario(seed, CFG)
    crowd = Crowd(sc, CFG)
    state = crowd.initial_state()
    robot, heading = np.array(sc.robot_start), sc.robot_heading
    out = []
    for k in range(steps.stop):
        state = crowd.step(state, robot, np.zeros(2))
        if k in steps:
            centers = np.vstack([state.positions, crowd.static_centers])
            radii = np.concatenate([np.full(len(state.positions), R_PED), crowd.static_radii])
            tracker.update((k + 1) * DT, detect(robot, heading, centers, radii))
            out.append(tracker.state_dict())
    return out


def test_same_inputs_give_identical_tracks_and_state_dict_resumes_exactly():
    a = _run_crowd(CrowdTracker(), 3, range(0, 120))
    b = _run_crowd(CrowdTracker(), 3, range(0, 120))
    assert a == b
    assert len(a[-1]["tracks"]) >= 3  # a real crowd was tracked
    # Resume from plain data (through JSON) at scan 60: identical to the uninterrupted run.
    resumed = CrowdTracker()
    resumed.load_state_dict(json.loads(json.dumps(a[59])))
    assert resumed.state_dict() == a[59]
    assert _run_crowd(resumed, 3, range(60, 120)) == a[60:]
    # reset: ids from 0 again.
    resumed.reset()
    assert resumed.state_dict() == {"time": None, "next_id": 0, "tracks": []}


def test_bad_inputs_are_refused():
    tracker = CrowdTracker()
    tracker.update(1.0, Detections.empty())
    with pytest.raises(ValueError, match="earlier"):
        tracker.update(0.5, Detections.empty())
    with pytest.raises(ValueError, match="track"):
        tracker.load_state_dict({"time": 0.0, "next_id": 1, "tracks": [{"id": 0}]})
    assert tracker.state_dict()["time"] == 1.0  # unchanged
    with pytest.raises(ValueError, match="gate"):
        TrackerParams(gate=-1.0).validate()
    with pytest.raises(ValueError, match="max_radius"):
        DetectionParams(min_radius=0.8).validate()
    with pytest.raises(ValueError, match="ranges"):
        detect_objects(np.zeros((2, 3)), np.zeros(2), 0.0, L)


def _one(center, fixed: bool, radius: float = 0.3):
    from emonav_drake.sensing.lidar_objects import Detections

    return Detections(
        np.array([center], dtype=float), np.array([radius]), np.array([12]), np.array([fixed])
    )


def test_a_fixed_object_neither_drifts_while_unseen_nor_takes_a_neighbours_detection():
    """The leg detector's tracker (`sticky_fixed`): a disc found as a fixed detection with
    noisy centres is a static object; hidden for 1.2 s it stays where it was (a tracker
    that predicts it with its noise-born velocity drifted and, its gate widened, took the
    detection of the disc beside it: a static obstacle where there is none)."""
    from emonav_drake.params import apply_sensor_preset
    from emonav_drake.sensing.crowd_tracker import CrowdTracker, tracker_params

    cfg = EmoNavConfig()
    apply_sensor_preset(cfg, "vlp16")
    params = tracker_params(cfg)
    assert params.sticky_fixed
    rng = np.random.default_rng(3)
    tracker = CrowdTracker(params)
    centre = np.array([2.0, -1.0])
    for k in range(20):  # 2 s of fits scattered by 5 cm
        tracker.update(0.1 * k, _one(centre + rng.normal(0, 0.05, 2), True))
    (track,) = tracker.tracks()
    assert tracker.is_static(track) and np.all(track.velocity == 0.0)
    for k in range(20, 32):  # hidden
        tracker.update(0.1 * k, Detections.empty())
    held = [tr for tr in tracker.tracks() if tr.id == track.id]
    assert held and np.linalg.norm(held[0].position - centre) < 0.05
    # a detection 0.6 m away (the next disc) starts its own track
    tracker.update(3.2, _one(centre + [0.5, -0.35], True))
    old, new = tracker.all_tracks()
    assert old.id == track.id and np.linalg.norm(old.position - centre) < 0.05
    assert np.linalg.norm(new.position - centre - [0.5, -0.35]) < 1e-9


def test_a_walking_person_with_one_disc_like_scan_keeps_walking():
    from emonav_drake.params import apply_sensor_preset
    from emonav_drake.sensing.crowd_tracker import CrowdTracker, tracker_params

    cfg = EmoNavConfig()
    apply_sensor_preset(cfg, "vlp16")
    tracker = CrowdTracker(tracker_params(cfg))
    for k in range(30):  # 1 m/s along +x; scan 15 looks like a disc (a fixed detection)
        tracker.update(0.1 * k, _one([0.1 * k, 2.0], k == 15, 0.15))
    (track,) = tracker.tracks()
    assert not tracker.is_static(track)
    assert abs(track.velocity[0] - 1.0) < 0.15 and abs(track.position[0] - 2.9) < 0.1


def test_the_tracker_system_drops_the_known_walls_returns_and_keeps_a_person_by_one():
    """Map-based filtering (`CrowdTrackerSystem`, `known_walls`): in a corridor of known
    walls the scan's wall returns become no-returns, so the walls give no objects; a disc
    standing 0.3 m off a wall is still there, its beams intact."""
    from emonav_drake.params import EmoNavConfig
    from emonav_drake.sensing.leg_detection import detect_scan
    from emonav_drake.sensing.lidar import scan_discs
    from emonav_drake.systems.crowd_tracker_system import CrowdTrackerSystem

    cfg = EmoNavConfig()
    walls = np.array([[[-6.0, 1.2], [6.0, 1.2]], [[-6.0, -1.2], [6.0, -1.2]]])
    system = CrowdTrackerSystem(cfg, known_walls=walls)
    xy, heading, k = np.zeros(2), 0.3, cfg.lidar.num_beams
    args = (k, cfg.lidar.max_range, cfg.lidar.min_range)
    empty = scan_discs(xy, heading, np.zeros((0, 2)), np.zeros(0), *args, segments=walls)
    person = scan_discs(xy, heading, [[3.0, 0.6]], [0.3], *args, segments=walls)

    def found(ranges):
        d = detect_scan(ranges, xy, heading, cfg.lidar.max_range, system.perception.detection)
        return np.asarray(d.centers).reshape(-1, 2)

    assert len(found(empty)) > 0  # unfiltered, the walls are objects
    filtered = system.without_known_walls(empty, xy, heading)
    assert np.all(filtered == cfg.lidar.max_range) and len(found(filtered)) == 0
    kept = system.without_known_walls(person, xy, heading)
    hit = person < empty - 0.05  # the person's beams
    assert hit.sum() > 5 and np.array_equal(kept[hit], person[hit])
    centers = found(kept)
    assert len(centers) == 1 and np.linalg.norm(centers[0] - [3.0, 0.6]) < 0.05
    # without a map, nothing is dropped
    assert np.array_equal(CrowdTrackerSystem(cfg).without_known_walls(empty, xy, heading), empty)
