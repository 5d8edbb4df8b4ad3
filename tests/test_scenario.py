import math

import numpy as np
import pytest

from emonav_drake.params import EMOTION_NAMES, ConfigError, EmoNavConfig
from emonav_drake.scenarios.scenario import dump_scenario, load_scenario, sample_scenario


def test_same_seed_same_scenario_and_different_seeds_differ():
    assert sample_scenario(3) == sample_scenario(3)
    assert sample_scenario(3) != sample_scenario(4)


def test_sampling_follows_the_paper():
    cfg = EmoNavConfig()
    counts_p, counts_s, emotions = set(), set(), set()
    for seed in range(200):
        sc = sample_scenario(seed, cfg)
        counts_p.add(len(sc.pedestrians))
        counts_s.add(len(sc.obstacles))
        assert sc.robot_start == [-4.0, 0.0] and sc.robot_goal == [4.0, 0.0]
        discs = [(*sc.robot_start, 0.3), (*sc.robot_goal, 0.3)]
        for o in sc.obstacles:
            assert -3 <= o.center[0] <= 3 and -1.5 <= o.center[1] <= 1.5
            assert 0.2 <= o.radius <= 0.4
            discs.append((*o.center, o.radius))
        for p in sc.pedestrians:
            r = math.hypot(*p.start)
            assert 3.5 <= r <= 4.5
            assert np.allclose(p.goal, [-p.start[0], -p.start[1]])  # antipodal goal
            emotions.add(p.emotion)
            discs += [(*p.start, 0.3), (*p.goal, 0.3)]
        for i in range(len(discs)):  # nothing starts in collision
            for j in range(i):
                a, b = discs[i], discs[j]
                assert math.dist(a[:2], b[:2]) >= a[2] + b[2]
    assert counts_p == {1, 2, 3, 4} and counts_s == {1, 2, 3}
    assert emotions == set(EMOTION_NAMES)


def test_time_varying_mode_changes_one_emotion_every_period():
    cfg = EmoNavConfig()
    cfg.crowd.time_varying_emotions = True
    sc = sample_scenario(7, cfg)
    scheduled = [p for p in sc.pedestrians if p.emotion_schedule]
    assert len(scheduled) == 1
    sched = scheduled[0].emotion_schedule
    assert len(sched) >= 50 / 2.0  # covers the 50 s episode
    assert all(a != b for a, b in zip(sched, sched[1:], strict=False))
    assert sample_scenario(7, cfg) == sc


def test_yaml_round_trip_and_invalid_fields_are_named(tmp_path):
    sc = sample_scenario(11)
    path = tmp_path / "s.yaml"
    path.write_text(dump_scenario(sc))
    assert load_scenario(path) == sc
    path.write_text("pedestrians:\n  - {start: [1.0, 2.0], goal: [0.0, 0.0], emotion: angryy}\n")
    with pytest.raises(ConfigError, match=r"pedestrians\[0\]\.emotion"):
        load_scenario(path)
    path.write_text("obstacles:\n  - {center: [1.0, 2.0], radius: -0.3}\n")
    with pytest.raises(ConfigError, match=r"obstacles\[0\]\.radius"):
        load_scenario(path)
    path.write_text("robot_start: [1.0, .nan]\n")
    with pytest.raises(ConfigError, match="robot_start"):
        load_scenario(path)
    path.write_text("robot_start: [1.0, 2.0\n")
    with pytest.raises(ConfigError):
        load_scenario(path)
