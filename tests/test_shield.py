"""The LGM safety shield (`planning/lgm_shield.py`, `planners/shield.py`) with the real
shipped policy, the real LIP step map and the real fitted Digit response."""

import dataclasses as dc
import math

import numpy as np
import pytest

from emonav_drake.navigation.lip_world import NavigationWorld
from emonav_drake.params import EmoNavConfig, EpisodeParams
from emonav_drake.planners import SHIELDED, configure_for, make_planner
from emonav_drake.planners.model_aware import load_response
from emonav_drake.planners.policy import PolicyError, PolicyPlanner
from emonav_drake.planners.shield import ShieldedPolicy
from emonav_drake.planners.variants import shipped_checkpoint
from emonav_drake.planning.lgm_shield import (
    ShieldParams,
    body_labels,
    body_velocities,
    brake_plans,
    lgm_hit_points,
    moving_points,
    path_gaps,
    shield_choice,
    to_world,
    zone_intrusion,
)
from emonav_drake.robot.lip import LipState, held_plans, lip_in_step, lip_rollout, lip_step
from emonav_drake.scenarios.scenario import Scenario, StaticDiscSpec, sample_scenario
from emonav_drake.sensing.grid_maps import lgm_frame


def test_hit_points_lie_on_the_seen_side_of_the_disc():
    cfg = EmoNavConfig()
    li = cfg.lidar
    center, radius = np.array([1.5, 0.4]), 0.3
    frame = lgm_frame(
        (0.0, 0.0), 0.0, center[None], [radius], [0.5], li.num_beams, li.grid_size, li.max_range
    )
    pts = lgm_hit_points(frame, li.num_beams, li.max_range)
    assert len(pts) > 3
    ring = li.max_range / li.grid_size
    arc = 2 * math.pi / li.grid_size * np.linalg.norm(center)  # one sector's width there
    dist = np.linalg.norm(pts - center, axis=1)
    # each point is its hit moved to the sector's centre line (≤ half a sector across the
    # beam) and to the ring's near edge (≤ one ring along it)
    assert (np.abs(dist - radius) <= math.hypot(arc / 2, ring) + 1e-9).all()
    # the seen side faces the robot
    assert (np.linalg.norm(pts, axis=1) < np.linalg.norm(center)).all()
    assert lgm_hit_points(np.zeros((100, 100), np.uint8), li.num_beams, li.max_range).shape == (
        0,
        2,
    )
    with pytest.raises(ValueError, match="square"):
        lgm_hit_points(np.zeros((4, 5), np.uint8), li.num_beams, li.max_range)


def test_points_of_a_still_disc_stay_still_as_the_robot_walks_and_a_pedestrian_moves():
    """Two frames 0.4 s apart from a robot that walked 0.16 m and turned: the disc's points
    match the previous frame's in the world; a pedestrian that walked 0.3 m does not."""
    li = EmoNavConfig().lidar
    disc, ped = np.array([2.0, 0.8]), np.array([1.8, -1.2])
    poses = [np.array([0.0, 0.0, 0.0]), np.array([0.16, 0.02, 0.15])]
    peds = [ped, ped + [0.0, 0.3]]
    world = []
    for pose, p in zip(poses, peds, strict=True):
        frame = lgm_frame(
            pose[:2], pose[2], np.stack([disc, p]), [0.3, 0.3], [0.2, 0.5],
            li.num_beams, li.grid_size, li.max_range,
        )  # fmt: skip
        world.append(to_world(lgm_hit_points(frame, li.num_beams, li.max_range), pose))
    p = ShieldParams()
    near_disc = np.linalg.norm(world[1] - disc, axis=1) < 0.5
    assert near_disc.any() and (~near_disc).any()
    # point by point, part of the pedestrian's seen side lies where it was seen before ...
    alone = moving_points(world[1], world[0], p.static_match)
    assert not alone[near_disc].any() and 0 < alone[~near_disc].mean() < 1
    # ... as one body it all moves, and the disc stays still
    moving = moving_points(world[1], world[0], p.static_match, p.body)
    assert not moving[near_disc].any() and moving[~near_disc].all()
    assert moving_points(world[1], None, 0.12).all()  # the first step: nothing is known


