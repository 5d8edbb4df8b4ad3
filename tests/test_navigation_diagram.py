import logging

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator

from emonav_drake.diagrams.navigation import (
    build_navigation_diagram,
    run_episode,
)
from emonav_drake.learning.env import EmoNavLIPEnv
from emonav_drake.navigation.lip_world import CommandError
from emonav_drake.params import EmoNavConfig
from emonav_drake.planners.dwa import DwaPlanner
from emonav_drake.planners.replay import ReplayPlanner
from emonav_drake.scenarios.scenario import sample_scenario
from emonav_drake.systems.episode_monitor import episode_monitor_callback
from tests.diagram_stacks import diagram_stacks


def _env_rollout(seed, config, actions=None, planner=None):
    """Robot states, pedestrian positions, rewards and LGM stacks of an env episode."""
    env = EmoNavLIPEnv(config, goal_radius=0.2)
    obs, _ = env.reset(seed=seed)
    w = env.world
    robots, peds, rewards, stacks, taken = (
        [np.array(w.robot)],
        [w.crowd_state.positions],
        [],
        [],
        [],
    )
    stacks.append(obs["lgm"])
    k = 0
    while True:
        u = planner.plan(env.planner_input()) if planner else actions[k]
        taken.append(np.asarray(u, float))
        obs, r, term, trunc, info = env.step(u)
        robots.append(np.array(w.robot))
        peds.append(w.crowd_state.positions)
        rewards.append(r)
        stacks.append(obs["lgm"])
        k += 1
        if term or trunc:
            return robots, peds, rewards, stacks, np.array(taken), info


@pytest.mark.parametrize("time_varying", [False, True])
def test_diagram_and_gymnasium_env_give_the_same_trajectory(time_varying):
    cfg = EmoNavConfig()
    cfg.crowd.time_varying_emotions = time_varying
    seed = 12
    rng = np.random.default_rng(0)
    actions = np.column_stack([rng.uniform(0.2, 0.4, 40), rng.uniform(-0.2, 0.2, 40)])
    robots, peds, rewards, _, _, info = _env_rollout(seed, cfg, actions=actions)
    record, log = run_episode(
        sample_scenario(seed, cfg), cfg, ReplayPlanner(actions), goal_radius=0.2, trace=True
    )
    assert record.outcome == info["outcome"] and record.steps == len(rewards)
    assert np.array_equal(np.array(log.robot), np.array(robots))
    for a, b in zip(log.pedestrians, peds, strict=True):
        assert np.array_equal(a, b)
    assert log.rewards[1:] == rewards and np.isnan(log.rewards[0])  # none before step 0
    assert np.array_equal(log.commands, actions[: record.steps])


def test_dwa_episode_matches_and_the_lgm_stack_is_the_envs():
    cfg = EmoNavConfig()
    seed = 3
    robots, peds, rewards, stacks, taken, info = _env_rollout(seed, cfg, planner=DwaPlanner(cfg))
    nav = build_navigation_diagram(
        sample_scenario(seed, cfg), cfg, DwaPlanner(cfg), goal_radius=0.2
    )
    sim = Simulator(nav.diagram)
    sim.set_monitor(episode_monitor_callback(nav.diagram, nav.monitor))
    sim.Initialize()
    ctx = sim.get_mutable_context()
    lgm_port = nav.grid_maps.GetOutputPort("lgm_stack")
    for k in range(5):  # the planner sees the env's observation at every step
        if k > 0:  # (k = 0: right after Initialize, before the events at t = 0)
            sim.AdvanceTo(k * cfg.robot.step_time)
        assert np.array_equal(lgm_port.Eval(nav.grid_maps.GetMyContextFromRoot(ctx)), stacks[k])
    # the simulator's monitor stops exactly at the step that ends the episode
    sim.AdvanceTo(100.0)
    status = nav.monitor.GetOutputPort("status").Eval(nav.monitor.GetMyContextFromRoot(ctx))
    assert status.done and status.record.outcome == info["outcome"] == "success"
    assert ctx.get_time() == pytest.approx(status.record.steps * cfg.robot.step_time)
    assert status.record.total_reward == pytest.approx(sum(rewards))


