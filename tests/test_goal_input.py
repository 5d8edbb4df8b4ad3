"""The goal a policy reads: the goal itself, or the bearing of a guide sub-goal around the
static discs (`navigation/goal_input.py`), through the planner and the DAgger route."""

import math

import numpy as np
import pytest

from emonav_drake.crowd.crowd import CrowdSnapshot
from emonav_drake.navigation import goal_input as gi
from emonav_drake.planning.mpc_guide import GuidePath
from emonav_drake.robot.lip import LipState

R = 0.3  # robot radius [m]


def _crowd(centers, radii, d_static=0.2) -> CrowdSnapshot:
    return CrowdSnapshot(
        positions=np.zeros((0, 2)),
        velocities=np.zeros((0, 2)),
        radius=0.3,
        emotions=np.zeros(0, np.int64),
        discomfort=np.zeros(0),
        static_centers=np.asarray(centers, float).reshape(-1, 2),
        static_radii=np.asarray(radii, float),
        static_discomfort=d_static,
    )


def _clearance(p, q, centers, r_zone) -> np.ndarray:
    d = q - p
    t = np.clip((centers - p) @ d / (d @ d), 0.0, 1.0)
    return np.linalg.norm(centers - p - t[:, None] * d, axis=1) - r_zone


def test_without_a_blocking_disc_the_guide_input_is_the_goal():
    robot, goal = LipState(0.0, 0.0, 0.3, 0.0), np.array([5.0, 0.0])
    free = _crowd([[2.5, 3.0]], [0.3])  # a disc well off the line to the goal
    for crowd in (_crowd([], []), free):
        g = gi.policy_goal_state(robot, goal, crowd, "guide", R)
        np.testing.assert_array_equal(g, gi.policy_goal_state(robot, goal, crowd, "goal", R))
    assert gi.policy_goal_state(robot, goal, free, "goal", R)[0] == pytest.approx(5.0)


def test_a_disc_on_the_line_turns_the_bearing_to_a_subgoal_in_sight_around_it():
    robot, goal = LipState(0.0, 0.0, 0.0, 0.0), np.array([6.0, 0.05])
    centers, radii = np.array([[3.0, 0.0]]), np.array([0.4])
    crowd = _crowd(centers, radii)
    plain = gi.policy_goal_state(robot, goal, crowd, "goal", R)
    guided = gi.policy_goal_state(robot, goal, crowd, "guide", R)
    assert guided[0] == plain[0]  # the distance stays the goal's
    assert abs(guided[1] - plain[1]) > 0.15  # it steers around the disc
    sub = gi.guide_subgoal(robot, goal, crowd, R)
    r_zone = radii + R + crowd.static_discomfort + gi._MPC.discomfort_margin
    assert _clearance(np.zeros(2), sub, centers, r_zone).min() >= -1e-9  # in sight
    assert 0.5 < np.linalg.norm(sub) <= gi.GUIDE_LOOKAHEAD + 1e-9
    bearing = math.atan2(sub[1], sub[0])
    assert guided[1] == pytest.approx(bearing)
    # the mirrored world (y -> -y) turns the other way
    mirrored = gi.policy_goal_state(
        robot, goal * [1, -1], _crowd(centers * [1, -1], radii), "guide", R
    )
    assert np.sign(mirrored[1]) == -np.sign(guided[1])


def test_the_guide_grid_depends_on_the_goal_and_discs_only():
    """The same answer whatever the process computed before (cache cleared or not)."""
    goal = np.array([6.0, 0.05])
    crowd = _crowd([[3.0, 0.0], [4.0, 1.2]], [0.4, 0.3])
    robots = [LipState(0.0, 0.0, 0.0, 0.0), LipState(1.0, -0.4, 0.5, 0.3)]
    first = [gi.policy_goal_state(r, goal, crowd, "guide", R) for r in reversed(robots)]
    gi._guide.cache_clear()
    again = [gi.policy_goal_state(r, goal, crowd, "guide", R) for r in robots]
    np.testing.assert_array_equal(np.array(first[::-1]), np.array(again))


def test_the_guide_follows_the_mpc_guide_path():
    goal, centers, radii = np.array([6.0, 0.05]), np.array([[3.0, 0.0]]), np.array([0.4])
    crowd = _crowd(centers, radii)
    sub = gi.guide_subgoal(LipState(0.0, 0.0, 0.0, 0.0), goal, crowd, R)
    guide = gi._guide(goal.tobytes(), centers.tobytes(), radii.tobytes(), 0.2, R)
    assert isinstance(guide, GuidePath)
    path = guide.path(np.zeros(2))
    assert np.min(np.linalg.norm(path - sub, axis=1)) < 1e-9  # a waypoint of the path


def test_unknown_goal_input_is_refused():
    with pytest.raises(ValueError, match="goal_input = 'waypoint'"):
        gi.check_goal_input("waypoint")
    from emonav_drake.learning.config import DaggerConfig
    from emonav_drake.params import ConfigError

    with pytest.raises(ConfigError, match="goal_input"):
        DaggerConfig(goal_input="waypoint").validate()


def test_a_guide_policy_reads_the_guide_and_an_old_checkpoint_the_goal(tmp_path):
    import torch

    from emonav_drake.navigation.lip_world import NavigationWorld
    from emonav_drake.params import EmoNavConfig
    from emonav_drake.planners.policy import PolicyPlanner, describe_policy
    from emonav_drake.planners.variants import VARIANTS
    from emonav_drake.scenarios.scenario import sample_scenario

    src = VARIANTS["emobipednav_digit_mpc"].checkpoint
    ckpt = torch.load(src, map_location="cpu", weights_only=False)
    assert "goal_input" not in ckpt["observation"]
    ckpt["observation"]["goal_input"] = "guide"
    torch.save(ckpt, tmp_path / "guide.pt")
    old, new = PolicyPlanner(src), PolicyPlanner(tmp_path / "guide.pt")
    assert (old.goal_input, new.goal_input) == ("goal", "guide")
    assert "guide sub-goal" in describe_policy(new.meta)
    cfg = EmoNavConfig()
    # a scenario whose first state has a disc between the robot and its goal
    for seed in range(600_000, 600_050):
        obs = NavigationWorld(sample_scenario(seed, cfg), cfg).planner_input()
        if gi.guide_subgoal(obs.robot, obs.goal_xy, obs.crowd, cfg.robot.radius) is not None:
            break
    else:
        pytest.fail("no blocked start in 50 scenarios")
    np.testing.assert_array_equal(old.goal_state(obs), obs.goal_state())
    assert not np.array_equal(new.goal_state(obs), obs.goal_state())
