import numpy as np

from emonav_drake.crowd.crowd import Crowd
from emonav_drake.params import NEGATIVE, NEUTRAL, EmoNavConfig
from emonav_drake.scenarios.scenario import (
    PedestrianSpec,
    Scenario,
    StaticDiscSpec,
    sample_scenario,
)

CFG = EmoNavConfig()
FAR = np.array([100.0, 100.0])


def _walk(crowd, state, steps):
    for _ in range(steps):
        state = crowd.step(state, FAR, np.zeros(2))
    return state


def test_pedestrian_walks_to_its_goal_and_turns_round():
    sc = Scenario(pedestrians=[PedestrianSpec(start=[-2.0, 0.0], goal=[2.0, 0.0])])
    crowd = Crowd(sc, CFG)
    s = crowd.initial_state()
    xs = []
    for _ in range(60):  # 4 m at 1 m/s, then 2 s back
        s = crowd.step(s, FAR, np.zeros(2))
        xs.append(s.positions[0][0])
        assert np.linalg.norm(s.velocities[0]) <= 1.0 + 1e-9
    assert max(xs) >= 2.0 - CFG.crowd.goal_tolerance  # reached the goal's tolerance
    assert xs[-1] < 1.0 and s.velocities[0][0] < 0  # turned round, heading back
    assert np.allclose(s.goals[0], [-2.0, 0.0])


def test_pedestrian_avoids_a_slower_robot_but_not_a_faster_one():
    # A pedestrian walking at 1 m/s straight at a robot standing in its way.
    sc = Scenario(pedestrians=[PedestrianSpec(start=[-3.0, 0.0], goal=[3.0, 0.0])])
    crowd = Crowd(sc, CFG)
    s = _walk(crowd, crowd.initial_state(), 5)  # up to speed, robot far away
    still = s
    min_gap = np.inf
    for _ in range(40):  # robot at rest at the origin: slower, so it is avoided
        still = crowd.step(still, np.zeros(2), np.zeros(2))
        min_gap = min(min_gap, np.linalg.norm(still.positions[0]))
    assert min_gap >= 0.6 - 1e-6  # never touches the robot (radii 0.3 + 0.3)
    # Same, but the robot walks towards the pedestrian faster than it: invisible.
    fast = s
    for _ in range(10):
        fast = crowd.step(fast, np.zeros(2), np.array([-1.2, 0.0]))
    assert abs(fast.positions[0][1]) < 1e-9  # the pedestrian did not deviate


def test_static_discs_are_avoided():
    sc = Scenario(
        pedestrians=[PedestrianSpec(start=[-3.0, 0.01], goal=[3.0, 0.01])],
        obstacles=[StaticDiscSpec(center=[0.0, 0.0], radius=0.4)],
    )
    crowd = Crowd(sc, CFG)
    s = crowd.initial_state()
    for _ in range(55):
        s = crowd.step(s, FAR, np.zeros(2))
        assert np.linalg.norm(s.positions[0]) >= 0.3 + 0.4 - 1e-6
    assert s.positions[0][0] > 1.5  # went round the disc


def test_crowd_is_deterministic_and_time_varying_emotions_follow_the_schedule():
    cfg = EmoNavConfig()
    cfg.crowd.time_varying_emotions = True
    sc = sample_scenario(5, cfg)
    a, b = Crowd(sc, cfg), Crowd(sc, cfg)
    sa, sb = _walk(a, a.initial_state(), 50), _walk(b, b.initial_state(), 50)
    assert np.array_equal(sa.positions, sb.positions)
    who = next(i for i, p in enumerate(sc.pedestrians) if p.emotion_schedule)
    names = sc.pedestrians[who].emotion_schedule
    for substep in (0, 19, 20, 45, 60):
        code = a.emotions_at(substep)[who]
        assert ("happy", "neutral", "negative")[code] == names[substep // 20]
    snap = a.snapshot(sa)
    assert np.allclose(snap.discomfort, np.array([0.2, 0.35, 0.5])[sa.emotions])


def test_snapshot_discomfort_matches_emotion():
    sc = Scenario(
        pedestrians=[
            PedestrianSpec(emotion="negative"),
            PedestrianSpec(start=[1.0, 4.0], goal=[1.0, -4.0]),
        ]
    )
    crowd = Crowd(sc, CFG)
    snap = crowd.snapshot(crowd.initial_state())
    assert list(snap.emotions) == [NEGATIVE, NEUTRAL]
    assert list(snap.discomfort) == [0.5, 0.35]
