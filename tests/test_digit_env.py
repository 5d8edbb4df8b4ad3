"""`EmoNavDigit-v0`: the Digit navigation diagram as a Gymnasium env (pydrake.gym).

It passes gymnasium's env checker, has `EmoNavLIP-v0`'s spaces, and the same seed and
actions give the same trajectory, rewards and record as the Digit diagram driven by a
planner that replays those actions.
"""

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import emonav_drake  # noqa: F401  (registers the environments)
from emonav_drake.diagrams.navigation_digit import run_digit_episode
from emonav_drake.learning.digit_env import EmoNavDigitEnv
from emonav_drake.learning.env import EmoNavLIPEnv
from emonav_drake.navigation.lip_world import CommandError
from emonav_drake.params import EmoNavConfig
from emonav_drake.planners.replay import ReplayPlanner
from emonav_drake.scenarios.scenario import sample_scenario


def _short(steps: int) -> EmoNavConfig:
    cfg = EmoNavConfig()
    cfg.episode.max_steps = steps
    return cfg


@pytest.mark.slow
def test_the_env_checker_passes_and_the_spaces_are_the_lip_envs():
    env = gym.make("emonav_drake:EmoNavDigit-v0", config=_short(3)).unwrapped
    assert isinstance(env, EmoNavDigitEnv)
    lip = EmoNavLIPEnv(_short(3))
    assert env.observation_space == lip.observation_space
    assert env.action_space == lip.action_space
    check_env(env, skip_render_check=True)


@pytest.mark.slow
def test_same_seed_and_actions_give_the_diagrams_trajectory():
    cfg = _short(6)
    seed = 7
    rng = np.random.default_rng(0)
    actions = np.column_stack([rng.uniform(0.2, 0.4, 6), rng.uniform(-0.2, 0.2, 6)])
    env = EmoNavDigitEnv(cfg)
    obs, info = env.reset(seed=seed)
    assert info["scenario_seed"] == seed
    robots, rewards, last = [], [], None
    for k, a in enumerate(actions):
        np.testing.assert_array_equal(obs["last_action"], np.float32(last if k else [0, 0]))
        obs, reward, terminated, truncated, info = env.step(a)
        robots.append(env.navigation.station.GetOutputPort("robot_state").Eval(
            env.navigation.station.GetMyContextFromRoot(env.simulator.get_context())
        ).copy())  # fmt: skip
        rewards.append(reward)
        last = a
        if terminated or truncated:
            break
    assert truncated and info["outcome"] == "timeout" and len(rewards) == 6
    record, trace = run_digit_episode(
        sample_scenario(seed, cfg), cfg, ReplayPlanner(actions), trace=True
    )
    np.testing.assert_allclose(np.array(robots), np.array(trace.robot[1:7]), atol=1e-9)
    env_record = info["episode_record"]
    assert env_record["steps"] == record.steps == 6
    assert env_record["total_reward"] == pytest.approx(record.total_reward, abs=1e-9)
    assert sum(rewards) == pytest.approx(record.total_reward, abs=1e-9)
    with pytest.raises(RuntimeError, match="reset"):
        env.step(actions[0])


def test_invalid_actions_raise_like_the_lip_env():
    env = EmoNavDigitEnv(_short(3))
    env.reset(seed=1)
    with pytest.raises(CommandError):
        env.step(np.array([np.nan, 0.0]))
    with pytest.raises(CommandError):
        env.step(np.array([0.9, 0.0]))
