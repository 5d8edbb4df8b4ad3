"""SAC directly on `EmoNavDigit-v0` (the paper's route, for a GPU or a cluster), tiny scale.

The real Digit diagram, the real networks: a few environment steps and updates write a
loadable SAC actor that runs in the Digit diagram; an interrupted run resumes bit-for-bit
(the Digit env continues a saved episode by applying its commands again).
"""

import numpy as np
import pytest

from emonav_drake.diagrams.navigation_digit import run_digit_episode
from emonav_drake.learning.digit_env import EmoNavDigitEnv
from emonav_drake.learning.run_state import SAC_FORMAT, read_run_state
from emonav_drake.learning.sac_config import SacConfig
from emonav_drake.learning.sac_trainer import make_env, train_sac
from emonav_drake.params import ConfigError, EmoNavConfig
from emonav_drake.planners import configure_for, make_planner
from emonav_drake.scenarios.scenario import sample_scenario
from tests.state_equality import assert_equal_state


def _tiny(**kw) -> SacConfig:
    base = dict(
        plant="digit",
        grid_kind="lgm",
        num_frames=2,
        grid_size=50,
        pool=2,
        filters=4,
        features=8,
        hidden=16,
        total_steps=8,
        random_steps=3,
        replay_size=64,
        batch_size=4,
        eval_every=10_000,
        checkpoint_every=10_000,
        seed=3,
        threads=1,
    )
    return SacConfig(**(base | kw)).validate()


def test_the_plant_is_validated_and_selects_the_digit_env():
    with pytest.raises(ConfigError, match="plant = 'atlas' is invalid"):
        SacConfig(plant="atlas").validate()
    env = make_env(_tiny())
    assert isinstance(env, EmoNavDigitEnv)
    assert env.observation_space["lgm"].shape == (2, 50, 50)


@pytest.mark.slow
def test_a_saved_digit_episode_continues_exactly():
    cfg = EmoNavConfig()
    cfg.episode.max_steps = 8
    rng = np.random.default_rng(1)
    commands = np.column_stack([rng.uniform(0.2, 0.4, 6), rng.uniform(-0.2, 0.2, 6)])
    a = EmoNavDigitEnv(cfg)
    a.reset(seed=5)
    for c in commands[:3]:
        a.step(c)
    state = a.state_dict()
    assert len(state["commands"]) == 3 and state["reset_seed"] == 5
    b = EmoNavDigitEnv(cfg)
    b.load_state_dict(state)
    for c in commands[3:]:
        oa, ra, ta, tra, _ = a.step(c)
        ob, rb, tb, trb, _ = b.step(c)
        assert ra == rb and (ta, tra) == (tb, trb)
        for key in oa:
            np.testing.assert_array_equal(oa[key], ob[key])
    assert a.np_random.bit_generator.state == b.np_random.bit_generator.state
    with pytest.raises(ValueError, match="saved map kind 'lgm' != 'ogm'"):
        EmoNavDigitEnv(cfg, grid_kind="ogm").load_state_dict(state)
    too_many = state | {"commands": state["commands"] + [[0.3, 0.0]] * 8}
    with pytest.raises(ValueError, match="ended before its command 8"):
        EmoNavDigitEnv(cfg).load_state_dict(too_many)


@pytest.mark.slow
def test_tiny_sac_on_digit_writes_a_loadable_actor_and_resumes_bit_for_bit(tmp_path):
    whole = train_sac(tmp_path / "whole", _tiny(), progress=False)
    state, _ = read_run_state(tmp_path / "whole" / "checkpoint.pt", SAC_FORMAT)
    assert state["step"] == 8 == state["replay"]["size"]
    assert state["config"]["plant"] == "digit"

    # stopped after 5 steps (mid-episode: random actions rarely end one in 2 s), resumed
    train_sac(tmp_path / "split", _tiny(), stop_at=5, progress=False)
    saved, _ = read_run_state(tmp_path / "split" / "checkpoint.pt", SAC_FORMAT)
    assert saved["step"] == 5 and len(saved["envs"][0]["commands"]) > 0
    resumed = train_sac(tmp_path / "split", _tiny(), resume=True, progress=False)
    assert_equal_state(whole.state_dict(), resumed.state_dict())

    # the actor runs in the Digit diagram through --planner sac
    cfg = EmoNavConfig()
    cfg.episode.max_steps = 3
    planner = make_planner("sac", cfg, checkpoint=tmp_path / "whole" / "policy.pt")
    cfg2, kind = configure_for(planner, cfg)
    assert kind == "lgm" and cfg2.lidar.num_frames == 2
    assert cfg.lidar.num_frames == EmoNavConfig().lidar.num_frames  # not modified
    record, _ = run_digit_episode(sample_scenario(0, cfg2), cfg2, planner)
    assert record.steps == 3 and record.outcome in ("timeout", "collision", "success")
