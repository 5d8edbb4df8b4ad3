"""The MPC baseline (`planners/mpc.py`): model, behaviour, bounds, fallback, determinism."""

import copy
import math

import numpy as np
import pytest

from emonav_drake.crowd.crowd import CrowdSnapshot
from emonav_drake.diagrams.navigation import run_episode
from emonav_drake.learning.env import EmoNavLIPEnv
from emonav_drake.navigation.lip_world import NavigationWorld, PlannerInput
from emonav_drake.params import ConfigError, EmoNavConfig, load_config
from emonav_drake.planners import make_planner
from emonav_drake.planners.mpc import MpcPlanner
from emonav_drake.robot.lip import LipState, lip_step
from emonav_drake.scenarios.scenario import (
    PedestrianSpec,
    Scenario,
    StaticDiscSpec,
    sample_scenario,
)


def _snapshot(ped_pos=(), ped_vel=(), emotions=(), static=(), radii=()) -> CrowdSnapshot:
    cfg = EmoNavConfig()
    emotions = np.asarray(emotions, dtype=np.int64)
    return CrowdSnapshot(
        positions=np.asarray(ped_pos, dtype=float).reshape(-1, 2),
        velocities=np.asarray(ped_vel, dtype=float).reshape(-1, 2),
        radius=cfg.crowd.pedestrian_radius,
        emotions=emotions,
        discomfort=np.asarray(cfg.reward.emotion_distances())[emotions],
        static_centers=np.asarray(static, dtype=float).reshape(-1, 2),
        static_radii=np.asarray(radii, dtype=float),
        static_discomfort=cfg.reward.static_discomfort,
    )


def _episode(scenario, cfg, planner):
    """Run one episode in the numpy world; returns the record, commands and robot states."""
    world = NavigationWorld(scenario, cfg, goal_radius=cfg.episode.eval_goal_radius, grid_kind=None)
    planner.reset()
    obs = world.planner_input()
    commands, robots = [], [world.robot]
    while True:
        u = planner.plan(obs)
        commands.append(u)
        _, outcome = world.step(u)
        robots.append(world.robot)
        obs = world.planner_input()
        if outcome:
            return world.record, np.array(commands), np.array(robots)


def _in_bounds(u, cfg):
    r = cfg.robot
    return (
        u.shape == (2,)
        and np.all(np.isfinite(u))
        and 0.0 <= u[0] <= r.max_speed
        and -r.max_heading_change <= u[1] <= r.max_heading_change
    )


def test_rollout_is_the_lip_step_map_and_the_jacobian_matches_finite_differences():
    cfg = EmoNavConfig()
    mpc = MpcPlanner(cfg)
    rng = np.random.default_rng(0)
    n = cfg.mpc.horizon_steps
    u = np.column_stack([rng.uniform(0, 0.4, n), rng.uniform(-0.2, 0.2, n)])
    p0, th0, v0 = np.array([0.3, -0.2]), 0.7, 0.25
    pos, phi, dx = mpc.rollout(p0, th0, v0, u[None])
    s = LipState(p0[0], p0[1], th0, v0)
    r = cfg.robot
    for k in range(n):
        s = lip_step(s, u[k, 0], u[k, 1], r.omega, r.step_time)
        assert pos[0, k] == pytest.approx([s.x, s.y], abs=1e-12)
    jac = mpc.jacobian(phi[0], dx[0])  # (N, 2N, 2)
    flat = np.concatenate([u[:, 0], u[:, 1]])
    eps = 1e-6
    for c in range(2 * n):
        e = np.zeros(2 * n)
        e[c] = eps
        up = (flat + e).reshape(2, n).T
        um = (flat - e).reshape(2, n).T
        fd = (mpc.rollout(p0, th0, v0, up[None])[0] - mpc.rollout(p0, th0, v0, um[None])[0])[0]
        assert jac[:, c, :] == pytest.approx(fd / (2 * eps), abs=1e-7)


def test_empty_world_walks_straight_to_the_goal_at_the_speed_limit():
    cfg = EmoNavConfig()
    mpc = MpcPlanner(cfg)
    record, commands, robots = _episode(Scenario(), cfg, mpc)
    assert record.outcome == "success" and mpc.fallbacks == 0
    # straight: no turn, the robot stays on the line y = 0 facing the goal
    assert np.abs(commands[:, 1]).max() < 1e-6
    assert np.abs(robots[:, 1]).max() < 1e-6 and np.abs(robots[:, 2]).max() < 1e-6
    # at the speed limit all the way, except for slowing down at the goal itself
    full = 2 * math.tanh(cfg.robot.omega * cfg.robot.step_time / 2) / cfg.robot.omega * 0.4
    cruising = robots[:-1, 0] < cfg.robot.goal[0] - 3 * full
    assert commands[cruising, 0] == pytest.approx(cfg.robot.max_speed, abs=1e-4)
    # the fewest steps possible at 0.4 m/s: the first step starts from rest
    needed = 8.0 - cfg.episode.eval_goal_radius
    assert record.steps <= math.ceil((needed - full / 2) / full) + 2


