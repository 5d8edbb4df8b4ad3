"""DAgger rounds on the full-order Digit (`emonav digit-rounds`), end to end at tiny scale:
a calibrated run, then one Digit round whose student acts in the Digit diagram while the
model-aware expert labels; the round writes a loadable policy and a resumable state."""

import numpy as np
import pytest

from emonav_drake.learning.config import DaggerConfig
from emonav_drake.learning.dagger import train_dagger
from emonav_drake.learning.digit_dagger import DIGIT_ROUNDS_FORMAT, run_digit_rounds
from emonav_drake.learning.digit_rounds_config import DigitRoundsConfig
from emonav_drake.learning.run_state import read_run_state
from emonav_drake.params import EmoNavConfig
from emonav_drake.planners.policy import PolicyPlanner
from emonav_drake.planners.specs import MpcNearbySpec, MpcSpec, ShieldSpec, describe_spec
from emonav_drake.planners.variants import CONFIG_DIR as ROUTES
from emonav_drake.typed_yaml import load_typed_yaml


def _tiny_route_then_a_digit_round(tmp_path, cfg: DaggerConfig):
    """`cfg`'s calibrated run at a tiny budget, then one Digit round of two 3-step
    episodes from it; returns the round's policy file."""
    cfg.expert_episodes, cfg.episodes_per_round, cfg.rounds = 2, 1, 1
    cfg.grad_steps_first, cfg.grad_steps_per_round, cfg.batch_size = 2, 2, 8
    cfg.eval_episodes = 1
    source = tmp_path / "calibrated"
    train_dagger(source, cfg.validate(), command="test")
    short = EmoNavConfig()
    short.episode.max_steps = 3
    rounds = DigitRoundsConfig(rounds=1, episodes=2, grad_steps=3, batch_size=8, beta=0.5)
    return run_digit_rounds(tmp_path / "digit", source, rounds, env_config=short)


@pytest.mark.slow
@pytest.mark.parametrize(
    "route", ["emobipednav_digit", "emobipednav_digit_mpc", "emobipednav_distilled"]
)
def test_a_tiny_digit_round_writes_a_loadable_policy(tmp_path, route):
    cfg = load_typed_yaml(DaggerConfig, path=ROUTES / f"{route}.yaml")
    if isinstance(cfg.expert, MpcSpec):
        cfg.expert = MpcSpec(clearance=0.1)  # a widened teacher labels on Digit too
    policy = _tiny_route_then_a_digit_round(tmp_path, cfg)
    planner = PolicyPlanner(policy)
    prov = planner.meta["provenance"]
    assert prov["route"] == "dagger+digit" and prov["round"] == 0
    # the calibrated run's teacher labels, a shield wrapping the run's initial policy
    assert prov["config"]["expert"] == describe_spec(cfg.teacher())
    (entry,) = prov["history"]
    assert entry["episodes"] == 2 and entry["seeds"] == [4_000_000, 4_000_001]
    assert entry["digit_samples"] >= 6  # 3 planner instants (at least) per episode
    assert entry["digit_steps_per_second_per_worker"] > 0
    if isinstance(cfg.expert, ShieldSpec):  # the policy it shields: the run's initial one
        assert cfg.teacher().checkpoint == cfg.init_policy
        state, _ = read_run_state(tmp_path / "digit" / "digit_rounds.pt", DIGIT_ROUNDS_FORMAT)
        targets = state["demos"]["targets"]  # soft labels on Digit too
        assert len(targets) == entry["digit_samples"]
        np.testing.assert_allclose(targets.sum(axis=1), 1.0, atol=1e-5)
    assert (tmp_path / "digit" / "digit_rounds.pt").is_file()
    u = planner.act(np.zeros((9, 100, 100), np.uint8), np.array([8.0, 0.0]), np.zeros(2))
    assert 0 <= u[0] <= 0.4 and abs(u[1]) <= 0.2


