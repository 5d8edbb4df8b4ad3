"""The paper's observation variants, trained by the CPU route and registered by name.

`emonav train --variant NAME` runs the DAgger route on the variant's observation (tiny
budget here); the checkpoint it writes records the observation and its provenance and
runs one episode on the LIP plant and on Digit through `--planner NAME --checkpoint`.
Shipped variant policies run by name without a checkpoint.
"""

import json

import numpy as np
import pytest

from emonav_drake.cli import main
from emonav_drake.learning.config import DaggerConfig
from emonav_drake.planners.policy import load_policy
from emonav_drake.planners.variants import VARIANTS, PolicyVariant, shipped_checkpoint, variant
from emonav_drake.typed_yaml import ConfigError, load_typed_yaml


@pytest.fixture(scope="module")
def tiny_variants(tmp_path_factory):
    """A directory for the tiny variant runs (one per variant)."""
    return tmp_path_factory.mktemp("variants")


def _tiny_run(root, name: str):
    """`emonav train --variant NAME` with the variant's YAML shrunk to a tiny budget."""
    out = root / name
    if (out / "policy.pt").is_file():
        return out
    cfg = load_typed_yaml(DaggerConfig, path=variant(name).config)
    cfg.expert_episodes, cfg.episodes_per_round, cfg.rounds = 2, 1, 1
    cfg.grad_steps_first, cfg.grad_steps_per_round, cfg.batch_size = 4, 2, 8
    cfg.eval_episodes = 1
    if not cfg.init_policy:  # a warm start keeps the network of the policy it starts from
        cfg.hidden = 16
    from emonav_drake.learning.dagger import train_dagger

    train_dagger(out, cfg.validate(), command=f"test {name}", variant=name)
    return out


@pytest.mark.slow
@pytest.mark.parametrize("name", list(VARIANTS))
def test_each_variant_trains_and_its_checkpoint_runs_on_both_plants(tiny_variants, name):
    out = _tiny_run(tiny_variants, name)
    model, meta = load_policy(out / "policy.pt")
    cfg = load_typed_yaml(DaggerConfig, path=variant(name).config)
    assert meta["observation"]["grid_kind"] == cfg.grid_kind
    assert meta["observation"]["num_frames"] == cfg.num_frames
    assert meta["observation"]["goal_input"] == cfg.goal_input
    expected_encoder = {"lgm": "lgm", "ogm": "lgm", "drlvo": "lgm", "scan": "scan"}[cfg.grid_kind]
    if cfg.encoder == "lstm":
        expected_encoder = "scan_lstm"
    assert meta["encoder"]["type"] == expected_encoder
    prov = meta["provenance"]
    assert prov["variant"] == name and prov["command"] == f"test {name}"
    assert prov["selection_seeds"] == [600_000, 600_000]  # the variant YAML's offset, 1 ep
    assert prov["training_seeds"] == [1_000_000, 1_000_002]  # 2 expert + 1 DAgger episode
    assert prov["wall_seconds"] > 0 and prov["samples"] > 0
    history = json.loads((out / "history.json").read_text())
    assert [h["round"] for h in history] == [0, 1]
    # the route trained (and selected) in its setting's discomfort distances
    from emonav_drake.configs import load_setting
    from emonav_drake.learning.dagger_state import STATE_FILE, read_dagger_state

    _, saved, _ = read_dagger_state(out / STATE_FILE)
    reward = saved["env_config"]["reward"]
    trained = [reward[f"{e}_discomfort"] for e in ("happy", "neutral", "negative")]
    assert trained == list(load_setting(cfg.setting).reward.emotion_distances())
    assert prov["config"]["setting"] == cfg.setting
    short = out / "short.yaml"
    short.write_text("episode: {max_steps: 2}\n")
    for plant in ("lip", "digit"):
        rec = out / f"{plant}.json"
        argv = ["sim", "--planner", name, "--checkpoint", str(out / "policy.pt")]
        argv += ["--plant", plant, "--config", str(short), "--seed", "4", "--json", str(rec)]
        assert main(argv) == 0
        record = json.loads(rec.read_text())
        assert record["steps"] == 2 and record["outcome"] == "timeout", (plant, record)


def test_variants_differ_from_the_shipped_route_by_observation_only():
    base = load_typed_yaml(DaggerConfig, path=variant("emobipednav").config)
    observation = {"grid_kind", "num_frames", "encoder"}
    for name in [n for n, v in VARIANTS.items() if v.route == "lip"]:
        cfg = load_typed_yaml(DaggerConfig, path=variant(name).config).validate()
        differ = {k for k, v in vars(cfg).items() if v != getattr(base, k) and k not in observation}
        assert not differ, f"{name} changes {differ}: not the same route"
    assert base.rounds == 10 and base.eval_episodes == 200 and base.eval_seed_offset == 600_000