def test_diagram_clips_out_of_range_commands_with_a_warning_and_rejects_nan(caplog):
    cfg = EmoNavConfig()
    cfg.episode.max_steps = 4
    sc = sample_scenario(0, cfg)
    with caplog.at_level(logging.WARNING):
        record, log = run_episode(sc, cfg, ReplayPlanner([[0.9, 0.5]] * 4), trace=True)
    assert "clipped" in caplog.text
    assert np.allclose(log.robot[2][2], 0.4)  # heading changed by the bound 0.2 per step
    assert log.robot[2][3] == pytest.approx(0.4)  # speed clipped to 0.4
    with pytest.raises(CommandError, match="not finite"):
        run_episode(sc, cfg, ReplayPlanner([[np.nan, 0.0]]))


def test_meshcat_recording_writes_a_self_contained_html(tmp_path):
    from pydrake.geometry import Meshcat

    cfg = EmoNavConfig()
    cfg.episode.max_steps = 5
    out = tmp_path / "replay.html"
    meshcat = Meshcat()
    record, _ = run_episode(
        sample_scenario(4, cfg),
        cfg,
        DwaPlanner(cfg),
        meshcat=meshcat,
        record_html=out,
        show_rays=True,
    )
    html = out.read_text()
    assert record.steps == 5
    assert len(html) > 10_000 and "<html" in html.lower()
    assert meshcat.HasPath("/emonav/pedestrians/0") and meshcat.HasPath("/emonav/rays")


@pytest.mark.parametrize("seed", [84, 63])
def test_episode_records_are_identical(seed):
    # Seeds where the monitor once evaluated a step one ulp late (after the crowd moved).
    cfg = EmoNavConfig()
    env = EmoNavLIPEnv(cfg, goal_radius=0.2, grid_kind="lgm")
    env.reset(seed=seed)
    dwa = DwaPlanner(cfg)
    while not env.world.tracker.done:
        env.step(dwa.plan(env.planner_input()))
    record, _ = run_episode(sample_scenario(seed, cfg), cfg, DwaPlanner(cfg), goal_radius=0.2)
    assert record.to_json() == env.world.record.to_json()


@pytest.mark.slow
@pytest.mark.parametrize(
    ("family", "seed"),
    [("corner_traffic", 6001), ("doorway", 3), ("office", 3), ("t_junction", 5)],
)
def test_the_lip_world_follows_the_global_route_as_the_diagram_does(family, seed):
    """In a scene with walls both worlds follow the route layer's sub-goal
    (`navigation/route_following.py`): the same DWA episode, step for step."""
    cfg = EmoNavConfig()
    cfg.crowd.family = family
    scenario = sample_scenario(seed, cfg)
    assert scenario.walls
    env = EmoNavLIPEnv(cfg, goal_radius=0.2, grid_kind="lgm")
    env.reset(seed=seed)
    w = env.world
    assert w.route is not None and len(w.route_points) >= 2
    dwa, robots, subgoals = DwaPlanner(cfg), [np.array(w.robot)], []
    while not w.tracker.done:
        inp = env.planner_input()
        assert inp.goal_is_subgoal
        subgoals.append(inp.goal_xy)
        env.step(dwa.plan(inp))
        robots.append(np.array(w.robot))
    record, log = run_episode(scenario, cfg, DwaPlanner(cfg), goal_radius=0.2, trace=True)
    assert record.to_json() == w.record.to_json()
    assert np.array_equal(np.array(log.robot), np.array(robots))
    # the sub-goal is not the goal while the route turns (the layer did something)
    assert any(np.linalg.norm(g - scenario.robot_goal) > 0.5 for g in subgoals)


