import gymnasium
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

from emonav_drake.learning.env import EmoNavLIPEnv
from emonav_drake.navigation.lip_world import CommandError
from emonav_drake.planners.dwa import DwaPlanner


def test_make_by_id_and_env_checker():
    env = gymnasium.make("emonav_drake:EmoNavLIP-v0")
    check_env(env.unwrapped, skip_render_check=True)
    obs, info = env.reset(seed=3)
    assert obs["lgm"].shape == (9, 100, 100) and obs["lgm"].dtype == np.uint8
    assert obs["goal"].shape == (2,) and obs["last_action"].shape == (2,)
    assert obs["goal"][0] == pytest.approx(8.0)  # (−4, 0) → (4, 0)
    # on reset the first frame is repeated N times
    assert all(np.array_equal(obs["lgm"][0], f) for f in obs["lgm"])
    assert info["scenario_seed"] == 3


def test_same_seed_same_trajectory():
    def rollout(seed):
        env = EmoNavLIPEnv()
        env.reset(seed=seed)
        env.action_space.seed(seed)
        out = []
        for _ in range(20):
            obs, r, term, trunc, _ = env.step(env.action_space.sample())
            out.append((obs["lgm"].copy(), r))
            if term or trunc:
                break
        return out

    a, b = rollout(5), rollout(5)
    assert len(a) == len(b)
    assert all(np.array_equal(x[0], y[0]) and x[1] == y[1] for x, y in zip(a, b, strict=True))


def test_bad_actions_are_rejected_with_a_clear_error():
    env = EmoNavLIPEnv()
    env.reset(seed=0)
    for bad in ([np.nan, 0.0], [0.5, 0.0], [-0.1, 0.0], [0.2, 0.3], [0.1]):
        with pytest.raises(CommandError, match="command"):
            env.step(np.array(bad, dtype=np.float32))
    # nothing was lost: the episode continues from where it was
    obs, *_ = env.step(np.array([0.4, 0.0], dtype=np.float32))
    assert obs["last_action"][0] == pytest.approx(0.4)
    with pytest.raises(RuntimeError, match="reset"):
        EmoNavLIPEnv().step(np.zeros(2, dtype=np.float32))


def test_dwa_as_a_policy_reaches_the_goal_and_the_episode_ends():
    env = EmoNavLIPEnv(goal_radius=0.2)
    env.reset(seed=1)
    dwa = DwaPlanner(env.config)
    total, steps = 0.0, 0
    while True:
        _, r, term, trunc, info = env.step(dwa.plan(env.planner_input()))
        total, steps = total + r, steps + 1
        if term or trunc:
            break
    assert info["outcome"] == "success" and term and not trunc
    assert info["episode_record"]["steps"] == steps
    assert total == pytest.approx(info["episode_record"]["total_reward"])
    # the progress rewards telescope: 0.3 · (8 − final distance) + 0.5 on arrival, less penalties
    assert total <= 0.3 * 8.0 + 0.5 + 1e-9
    with pytest.raises(RuntimeError, match="ended"):
        env.step(np.zeros(2, dtype=np.float32))


def test_ogm_variant_and_timeout_truncates():
    env = EmoNavLIPEnv(grid_kind="ogm")
    env.config.episode.max_steps = 3
    env.reset(seed=2)
    flags = [env.step(np.zeros(2, dtype=np.float32))[2:4] for _ in range(3)]
    assert flags[-1] == (False, True)  # truncated, not terminated
    with pytest.raises(ValueError, match="grid_kind"):
        EmoNavLIPEnv(grid_kind="polar")