@pytest.mark.parametrize("y", [0.0, 0.1, -0.1])
def test_avoids_a_static_disc_on_the_straight_line(y):
    cfg = EmoNavConfig()
    disc = StaticDiscSpec(center=[0.0, y], radius=0.4)
    mpc = MpcPlanner(cfg)
    record, commands, robots = _episode(Scenario(obstacles=[disc]), cfg, mpc)
    assert record.outcome == "success" and mpc.fallbacks == 0
    gap = np.hypot(robots[:, 0] - 0.0, robots[:, 1] - y) - disc.radius
    assert gap.min() > cfg.robot.radius  # no contact
    # it goes round the disc without entering the discomfort zone (d_static = 0.2 m)
    assert gap.min() >= cfg.robot.radius + cfg.reward.static_discomfort
    assert record.discomfort_steps == 0
    assert np.abs(robots[:, 1]).max() > 0.5  # it did leave the straight line
    assert record.steps < 75  # and did not dawdle (a straight run takes 57 steps)


def test_gets_out_of_a_pocket_formed_by_discs():
    """Two discs too close to pass between, with the robot heading into the gap."""
    cfg = EmoNavConfig()
    discs = [StaticDiscSpec([-1.0, 0.45], 0.4), StaticDiscSpec([-1.0, -0.45], 0.4)]
    record, _, robots = _episode(Scenario(obstacles=discs), cfg, MpcPlanner(cfg))
    assert record.outcome == "success"
    assert np.abs(robots[:, 1]).max() > 1.0  # round one of them


@pytest.mark.slow
def test_commands_stay_within_bounds_over_many_random_problems():
    cfg = EmoNavConfig()
    mpc = MpcPlanner(cfg)
    rng = np.random.default_rng(1)
    for trial in range(300):
        p = rng.integers(0, 5)
        s = rng.integers(0, 4)
        robot_xy = rng.uniform(-4, 4, 2)
        obs = PlannerInput(
            robot=LipState(*robot_xy, rng.uniform(-np.pi, np.pi), rng.uniform(0, 0.4)),
            goal_xy=rng.uniform(-5, 5, 2) if trial % 10 else robot_xy.copy(),
            last_command=np.array([rng.uniform(0, 0.4), rng.uniform(-0.2, 0.2)]),
            crowd=_snapshot(
                robot_xy + rng.uniform(-2, 2, (p, 2)),
                rng.uniform(-1, 1, (p, 2)),
                rng.integers(0, 3, p),
                robot_xy + rng.uniform(-2, 2, (s, 2)),
                rng.uniform(0.2, 0.4, s),
            ),
            lgm_stack=None,
            step=int(rng.integers(0, 3)),  # sometimes the next step: warm starts
        )
        u = mpc.plan(obs)
        assert _in_bounds(u, cfg), (trial, u)
    assert mpc.plans == 300


def test_degenerate_problems_give_a_valid_command():
    cfg = EmoNavConfig()
    mpc = MpcPlanner(cfg)
    here = np.array([1.0, -1.0])
    cases = [
        _snapshot([here], [[0.0, 0.0]], [2]),  # a pedestrian exactly on the robot
        _snapshot(static=[here], radii=[0.4]),  # a disc centred on the robot
        _snapshot([here + [0.5, 0.0]] * 4, [[-1.0, 0.0]] * 4, [2] * 4),  # a wall charging
        _snapshot(),
    ]
    for i, crowd in enumerate(cases):
        for goal in (here, here + [3.0, 0.0], here + [-50.0, 20.0]):
            obs = PlannerInput(
                LipState(*here, math.pi, 0.4), goal, np.array([0.4, -0.2]), crowd, None, i
            )
            assert _in_bounds(mpc.plan(obs), cfg)


@pytest.mark.slow
def test_commands_stay_within_bounds_in_random_episodes():
    cfg = EmoNavConfig()
    mpc = MpcPlanner(cfg)
    for seed in range(1000, 1012):
        world = NavigationWorld(sample_scenario(seed, cfg), cfg, grid_kind=None)
        mpc.reset()
        for _ in range(40):
            u = mpc.plan(world.planner_input())
            assert _in_bounds(u, cfg)
            if world.step(u)[1]:
                break


