"""The named scenario families: seeded, valid, reachable, and the paper's seeds unchanged."""

import dataclasses as dc
import math

import numpy as np
import pytest

from emonav_drake.params import SCENARIO_FAMILIES, EmoNavConfig
from emonav_drake.scenarios.scenario import (
    PedestrianSpec,
    Scenario,
    StaticDiscSpec,
    WallSpec,
    dump_scenario,
    sample_paper_scenario,
    sample_scenario,
)
from emonav_drake.scenarios.scenario_families import FAMILIES, goal_reachable, sample_family
from emonav_drake.typed_yaml import ConfigError

CFG = EmoNavConfig()
SEEDS = range(12)


def _family_config(name: str) -> EmoNavConfig:
    cfg = EmoNavConfig()
    cfg.crowd.family = name
    return cfg.validate()


@pytest.mark.slow
@pytest.mark.parametrize("name", SCENARIO_FAMILIES)
def test_every_family_is_seeded_valid_and_reachable(name):
    cfg = _family_config(name)
    scenes = [sample_scenario(s, cfg) for s in SEEDS]
    again = [sample_scenario(s, cfg) for s in SEEDS]
    assert [dump_scenario(a) for a in scenes] == [dump_scenario(b) for b in again]
    assert len({dump_scenario(a) for a in scenes}) == len(scenes)  # seeds differ
    r, p = CFG.robot.radius, CFG.crowd.pedestrian_radius
    for sc in scenes:
        sc.validate(r, p, CFG.episode.goal_radius)
        assert goal_reachable(sc, r)
        # no overlap at the start: pedestrians with each other and with the robot
        starts = np.array([q.start for q in sc.pedestrians])
        gaps = np.linalg.norm(starts[:, None] - starts[None], axis=2) + np.eye(len(starts)) * 9
        assert gaps.min() >= 2 * p
        assert np.linalg.norm(starts - sc.robot_start, axis=1).min() >= r + p
        for o in sc.obstacles:
            assert math.dist(o.center, sc.robot_start) >= o.radius + r


def test_the_paper_family_is_the_papers_sampler():
    for s in SEEDS:
        assert sample_scenario(s, CFG) == sample_paper_scenario(s, CFG)
        assert sample_family("paper", s) == sample_paper_scenario(s, CFG)


def test_families_draw_from_streams_of_their_own():
    one = sample_family("circle_crossing", 0)
    other = sample_family("delayed_crossing", 0)
    assert [p.start for p in one.pedestrians] != [p.start for p in other.pedestrians]


def test_what_each_family_promises():
    blocker = sample_family("blocker", 3)
    assert blocker.pedestrians[0].at_goal == "stand"
    assert abs(blocker.pedestrians[0].goal[1]) <= 0.3  # in the robot's path
    group = sample_family("group_approach", 3)
    assert [q.group for q in group.pedestrians] == [0, 0, 0]
    assert len(sample_family("dense_20", 3).pedestrians) == 20
    assert all(1.3 <= q.speed <= 1.6 for q in sample_family("fast_pedestrians", 3).pedestrians)
    assert len(sample_family("corridor_head_on", 3).walls) == 2
    assert sample_family("all_dynamic", 3).obstacles == []
    assert all(0 <= q.start_delay <= 8 for q in sample_family("delayed_crossing", 3).pedestrians)
    corner = sample_family("corner_traffic", 3)
    assert corner.robot_goal == [0.0, 4.0] and all(q.waypoints for q in corner.pedestrians)


def _room(door: float) -> list[WallSpec]:
    """A 2 x 2 m room round the robot's goal (4, 0), a door of `door` m in its west wall."""
    walls = [
        WallSpec(start=[3.0, -1.0], end=[5.0, -1.0]),
        WallSpec(start=[5.0, -1.0], end=[5.0, 1.0]),
        WallSpec(start=[5.0, 1.0], end=[3.0, 1.0]),
    ]
    if door <= 0:
        return [*walls, WallSpec(start=[3.0, 1.0], end=[3.0, -1.0])]
    return [
        *walls,
        WallSpec(start=[3.0, 1.0], end=[3.0, door / 2]),
        WallSpec(start=[3.0, -door / 2], end=[3.0, -1.0]),
    ]


def test_a_walled_off_goal_is_unreachable_and_a_door_opens_it():
    assert not goal_reachable(Scenario(walls=_room(0.0)), 0.3)
    assert goal_reachable(Scenario(walls=_room(0.8)), 0.3)  # a 0.8 m door for a 0.6 m robot
    assert not goal_reachable(Scenario(walls=_room(0.4)), 0.3)
    ring = [
        StaticDiscSpec(center=[4.0 + 0.9 * math.cos(a), 0.9 * math.sin(a)], radius=0.35)
        for a in np.linspace(0, 2 * math.pi, 12, endpoint=False)
    ]
    assert not goal_reachable(Scenario(obstacles=ring), 0.3)  # the goal inside a ring of discs


def test_an_unknown_family_is_refused_by_name():
    cfg = EmoNavConfig()
    cfg.crowd.family = "mall"
    with pytest.raises(ConfigError, match="crowd.family"):
        cfg.validate()
    with pytest.raises(ConfigError, match="mall"):
        sample_family("mall", 0)


def test_the_family_list_matches_the_configs_names():
    assert tuple(FAMILIES) == SCENARIO_FAMILIES
    assert all(f.summary and len(f.summary) < 70 for f in FAMILIES.values())


def test_a_family_scene_walks_through_the_crowd():
    # the behaviours are real in the crowd: the blocker arrives and stands
    from emonav_drake.crowd.crowd import Crowd

    sc = sample_family("blocker", 5)
    crowd = Crowd(sc, CFG)
    state = crowd.initial_state()
    far, still = np.array([40.0, 40.0]), np.zeros(2)
    for _ in range(150):
        state = crowd.step(state, far, still)
    b = sc.pedestrians[0]
    assert math.dist(state.positions[0], b.goal) < 0.3
    assert np.hypot(*state.velocities[0]) < 0.05
    assert dc.is_dataclass(b) and isinstance(b, PedestrianSpec)


@pytest.mark.slow
def test_a_family_benchmark_trial_replays_with_its_sim_command(tmp_path):
    """`emonav benchmark --family` records the family; `diagnose`'s re-run command names
    it, and `emonav sim` with that command plays the very trial again."""
    import json
    import shlex

    from emonav_drake.cli import main
    from emonav_drake.evaluation.failures import rerun_command

    run = tmp_path / "run"
    argv = ["benchmark", "--planners", "dwa", "--plant", "lip", "--trials", "2"]
    argv += ["--first-seed", "5", "--family", "corridor_head_on", "--out", str(run), "--quiet"]
    assert main(argv) == 0
    settings = json.loads((run / "settings.json").read_text())
    assert settings["setting_label"].endswith(", family corridor_head_on, global route")
    trial = json.loads((run / "trials.jsonl").read_text().splitlines()[1])
    command = rerun_command(settings, "dwa", trial["seed"])
    assert "--family corridor_head_on" in command
    out = tmp_path / "sim.json"
    assert main([*shlex.split(command)[1:], "--json", str(out)]) == 0
    record = json.loads(out.read_text())
    assert {k: record[k] for k in trial["record"]} == trial["record"]