def test_lip_rollout_is_the_step_map_step_by_step():
    r = EmoNavConfig().robot
    start = LipState(0.5, -1.0, 0.3, 0.25)
    plans = np.array([[[0.4, 0.2], [0.0, 0.0]], [[0.1, -0.3], [0.3, 0.1]]])
    paths = lip_rollout(start, plans, r.omega, r.step_time)
    for c in range(2):
        s = start
        for h in range(2):
            u = plans[c, h]
            mid = lip_in_step(s, u[0], u[1], r.omega, r.step_time, r.step_time / 2)
            s = lip_step(s, u[0], u[1], r.omega, r.step_time)
            np.testing.assert_allclose(paths[c, 2 * h], [mid.x, mid.y], atol=1e-12)
            np.testing.assert_allclose(paths[c, 2 * h + 1], [s.x, s.y], atol=1e-12)
    with pytest.raises(ValueError, match="plans"):
        lip_rollout(start, np.zeros((3, 2)), r.omega, r.step_time)


def test_response_plans_extend_the_held_rollout():
    model = load_response("digit")
    start, committed = LipState(1.0, 2.0, 0.3, 0.25), np.array([[0.3, 0.1], [0.4, -0.2]])
    cand = np.array([[0.4, 0.0], [0.2, 0.3], [0.0, -0.3]])
    np.testing.assert_array_equal(
        model.rollout_plans(start, committed, held_plans(cand, 3)),
        model.rollout(start, committed, cand, 3),
    )
    braked = model.rollout_plans(start, committed, brake_plans(cand, 2))
    np.testing.assert_array_equal(braked[:, :2], model.rollout(start, committed, cand, 1))
    # Digit answers a step late: the first step is u_{k−1}'s whatever the candidate
    assert np.ptp(braked[:, 1, 0]) < 0.05


def test_shield_choice_takes_the_best_admissible_else_the_widest_gap():
    scores = np.array([3.0, 2.0, 1.0])
    assert shield_choice(scores, np.array([0.1, 0.5, 0.9]), 0.4) == (1, True)
    assert shield_choice(scores, np.array([0.5, 0.5, 0.9]), 0.4) == (0, True)
    assert shield_choice(scores, np.array([0.1, 0.3, 0.3]), 0.4) == (1, False)
    assert path_gaps(np.zeros((2, 4, 2)), np.zeros((0, 2))).tolist() == [np.inf, np.inf]
    with pytest.raises(ValueError, match="margin"):
        ShieldParams(margin=-0.1)
    with pytest.raises(ValueError, match="brake_steps"):
        ShieldParams(brake_steps=-1)


def _facing_a_disc(cfg: EmoNavConfig, speed: float, gap: float):
    """A LIP world whose robot walks at `speed` straight at a disc whose surface is `gap`
    ahead of its centre, with the goal behind the disc."""
    scenario = Scenario(
        obstacles=[StaticDiscSpec(center=[-4.0 + gap + 0.3, 0.0], radius=0.3)],
        robot_start=[-4.0, 0.0],
        robot_goal=[4.0, 0.0],
    )
    world = NavigationWorld(scenario, cfg, goal_radius=EpisodeParams.eval_goal_radius)
    world.robot = LipState(-4.0, 0.0, 0.0, speed)
    return world