def test_infeasible_problem_falls_back_to_slowing_down_and_is_counted():
    cfg = EmoNavConfig()
    mpc = MpcPlanner(cfg)
    # a disc right under the robot: the hard contact constraint cannot be met
    obs = PlannerInput(
        robot=LipState(0.0, 0.0, 0.3, 0.4),
        goal_xy=np.array([4.0, 0.0]),
        last_command=np.array([0.4, 0.1]),
        crowd=_snapshot(static=[[0.05, 0.0]], radii=[0.3]),
        lgm_stack=None,
        step=7,
    )
    u = mpc.plan(obs)
    assert mpc.fallbacks == 1 and mpc.last_info["fallback"]
    assert u == pytest.approx([cfg.mpc.fallback_speed_scale * 0.4, 0.0])  # slower, same heading
    assert _in_bounds(u, cfg)
    # and the planner carries on normally once the problem is feasible again
    free = PlannerInput(
        obs.robot, obs.goal_xy, obs.last_command, _snapshot(), lgm_stack=None, step=8
    )
    u = mpc.plan(free)
    assert mpc.fallbacks == 1 and not mpc.last_info["fallback"] and _in_bounds(u, cfg)


def test_pedestrian_on_collision_course_is_avoided():
    cfg = EmoNavConfig()
    ped = PedestrianSpec(start=[2.0, 0.0], goal=[-6.0, 0.0], emotion="negative")
    mpc = MpcPlanner(cfg)
    record, _, robots = _episode(Scenario(pedestrians=[ped]), cfg, mpc)
    assert record.outcome == "success"
    assert record.min_ped_distance > cfg.robot.radius + cfg.crowd.pedestrian_radius


@pytest.mark.slow
def test_deterministic_and_replanning_the_same_step_gives_the_same_command():
    cfg = EmoNavConfig()
    sc = sample_scenario(5, cfg)
    a = _episode(sc, cfg, MpcPlanner(cfg))
    planner = MpcPlanner(cfg)
    b = _episode(sc, cfg, planner)
    assert np.array_equal(a[1], b[1]) and a[0] == b[0]
    # a reused planner (after reset) gives the same episode again
    c = _episode(sc, cfg, planner)
    assert np.array_equal(a[1], c[1])
    # planning a step twice with the same memory changes nothing, and the memory given
    # is not modified (the diagram keeps it in the Context)
    world = NavigationWorld(sc, cfg, grid_kind=None)
    p = MpcPlanner(cfg)
    memory = p.initial_memory()
    for k in range(15):
        obs = world.planner_input()
        before = copy.deepcopy(memory)
        u1, m1 = p.plan_with_memory(obs, memory)
        u2, m2 = p.plan_with_memory(obs, memory)
        assert np.array_equal(u1, u2) and np.array_equal(u1, a[1][k])
        assert np.array_equal(m1.plan.u, m2.plan.u) and np.array_equal(m1.plan.y, m2.plan.y)
        assert np.array_equal(memory.plan.u, before.plan.u) if k else memory.plan is None
        memory = m1
        world.step(u1)


@pytest.mark.slow
def test_works_as_a_policy_on_the_gymnasium_env_and_in_the_diagram():
    env = EmoNavLIPEnv(goal_radius=0.2)
    env.reset(seed=4)
    mpc = make_planner("mpc", env.config)
    assert isinstance(mpc, MpcPlanner) and mpc.name == "mpc"
    commands = []
    while True:
        u = mpc.plan(env.unwrapped.planner_input())
        assert env.action_space.contains(u.astype(np.float32))
        commands.append(u)
        _, _, term, trunc, info = env.step(u)
        if term or trunc:
            break
    assert info["outcome"] == "success"
    # the Drake diagram with the same planner walks the same episode
    record, log = run_episode(
        sample_scenario(4, env.config), env.config, mpc, goal_radius=0.2, trace=True
    )
    assert record.outcome == "success" and record.steps == len(commands)
    assert np.array_equal(np.array(log.commands), np.array(commands))


def test_mpc_params_are_validated():
    assert load_config().mpc.horizon_steps == 8
    with pytest.raises(ConfigError, match=r"mpc\.horizon_steps"):
        load_config(data="mpc: {horizon_steps: 1}")
    with pytest.raises(ConfigError, match=r"mpc\.prediction_discount"):
        load_config(data="mpc: {prediction_discount: 1.5}")


def test_a_wall_clock_cut_is_counted_and_warned(caplog):
    """OSQP's wall-clock limit is a safety: every solve it cuts is counted and logged (a
    limit of 1e-6 s, far below one ADMM iteration here, cuts every QP that iterates)."""
    cfg = load_config()
    cfg.mpc.time_limit = 1e-6
    cfg.episode.max_steps = 8
    mpc = MpcPlanner(cfg)
    with caplog.at_level("WARNING", logger="emonav_drake.planners.mpc"):
        _episode(sample_scenario(3, cfg), cfg, mpc)
    assert mpc.time_limit_hits > 0
    assert caplog.text.count("wall-clock safety") == mpc.time_limit_hits
    # the default (1 s) never fires on the same episode
    quiet = MpcPlanner(load_config())
    _episode(sample_scenario(3, cfg), cfg, quiet)
    assert quiet.time_limit_hits == 0