def test_the_table3_variants_are_the_default_route_in_a_constant_setting(tmp_path):
    """Table III's constant-DD rows: the default policy's route, changed in `setting` only,
    and the setting is the world the route trains in (its discomfort distances)."""
    from emonav_drake.configs import load_setting

    base = load_typed_yaml(DaggerConfig, path=variant("emobipednav_digit_mpc").config)
    for name, setting, dd in (
        ("emobipednav_dd02", "no_emotion", 0.2),
        ("emobipednav_dd05", "constant_0.5", 0.5),
    ):
        cfg = load_typed_yaml(DaggerConfig, path=variant(name).config).validate()
        differ = {k for k, v in vars(cfg).items() if v != getattr(base, k)}
        assert differ == {"setting"} and cfg.setting == setting, (name, differ)
        assert load_setting(setting).reward.emotion_distances() == pytest.approx([dd] * 3)
    with pytest.raises(ConfigError, match="setting"):
        DaggerConfig(setting="calm").validate()
    # a setting and an explicit environment configuration: ambiguous, refused before any work
    from emonav_drake.learning.dagger import train_dagger
    from emonav_drake.params import EmoNavConfig

    with pytest.raises(ConfigError, match="give one"):
        train_dagger(tmp_path, DaggerConfig(setting="no_emotion"), EmoNavConfig())
    assert not any(tmp_path.iterdir())


def test_the_mixed_variant_is_the_mpc_route_on_the_scenario_families(tiny_variants, tmp_path):
    """Issue 38 item 5: the same route and budget as `emobipednav_digit_mpc`, changed only in
    the scenes it trains and selects on; the run's world is the mixed family's."""
    base = load_typed_yaml(DaggerConfig, path=variant("emobipednav_digit_mpc").config)
    cfg = load_typed_yaml(DaggerConfig, path=variant("emobipednav_mixed").config).validate()
    assert {k for k, v in vars(cfg).items() if v != getattr(base, k)} == {"family"}
    assert cfg.family == "mixed" and base.family == "paper"
    from emonav_drake.learning.dagger_state import STATE_FILE, read_dagger_state

    out = _tiny_run(tiny_variants, "emobipednav_mixed")
    _, saved, _ = read_dagger_state(out / STATE_FILE)
    assert saved["env_config"]["crowd"]["family"] == "mixed"
    _, meta = load_policy(out / "policy.pt")
    assert meta["provenance"]["config"]["family"] == "mixed"
    with pytest.raises(ConfigError, match="family"):
        DaggerConfig(family="hallways").validate()
    from emonav_drake.learning.dagger import train_dagger
    from emonav_drake.params import EmoNavConfig

    env = EmoNavConfig()
    env.crowd.family = "dense_8"
    with pytest.raises(ConfigError, match="give one"):
        train_dagger(tmp_path, DaggerConfig(family="mixed"), env)
    assert not any(tmp_path.iterdir())


def test_the_mirrored_batch_is_the_mirrored_world_for_scans():
    # the student's augmentation flips scans beam i <-> K-1-i and the label's turn
    from emonav_drake.learning.dagger_student import Student
    from emonav_drake.params import EmoNavConfig
    from emonav_drake.planners.dwa import DwaPlanner

    env_cfg = EmoNavConfig()
    commands = DwaPlanner(env_cfg).candidates
    student = Student(DaggerConfig(grid_kind="scan", hidden=8), env_cfg, commands)
    for i, c in enumerate(commands):
        m = commands[student.mirrored[i]]
        np.testing.assert_allclose(m, c * [1.0, -1.0], atol=1e-12)
    assert student.mirror_augment and student.grid_kind == "scan"


@pytest.mark.slow
@pytest.mark.parametrize("name", [n for n, v in VARIANTS.items() if v.is_shipped])
def test_each_shipped_variant_runs_a_seeded_episode_on_both_plants_deterministically(
    sim_on_both_plants, name
):
    """The shipped checkpoint loads, declares its variant's observation, and runs by name
    through `emonav sim` on each plant: a whole LIP episode and the first 6 Digit steps,
    twice each with the same seed, to the same trajectory."""
    v = VARIANTS[name]
    _, meta = load_policy(shipped_checkpoint(name))
    cfg = load_typed_yaml(DaggerConfig, path=v.config)
    assert meta["observation"]["grid_kind"] == cfg.grid_kind
    assert meta["observation"]["num_frames"] == cfg.num_frames
    records = sim_on_both_plants(["--planner", name], 7)
    for plant, record in records.items():
        assert len(record["trajectory"]["t"]) == record["steps"] + 1, plant
    # the whole LIP episode ends by the goal, a collision or a timeout
    assert records["lip"]["outcome"] in ("success", "collision", "timeout")
    assert records["digit"]["steps"] == 6 and records["digit"]["path_length"] > 0.3


def test_unshipped_variants_say_how_to_train(monkeypatch):
    """A variant without its file (every one of this version is shipped; a new one is not,
    until trained) is refused by name with the command that trains it."""
    name = "not_trained"
    monkeypatch.setitem(VARIANTS, name, PolicyVariant(name, "X", "y", "policies/not_trained.pt"))
    with pytest.raises(ConfigError, match=f"emonav train --variant {name}"):
        shipped_checkpoint(name)
    assert all(v.is_shipped for n, v in VARIANTS.items() if n != name)


def test_train_variant_refuses_a_second_configuration(tmp_path, capsys):
    cfg = tmp_path / "c.yaml"
    cfg.write_text("rounds: 2\n")
    code = main(["train", "--variant", "ogm", "--config", str(cfg), "--out", str(tmp_path / "o")])
    assert code == 2
    assert "--config cannot be combined" in capsys.readouterr().err
    assert not (tmp_path / "o").exists()


def test_unknown_variant_is_refused():
    with pytest.raises(ConfigError, match="choose one of emobipednav"):
        variant("lstm_lgm")