def test_resuming_the_rounds_from_a_damaged_state_names_it_and_the_changed_settings(
    tmp_path, caplog, monkeypatch
):
    import dataclasses as dc

    import pytest

    import emonav_drake.learning.digit_dagger as digit_dagger
    from emonav_drake.learning.demonstrations import Demonstrations, FrameStore
    from emonav_drake.learning.run_state import RunStateError, write_run_state

    cfg = DaggerConfig(expert_episodes=1, rounds=1, episodes_per_round=1, batch_size=8)
    cfg.grad_steps_first = cfg.grad_steps_per_round = 2
    cfg.hidden, cfg.pool, cfg.eval_episodes = 16, 4, 1
    short = EmoNavConfig()
    short.episode.max_steps = 10
    source = tmp_path / "calibrated"
    train_dagger(source, cfg, short, command="test")

    def collected(*_a, **_k):
        raise AssertionError("a round started from a damaged state")

    monkeypatch.setattr(digit_dagger, "collect_round", collected)
    out = tmp_path / "digit"
    out.mkdir()
    saved = DigitRoundsConfig(rounds=1, episodes=7)
    demos = Demonstrations(FrameStore((100, 100))).to_plain(cfg.num_frames)
    state = {"round": 1, "history": [{}], "demos": demos, "config": dc.asdict(saved)}
    write_run_state(out / "digit_rounds.pt", digit_dagger.DIGIT_ROUNDS_FORMAT, state, {})
    rounds = DigitRoundsConfig(rounds=1, episodes=2)
    with pytest.raises(
        RunStateError,
        match=r"digit_rounds\.pt in .*digit is damaged .*no 'model' in it.*episodes: 7 → 2",
    ):
        run_digit_rounds(out, source, rounds, resume=True)
    assert "settings that differ from the saved ones: episodes: 7 → 2" in caplog.text


@pytest.mark.slow
@pytest.mark.parametrize(
    "expert",
    [
        ShieldSpec(checkpoint="emobipednav_digit_mpc", response="digit"),
        MpcNearbySpec(checkpoint="emobipednav_digit_mpc", response="digit", shielded=True),
    ],
    ids=["shield", "mpc_nearby_shield"],
)
def test_a_digit_round_collected_on_ray_equals_the_serial_one(expert):
    """The soft labels on Digit (the shield's; the MPC-steered policy's within its shield),
    on two Ray workers and serially: the same frames, states, labels and distributions, bit
    for bit (both on one torch thread); each label is its distribution's argmax."""
    from emonav_drake.learning.digit_dagger import collect_round
    from emonav_drake.planners.policy import DEFAULT_POLICY

    short = EmoNavConfig()
    short.episode.max_steps = 3
    cfg = DigitRoundsConfig(episodes=2, beta=0.5, expert=expert)
    serial = collect_round(DEFAULT_POLICY, cfg, 0, 1, None, short)
    ray = collect_round(DEFAULT_POLICY, cfg, 0, 2, None, short)
    assert [e["seed"] for e in ray] == [e["seed"] for e in serial] == [4_000_000, 4_000_001]
    for a, b in zip(serial, ray, strict=True):
        assert a["targets"].shape == (len(a["labels"]), 99)
        assert (a["targets"].argmax(axis=1) == a["labels"]).all()
        for key in ("frames", "states", "labels", "targets"):
            assert np.array_equal(a[key], b[key]), key


@pytest.mark.slow
def test_the_digit_rounds_walk_the_calibrated_runs_world(tmp_path):
    """A student trained in buildings on the tracker's crowd of a real sensor's scan meets
    them on Digit too: the rounds' episodes are the run's family (walls in every scene of
    `doorway`), and every round's line of the history names the world it walked."""
    cfg = DaggerConfig(grid_kind="lgm_tracks", num_frames=3, hidden=16, family="doorway")
    cfg.sensor, cfg.perception = "vlp16", "tracks"
    policy = _tiny_route_then_a_digit_round(tmp_path, cfg)
    (entry,) = PolicyPlanner(policy).meta["provenance"]["history"]
    assert entry["world"] == {"family": "doorway", "sensor": "vlp16", "perception": "tracks"}
    assert entry["walled_episodes"] == 2 and entry["digit_samples"] >= 6


def test_the_rounds_world_is_the_runs_and_refuses_another_family():
    from emonav_drake.learning.digit_dagger import rounds_world
    from emonav_drake.params import ConfigError

    run = DaggerConfig(family="office", sensor="vlp16", perception="tracks")
    world = rounds_world(run)
    assert world.crowd.family == "office"
    assert world.perception.state_source == "lidar" and world.perception.map_rings == "tracks"
    assert rounds_world(DaggerConfig()).perception.state_source == "truth"
    other = EmoNavConfig()
    other.crowd.family = "doorway"
    with pytest.raises(ConfigError, match="trained in family 'office'.*'doorway'"):
        rounds_world(run, other)