def test_the_shield_stops_the_shipped_policy_short_of_a_disc_ahead():
    cfg0 = EmoNavConfig()
    policy = PolicyPlanner(shipped_checkpoint("emobipednav"), robot_radius=cfg0.robot.radius)
    cfg, _ = configure_for(policy, cfg0)
    shield = ShieldedPolicy(policy, cfg, params=ShieldParams(margin=0.1))
    obs = _facing_a_disc(cfg, 0.4, 0.55).planner_input()
    scores = policy.command_scores(obs.lgm_stack, policy.goal_state(obs), obs.last_command)
    paths = shield.predicted_paths(obs, shield.initial_memory())
    pts = lgm_hit_points(obs.lgm_stack[-1], cfg.lidar.num_beams, cfg.lidar.max_range)
    gaps = path_gaps(paths, pts)
    clearance = cfg.robot.radius + 0.1
    # walking on at full speed would not stop clear; the shield's command does
    full_ahead = int(np.argmin(np.abs(policy.commands - [0.4, 0.0]).sum(axis=1)))
    assert gaps[full_ahead] < clearance
    u = shield.plan(obs)
    chosen = int(np.flatnonzero((policy.commands == u).all(axis=1))[0])
    assert shield.last_admissible and gaps[chosen] >= clearance
    assert scores[chosen] == scores[gaps >= clearance].max()
    # with nothing in reach the shield is transparent: the policy's own command
    free = _facing_a_disc(cfg, 0.4, 4.0).planner_input()
    np.testing.assert_array_equal(shield.plan(free), policy.plan(free))
    assert shield.last_admissible


def test_the_shield_refuses_a_policy_it_cannot_shield():
    cfg = EmoNavConfig()
    for name in ("ogm", "lidar_sac"):
        policy = PolicyPlanner(shipped_checkpoint(name), robot_radius=cfg.robot.radius)
        with pytest.raises(PolicyError, match="LGM shield needs a categorical policy"):
            ShieldedPolicy(policy, cfg)


@pytest.mark.slow
@pytest.mark.parametrize("name", [n + s for n in SHIELDED for s in ("", "_digit")])
def test_shielded_planners_run_a_seeded_episode_on_both_plants(sim_on_both_plants, name):
    """By name through `emonav sim`: a whole LIP episode and 6 Digit steps, twice each to
    the same record; the Digit kind remembers u_{k−2} and the previous pose."""
    records = sim_on_both_plants(["--planner", name], 11)
    assert records["lip"]["outcome"] in ("success", "collision", "timeout")
    assert records["digit"]["steps"] == 6 and records["digit"]["path_length"] > 0.3
    planner = make_planner(name, EmoNavConfig())
    assert (planner.initial_memory().response is None) == (not name.endswith("_digit"))


def test_the_shield_turns_a_collision_of_the_mpc_routes_policy_into_a_success():
    """Tuning seed 700 075 in the LIP world (docs/shield.md): the MPC route's student (the
    default policy when the shield was tuned; `policy_shield`'s default) walks into a
    pedestrian; behind the shield, with nothing else changed, it reaches the goal and at
    least one of its steps was the shield's choice, not the policy's."""
    cfg0 = EmoNavConfig()
    outcomes, overridden = {}, 0
    student = shipped_checkpoint("emobipednav_digit_mpc")
    for name in ("policy", "policy_shield"):
        planner = make_planner(name, cfg0, student)
        cfg, _ = configure_for(planner, cfg0)
        world = NavigationWorld(
            sample_scenario(700_075, cfg), cfg, goal_radius=EpisodeParams.eval_goal_radius
        )
        outcome = None
        while outcome is None:
            obs = world.planner_input()
            u = planner.plan(obs)
            if name == "policy_shield":
                overridden += not np.array_equal(u, planner.policy.plan(obs))
            _, outcome = world.step(u)
        outcomes[name] = outcome
    assert outcomes == {"policy": "collision", "policy_shield": "success"}
    assert overridden > 0


