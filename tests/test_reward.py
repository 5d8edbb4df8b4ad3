import numpy as np
import pytest

from emonav_drake.crowd.crowd import CrowdSnapshot
from emonav_drake.navigation.reward import evaluate_step
from emonav_drake.params import HAPPY, NEGATIVE, EmoNavConfig, RewardParams

P = RewardParams()
GOAL = np.array([4.0, 0.0])


def _crowd(peds=(), emotions=(), statics=(), static_r=()):
    emotions = np.asarray(emotions, dtype=int)
    return CrowdSnapshot(
        positions=np.asarray(peds, dtype=float).reshape(-1, 2),
        velocities=np.zeros((len(peds), 2)),
        radius=0.3,
        emotions=emotions,
        discomfort=np.array([0.2, 0.35, 0.5])[emotions] if len(emotions) else np.zeros(0),
        static_centers=np.asarray(statics, dtype=float).reshape(-1, 2),
        static_radii=np.asarray(static_r, dtype=float),
        static_discomfort=0.2,
    )


def _eval(robot, crowd, prev=5.0, goal=GOAL):
    return evaluate_step(np.asarray(robot, float), goal, prev, crowd, 0.3, 0.1, P)


def test_progress_reward_when_nothing_is_near():
    ev = _eval([0.0, 0.0], _crowd())
    assert ev.reward == pytest.approx(0.3 * (5.0 - 4.0))
    assert not ev.collision and not ev.in_discomfort and ev.idt == (0, 0, 0, 0)


def test_collision_with_a_pedestrian_and_with_a_disc():
    # centre distance 0.55 < 0.3 + 0.3: gap to surface 0.25 <= r_robot
    ev = _eval([0.0, 0.0], _crowd(peds=[[0.55, 0.0]], emotions=[HAPPY]), prev=4.0)
    assert ev.collision
    assert ev.reward == pytest.approx(-0.6 - 0.1)  # plus the pedestrian's discomfort
    ev = _eval([0.0, 0.0], _crowd(statics=[[0.0, 0.6]], static_r=[0.3]), prev=4.0)
    assert ev.collision and ev.reward == pytest.approx(-0.6)
    # the boundary: a gap just under r_robot collides, just over does not
    ev = _eval([0.0, 0.0], _crowd(statics=[[0.0, 0.7]], static_r=[0.4 + 1e-9]), prev=4.0)
    assert ev.collision
    ev = _eval([0.0, 0.0], _crowd(statics=[[0.0, 0.7]], static_r=[0.4 - 1e-9]), prev=4.0)
    assert not ev.collision


def test_discomfort_is_counted_once_per_step():
    # inside a static zone (gap 0.4 < 0.2 + 0.3) and a negative pedestrian's (gap 0.7 < 0.8)
    crowd = _crowd(peds=[[-1.0, 0.0]], emotions=[NEGATIVE], statics=[[0.0, 0.7]], static_r=[0.3])
    ev = _eval([0.0, 0.0], crowd, prev=4.0)
    assert not ev.collision and ev.in_discomfort
    assert ev.reward == pytest.approx(-0.1)
    assert ev.idt == (1, 0, 0, 1)
    # a happy pedestrian at the same distance is comfortable (0.7 >= 0.2 + 0.3)
    ev = _eval([0.0, 0.0], _crowd(peds=[[-1.0, 0.0]], emotions=[HAPPY]), prev=4.0)
    assert not ev.in_discomfort and ev.reward == pytest.approx(0.0)


def test_goal_reward_and_min_distance():
    ev = _eval([3.95, 0.0], _crowd(peds=[[0.0, 3.0]], emotions=[HAPPY]), prev=0.2)
    assert ev.reached_goal and ev.reward == pytest.approx(0.5)
    assert ev.min_ped_distance == pytest.approx(np.hypot(3.95, 3.0))


def test_a_collision_names_what_was_hit():
    import dataclasses as dc

    from emonav_drake.navigation.metrics import EpisodeTracker

    cfg = EmoNavConfig()
    snap = CrowdSnapshot(
        positions=np.array([[1.0, 0.0], [0.0, 3.0]]),
        velocities=np.zeros((2, 2)),
        radius=0.3,
        emotions=np.array([2, 0]),
        discomfort=np.array([0.5, 0.2]),
        static_centers=np.array([[-2.0, 0.0]]),
        static_radii=np.array([0.5]),
        static_discomfort=0.2,
    )
    args = (np.array([8.0, 0.0]), 9.0, snap, cfg.robot.radius, 0.2, cfg.reward)
    ev = evaluate_step(np.array([0.5, 0.0]), *args)  # 0.5 m from the negative pedestrian
    assert ev.collision and ev.collided_with == "negative"
    ev = evaluate_step(np.array([-1.3, 0.0]), *args)  # 0.2 m from the disc's edge
    assert ev.collision and ev.collided_with == "static"
    assert evaluate_step(np.array([0.0, -3.0]), *args).collided_with == ""
    tracker = EpisodeTracker(10, 0.4)
    tracker.add(dc.replace(ev), 0.1)
    assert tracker.record.outcome == "collision"
    assert tracker.record.to_json()["collided_with"] == "static"