def test_a_saved_lip_world_continues_on_its_route():
    from emonav_drake.navigation.lip_world import NavigationWorld

    cfg = EmoNavConfig()
    cfg.crowd.family = "office"
    scenario = sample_scenario(3, cfg)
    a, dwa = NavigationWorld(scenario, cfg), DwaPlanner(cfg)
    for _ in range(8):
        a.step(dwa.plan(a.planner_input()))
    b = NavigationWorld.from_state_dict(a.state_dict(), cfg)
    assert np.array_equal(b.route_points, a.route_points)
    for _ in range(6):
        ua, ub = dwa.plan(a.planner_input()), dwa.plan(b.planner_input())
        assert np.array_equal(ua, ub)
        a.step(ua)
        b.step(ub)
    assert a.record.to_json() == b.record.to_json()
    # without walls there is no route, and the goal is the goal
    paper = NavigationWorld(sample_scenario(3, EmoNavConfig()), EmoNavConfig())
    assert paper.route is None and not paper.planner_input().goal_is_subgoal


@pytest.mark.slow
def test_the_lip_world_replans_when_a_door_closes_as_the_diagram_does():
    from emonav_drake.navigation.lip_world import NavigationWorld
    from emonav_drake.scenarios import scenario_path
    from emonav_drake.scenarios.scenario import load_scenario

    cfg = EmoNavConfig()
    scenario = load_scenario(scenario_path("closed_door"))
    w, dwa = NavigationWorld(scenario, cfg, goal_radius=0.2), DwaPlanner(cfg)
    first = w.route_points.copy()
    while not w.tracker.done:
        w.step(dwa.plan(w.planner_input()))
    # replanned round the cart through the other door
    assert w.route_points.shape != first.shape or not np.allclose(w.route_points, first)
    record, _ = run_episode(scenario, cfg, DwaPlanner(cfg), goal_radius=0.2)
    assert record.to_json() == w.record.to_json()


def _deployable(family="paper", rings="truth"):
    from emonav_drake.params import apply_deployable

    cfg = EmoNavConfig()
    cfg.crowd.family = family
    apply_deployable(cfg)  # VLP-16 scan with its faults, planners on LiDAR tracks
    cfg.perception.map_rings = rings
    return cfg.validate()


@pytest.mark.parametrize(
    ("family", "seed"), [("paper", 5), pytest.param("office", 3, marks=pytest.mark.slow)]
)
def test_the_lip_world_perceives_through_the_tracker_as_the_diagram_does(family, seed):
    """With LiDAR tracks the LIP world scans and tracks at the diagram's instants
    (`sensing/crowd_perception.py`): DWA, which reads the tracked crowd, walks the same
    episode step for step in both, and what it read were tracks, not the true crowd."""
    cfg = _deployable(family)
    env = EmoNavLIPEnv(cfg, goal_radius=0.2, grid_kind="lgm")
    env.reset(seed=seed)
    w = env.world
    dwa, robots, differs = DwaPlanner(cfg), [np.array(w.robot)], False
    while not w.tracker.done:
        inp = env.planner_input()
        truth = w.crowd.snapshot(w.crowd_state)
        seen = inp.crowd.positions
        differs |= seen.shape != truth.positions.shape or not np.allclose(seen, truth.positions)
        env.step(dwa.plan(inp))
        robots.append(np.array(w.robot))
    assert differs
    record, log = run_episode(
        sample_scenario(seed, cfg), cfg, DwaPlanner(cfg), goal_radius=0.2, trace=True
    )
    assert record.to_json() == w.record.to_json()
    assert np.array_equal(np.array(log.robot), np.array(robots))