def test_a_body_moves_at_its_measured_velocity():
    """Two frames of a pedestrian walking 0.2 m towards a robot that stands still: its
    points get ≈ its 0.5 m/s (the centroid of the seen side moves with it), the disc's 0;
    a point moving at that velocity closes the gap of a path that holds still."""
    li = EmoNavConfig().lidar
    disc, ped, pose = np.array([2.0, 1.0]), np.array([2.0, -0.8]), np.zeros(3)
    frames = []
    for p in (ped, ped - [0.2, 0.0]):
        frame = lgm_frame(
            pose[:2], 0.0, np.stack([disc, p]), [0.3, 0.3], [0.2, 0.2],
            li.num_beams, li.grid_size, li.max_range,
        )  # fmt: skip
        frames.append(to_world(lgm_hit_points(frame, li.num_beams, li.max_range), pose))
    v = body_velocities(frames[1], frames[0], 0.25, 0.4, 1.5)
    on_ped = np.linalg.norm(frames[1] - (ped - [0.2, 0.0]), axis=1) < 0.5
    # the seen side's centroid also slides as the angle of view changes: ≈ 0.12 m/s here
    np.testing.assert_allclose(v[on_ped].mean(axis=0), [-0.5, 0.0], atol=0.15)
    assert np.abs(v[~on_ped]).max() < 0.08
    assert (body_labels(frames[1], 0.25)[on_ped] != body_labels(frames[1], 0.25)[~on_ped][0]).all()
    still_path = np.zeros((1, 2, 2))
    points, vel = np.array([[1.0, 0.0]]), np.array([[-1.0, 0.0]])
    assert path_gaps(still_path, points)[0] == 1.0
    assert path_gaps(still_path, points, None, vel, np.array([0.2, 0.4]))[0] == pytest.approx(0.6)


def test_zone_intrusion_is_the_depth_into_the_nearest_zone():
    paths = np.array([[[0.0, 0.0], [0.5, 0.0]], [[0.0, 0.0], [0.0, 0.5]]])
    points = np.array([[1.0, 0.0]])
    np.testing.assert_allclose(zone_intrusion(paths, points, 0.6), [0.1, 0.0])
    assert zone_intrusion(paths, np.zeros((0, 2)), 0.6).tolist() == [0.0, 0.0]
    with pytest.raises(ValueError, match="comfort_weight needs static_margin"):
        ShieldParams(comfort_weight=10.0, static_margin=None)
    with pytest.raises(ValueError, match="1/m"):
        ShieldParams(comfort_weight=-1.0)


def test_the_comfort_weight_steers_the_shield_out_of_a_still_discs_zone():
    """A disc just right of the robot's line, seen in two frames (so its points are
    still): with `comfort_weight` the shield's command reaches less deep into the disc's
    discomfort zone than the policy's admissible best, which enters it."""
    cfg0 = EmoNavConfig()
    policy = PolicyPlanner(shipped_checkpoint("emobipednav"), robot_radius=cfg0.robot.radius)
    cfg, _ = configure_for(policy, cfg0)
    scenario = Scenario(
        obstacles=[StaticDiscSpec(center=[-3.55, -0.5], radius=0.3)],
        robot_start=[-4.0, 0.0],
        robot_goal=[4.0, 0.0],
    )
    world = NavigationWorld(scenario, cfg, goal_radius=EpisodeParams.eval_goal_radius)
    world.robot = LipState(-4.0, 0.0, 0.0, 0.3)
    first = world.planner_input()
    chosen, depth = {}, {}
    for weight in (0.0, 200.0):
        shield = ShieldedPolicy(policy, cfg, params=ShieldParams(comfort_weight=weight))
        _, memory = shield.plan_with_memory(first, shield.initial_memory())
        obs = dc.replace(first, step=first.step + 1)  # the same frame again: every point still
        u, _ = shield.plan_with_memory(obs, memory)
        i = int(np.flatnonzero((policy.commands == u).all(axis=1))[0])
        paths = shield.predicted_paths(obs, memory)
        pts = lgm_hit_points(obs.lgm_stack[-1], cfg.lidar.num_beams, cfg.lidar.max_range)
        intrusion = shield.static_intrusion(paths, pts, np.zeros(len(pts), bool))
        chosen[weight], depth[weight] = i, intrusion
        assert shield.last_admissible
    assert depth[0.0][chosen[0.0]] > 0.0  # the policy's own choice enters the zone
    assert depth[200.0][chosen[200.0]] < depth[0.0][chosen[0.0]]
