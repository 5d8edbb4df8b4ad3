"""DAgger rounds on the full-order Digit (`emonav digit-rounds`), end to end at tiny scale:
a calibrated run, then one Digit round whose student acts in the Digit diagram while the
model-aware expert labels; the round writes a loadable policy and a resumable state."""

import numpy as np

from emonav_drake.learning.config import DaggerConfig
from emonav_drake.learning.dagger import train_dagger
from emonav_drake.learning.digit_dagger import DigitRoundsConfig, run_digit_rounds
from emonav_drake.learning.policy import PolicyPlanner
from emonav_drake.learning.variants import variant
from emonav_drake.params import EmoNavConfig, load_typed_yaml


def test_a_tiny_digit_round_writes_a_loadable_policy(tmp_path):
    cfg = load_typed_yaml(DaggerConfig, path=variant("emobipednav_digit").config)
    cfg.expert_episodes, cfg.episodes_per_round, cfg.rounds = 2, 1, 1
    cfg.grad_steps_first, cfg.grad_steps_per_round, cfg.batch_size = 2, 2, 8
    cfg.eval_episodes = 1
    source = tmp_path / "calibrated"
    train_dagger(source, cfg.validate(), command="test")
    short = EmoNavConfig()
    short.episode.max_steps = 3
    rounds = DigitRoundsConfig(rounds=1, episodes=2, grad_steps=3, batch_size=8, beta=0.5)
    policy = run_digit_rounds(tmp_path / "digit", source, rounds, env_config=short)
    planner = PolicyPlanner(policy)
    prov = planner.meta["provenance"]
    assert prov["route"] == "dagger+digit" and prov["round"] == 0
    (entry,) = prov["history"]
    assert entry["episodes"] == 2 and entry["seeds"] == [4_000_000, 4_000_001]
    assert entry["digit_samples"] >= 6  # 3 planner instants (at least) per episode
    assert entry["digit_steps_per_second_per_worker"] > 0
    assert (tmp_path / "digit" / "digit_rounds.pt").is_file()
    u = planner.act(np.zeros((9, 100, 100), np.uint8), np.array([8.0, 0.0]), np.zeros(2))
    assert 0 <= u[0] <= 0.4 and abs(u[1]) <= 0.2
