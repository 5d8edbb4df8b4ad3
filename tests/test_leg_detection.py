"""People as legs in a noisy scan: the leg detector and the tracker on it (issue 47 item 3).

Real components throughout: the sensor model's scan (`sensing/lidar_sensor.py`, the vlp16
preset: noise, dropouts, mixed pixels, spurious returns, two legs per walking person),
the detector (`sensing/lidar_objects.py` + `sensing/leg_detection.py`), the tracker.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from emonav_drake.crowd.crowd import CrowdSnapshot
from emonav_drake.crowd.pedestrian_legs import GAIT_CYCLE_LENGTH
from emonav_drake.params import EmoNavConfig, apply_sensor_preset
from emonav_drake.sensing.crowd_tracker import CrowdTracker, tracker_params
from emonav_drake.sensing.leg_detection import detect_scan, detection_params
from emonav_drake.sensing.lidar_objects import DetectionParams, detect_objects
from emonav_drake.sensing.lidar_sensor import sensed_ranges

ROBOT = np.zeros(2)


def _config(preset: str) -> EmoNavConfig:
    cfg = EmoNavConfig()
    apply_sensor_preset(cfg, preset)
    return cfg


def _snapshot(
    positions: np.ndarray,
    velocities: np.ndarray,
    phase: np.ndarray,
    time: float,
    static_centers: np.ndarray | None = None,
    static_radii: np.ndarray | None = None,
) -> CrowdSnapshot:
    p = len(positions)
    sc = np.zeros((0, 2)) if static_centers is None else static_centers
    return CrowdSnapshot(
        positions=positions,
        velocities=velocities,
        radius=0.3,
        emotions=np.zeros(p, dtype=np.int64),
        discomfort=np.zeros(p),
        static_centers=sc,
        static_radii=np.zeros(0) if static_radii is None else static_radii,
        static_discomfort=0.0,
        gait_phase=phase,
        time=time,
        seed=11,
    )


def test_ideal_and_disc_sensors_keep_the_disc_detector():
    assert detection_params(_config("ideal")) == DetectionParams()
    assert not detection_params(_config("ideal")).legs
    assert detection_params(_config("vlp16")).legs
    assert tracker_params(_config("ideal")).measurement_std == 0.03


@pytest.mark.parametrize("preset", ["vlp16", "ust10lx"])
@pytest.mark.parametrize("distance", [1.5, 3.0, 5.0])
def test_a_walking_person_is_one_detection_at_their_centre(preset, distance):
    """Over two gait cycles (legs apart, passing, apart again), a person walking across the
    line of sight is one detection within 0.12 m of their centre in at least 90 % of the
    scans; never more than one."""
    cfg = _config(preset)
    det_p = detection_params(cfg)
    one, errors = 0, []
    steps = 26  # 2.6 s at 1 m/s: two gait cycles of 1.3 m
    for k in range(steps):
        t = 0.1 * k
        pos = np.array([[distance, -1.3 + t]])
        phase = np.array([2 * math.pi * t / GAIT_CYCLE_LENGTH])
        snap = _snapshot(pos, np.array([[0.0, 1.0]]), phase, t)
        scan = sensed_ranges(ROBOT, 0.0, snap, cfg)
        det = detect_scan(scan, ROBOT, 0.0, cfg.lidar.max_range, det_p)
        people = det.centers[~det.walls]
        assert len(people) <= 1, (k, people)
        if len(people) == 1:
            one += 1
            errors.append(float(np.hypot(*(people[0] - pos[0]))))
    assert one >= 0.9 * steps
    assert np.quantile(errors, 0.9) <= 0.12, errors


def test_a_static_disc_is_one_fixed_detection_and_not_a_person():
    cfg = _config("vlp16")
    det_p = detection_params(cfg)
    center = np.array([[2.5, 0.4]])
    for k in range(20):
        snap = _snapshot(np.zeros((0, 2)), np.zeros((0, 2)), np.zeros(0), 0.1 * k, center, [0.3])
        scan = sensed_ranges(ROBOT, 0.0, snap, cfg)
        det = detect_scan(scan, ROBOT, 0.0, cfg.lidar.max_range, det_p)
        assert len(det) == 1 and det.walls[0], det
        assert np.hypot(*(det.centers[0] - center[0])) < 0.05
        assert det.radii[0] == pytest.approx(0.3, abs=0.05)


def test_the_disc_detector_on_legs_sees_two_objects_per_person():
    """Why the leg detector exists: the disc detector makes a walking person's legs two
    fallback discs of a pedestrian's radius, the person's centre inside neither."""
    cfg = _config("vlp16")
    pos = np.array([[2.0, 0.0]])
    snap = _snapshot(pos, np.array([[0.0, 1.0]]), np.array([math.pi / 2]), 0.0)
    scan = sensed_ranges(ROBOT, 0.0, snap, cfg)
    det = detect_objects(scan, ROBOT, 0.0, cfg.lidar.max_range, DetectionParams())
    assert len(det) == 2


@pytest.mark.parametrize("preset", ["vlp16", "ust10lx"])
def test_the_tracker_keeps_identity_through_a_crossing(preset):
    """Two people cross in front of the robot (paths at right angles, 0.7 m apart at the
    closest, both at 1 m/s, 3 m ahead) on a realistic sensor: each keeps one track id from
    its confirmation to the end, and the ids differ."""
    cfg = _config(preset)
    det_p, trk_p = detection_params(cfg), tracker_params(cfg)
    tracker = CrowdTracker(trk_p)
    vel = np.array([[0.0, 1.0], [-1.0, 0.0]])
    ids: list[list[int]] = [[], []]
    for k in range(50):
        t = 0.1 * k
        # B crosses A's path 1 s before A gets there: 0.70 m apart at the closest (t ≈ 2.4 s)
        pos = np.array([[3.0, -2.5 + t], [4.86 - t, 0.35]])
        phase = np.array([t, t + 1.0]) * 2 * math.pi / GAIT_CYCLE_LENGTH
        snap = _snapshot(pos, vel, phase, t)
        scan = sensed_ranges(ROBOT, 0.0, snap, cfg)
        tracker.update(t, detect_scan(scan, ROBOT, 0.0, cfg.lidar.max_range, det_p))
        tracks = [tr for tr in tracker.tracks() if not tracker.is_static(tr)]
        for p in range(2):
            near = [tr.id for tr in tracks if np.hypot(*(tr.x[:2] - pos[p])) < 0.5]
            if near:
                ids[p].append(near[0] if len(near) == 1 else -1)
    for p in range(2):
        assert len(ids[p]) >= 40, ids[p]
        assert len(set(ids[p])) == 1, ids[p]
    assert ids[0][0] != ids[1][0]


def test_detect_objects_refuses_legs_and_detect_scan_is_it_without():
    cfg = _config("ideal")
    snap = _snapshot(np.array([[2.0, 0.5]]), np.zeros((1, 2)), np.zeros(1), 0.0)
    scan = sensed_ranges(ROBOT, 0.0, snap, cfg)
    a = detect_objects(scan, ROBOT, 0.0, 6.0, DetectionParams())
    b = detect_scan(scan, ROBOT, 0.0, 6.0, DetectionParams())
    assert np.array_equal(a.centers, b.centers) and np.array_equal(a.radii, b.radii)
    with pytest.raises(ValueError, match="detect_scan"):
        detect_objects(scan, ROBOT, 0.0, 6.0, DetectionParams(legs=True))