def test_grid_maps_ring_the_tracked_people_in_both_worlds():
    """`perception.map_rings: tracks`: the maps' discomfort rings go round the tracked
    pedestrians — the same stacks in the LIP world and the diagram, and not the stacks
    of rings round the true crowd."""
    seed, steps = 5, 8
    cfg, truth_cfg = _deployable(rings="tracks"), _deployable()
    env, env_truth = (EmoNavLIPEnv(c, goal_radius=0.2, grid_kind="lgm") for c in (cfg, truth_cfg))
    obs, _ = env.reset(seed=seed)
    obs_truth, _ = env_truth.reset(seed=seed)
    dwa, stacks, truth_stacks, actions = DwaPlanner(cfg), [obs["lgm"]], [obs_truth["lgm"]], []
    for _ in range(steps):
        actions.append(dwa.plan(env.planner_input()))
        stacks.append(env.step(actions[-1])[0]["lgm"])
        truth_stacks.append(env_truth.step(actions[-1])[0]["lgm"])
    assert any(not np.array_equal(a, b) for a, b in zip(stacks, truth_stacks, strict=True))
    nav = build_navigation_diagram(
        sample_scenario(seed, cfg), cfg, ReplayPlanner(np.array(actions)), goal_radius=0.2
    )
    for k, got in enumerate(diagram_stacks(nav, cfg.robot.step_time, steps)):
        assert np.array_equal(got, stacks[k]), k


def test_the_maps_ring_a_standing_crowd_through_its_still_tracks():
    """Five people converge on the robot's path and stand (robot_crowding); the tracker
    holds a person who stands as a still track (a static disc), not a pedestrian. The
    maps that ring the tracks ring the still tracks too, so each standing person is
    inside a ring, as the planners reading tracks see them (before: no ring at all)."""
    from emonav_drake.crowd.crowd import obstacle_discs
    from emonav_drake.navigation.lip_world import NavigationWorld
    from emonav_drake.sensing.crowd_perception import perceived_inflation

    cfg = _deployable("robot_crowding", rings="tracks")
    w = NavigationWorld(sample_scenario(1, cfg), cfg)
    for _ in range(40):  # the robot stands; the pedestrians walk up and stand
        assert w.step(np.zeros(2))[1] is None
    truth, seen = w.crowd.snapshot(w.crowd_state), w.planner_input().crowd
    standing = truth.positions[np.hypot(*truth.velocities.T) < 0.05]
    assert len(standing) == 5 and len(seen.positions) == 0  # all of them still tracks
    centres = obstacle_discs(perceived_inflation(truth, seen))[0]
    assert len(centres)
    gap = np.linalg.norm(standing[:, None] - centres[None], axis=2).min(axis=1)
    assert (gap < 0.15).all(), gap


def test_a_saved_lip_world_keeps_its_tracks():
    from emonav_drake.navigation.lip_world import NavigationWorld

    cfg = _deployable()
    scenario = sample_scenario(5, cfg)
    a, dwa = NavigationWorld(scenario, cfg), DwaPlanner(cfg)
    for _ in range(6):
        a.step(dwa.plan(a.planner_input()))
    state = a.state_dict()
    assert state["lidar_tracker"]["tracks"]
    b = NavigationWorld.from_state_dict(state, cfg)
    for _ in range(6):
        ua, ub = dwa.plan(a.planner_input()), dwa.plan(b.planner_input())
        assert np.array_equal(ua, ub)
        a.step(ua)
        b.step(ub)
    assert a.record.to_json() == b.record.to_json()
    # a state perceived from tracks does not load into a world that reads the true crowd
    plain = NavigationWorld(scenario, EmoNavConfig())
    before = plain.state_dict()
    with pytest.raises(ValueError, match="perceived from LiDAR tracks"):
        plain.load_state_dict(state)
    assert plain.state_dict()["robot"] == before["robot"]


def test_rings_round_tracks_need_tracks_and_a_grid_map():
    from emonav_drake.navigation.lip_world import NavigationWorld
    from emonav_drake.typed_yaml import ConfigError

    cfg = EmoNavConfig()
    cfg.perception.map_rings = "tracks"
    with pytest.raises(ConfigError, match="perception.map_rings"):
        cfg.validate()
    cfg = _deployable(rings="tracks")
    with pytest.raises(ValueError, match="drlvo"):
        NavigationWorld(sample_scenario(0, cfg), cfg, grid_kind="drlvo")
