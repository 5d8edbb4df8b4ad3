"""SAC fine-tuning of a categorical student (`emonav train --algo finetune`), at tiny scale.

The real networks (the shipped student), the real world (`NavigationWorld`, LIP and the
Digit-calibrated one) and a real SIGINT raised inside a step or an update; no mocks.
"""

import json
import shlex
import signal
from pathlib import Path

import numpy as np
import pytest
import torch

from emonav_drake.cli import main
from emonav_drake.errors import RunInterrupted
from emonav_drake.learning import finetune as finetune_mod
from emonav_drake.learning.finetune import train_finetune
from emonav_drake.learning.finetune_agent import DiscreteSac, load_init, resolve_init
from emonav_drake.learning.finetune_state import (
    FINETUNE_FORMAT,
    STATE_FILE,
    read_finetune_state,
)
from emonav_drake.learning.replay import FrameReplayBuffer
from emonav_drake.learning.run_state import read_run_state
from emonav_drake.learning.sac_config import FinetuneConfig
from emonav_drake.navigation.lip_world import NavigationWorld
from emonav_drake.navigation.metrics import summarize
from emonav_drake.params import ConfigError, EmoNavConfig
from emonav_drake.planners.networks import Actor, CategoricalPolicy, LgmEncoder, ScanEncoder
from emonav_drake.planners.policy import (
    LIP_POLICY,
    PolicyPlanner,
    encoder_spec,
    save_policy,
    vector_state,
)
from emonav_drake.planners.variants import VARIANTS
from emonav_drake.scenarios.scenario import sample_scenario
from tests.cli_errors import assert_user_error, run
from tests.state_equality import assert_equal_state


def _env(max_steps=8):
    cfg = EmoNavConfig()
    cfg.episode.max_steps = max_steps
    return cfg


def _cfg(**kw):
    base = dict(
        total_steps=40,
        learning_starts=8,
        batch_size=16,
        hidden=32,
        state_features=16,
        critic_warmup=4,
        eval_every=16,
        eval_episodes=2,
        replay_size=200,
        seed=5,
    )
    return FinetuneConfig(**(base | kw))


def _head(state_dict):
    return {k: v for k, v in state_dict.items() if not k.startswith("encoder.")}


def _result(out):
    """Everything a run ends with: learner tensors, replay, history (wall times dropped)."""
    state, tensors = read_run_state(out / STATE_FILE, FINETUNE_FORMAT)
    progress = {k: v for k, v in state["progress"].items() if not k.endswith("_s")}
    history = [{k: v for k, v in e.items() if not k.endswith("_s")} for e in progress["history"]]
    progress["history"] = history
    policy = torch.load(out / "policy.pt", weights_only=True)["state_dict"]
    return tensors["agent"], state["replay"], progress, policy, state["updates"], history


def test_one_update_changes_the_actor_and_critics_but_not_the_encoder():
    cfg = _cfg(critic_warmup=0, batch_size=8)
    env = _env()
    _, model, _ = load_init("shipped", env)
    agent = DiscreteSac(cfg, model, torch.device("cpu"))
    before = {k: v.clone() for k, v in agent.state_dict()["policy"].items()}
    critic = {k: v.clone() for k, v in agent.critic.state_dict().items()}
    target = {k: v.clone() for k, v in agent.critic_target.state_dict().items()}
    # a few real transitions: features of real observations, real rewards
    replay = FrameReplayBuffer(20, (agent.features,), np.float32, 1)
    world = NavigationWorld(sample_scenario(2_000_000, env), env, grid_kind="lgm")
    commands = np.asarray(torch.load(LIP_POLICY, weights_only=True)["commands"])
    bounds = (env.robot.max_speed, env.robot.max_heading_change)

    def observe():
        obs = world.planner_input()
        return agent.encode(obs.lgm_stack), vector_state(obs.goal_state(), obs.last_command, bounds)

    f, s = observe()
    fid = replay.add_frame(f)
    rng = np.random.default_rng(0)
    for _ in range(5):
        a = agent.act(f, s, rng)
        ev, outcome = world.step(commands[a])
        f2, s2 = observe()
        fid2 = replay.add_frame(f2)
        replay.add([fid], s, np.array([a, 0.0], np.float32), ev.reward, [fid2], s2, False)
        f, s, fid = f2, s2, fid2
    info = agent.update(replay.sample(8, rng, agent.device))
    assert {"critic_loss", "actor_loss", "kl", "entropy"} <= set(info)
    after = agent.state_dict()["policy"]
    for k, v in before.items():
        changed = not torch.equal(v, after[k])
        assert changed == (not k.startswith("encoder.")), k  # the encoder is frozen
    for k, v in agent.critic.state_dict().items():
        assert not torch.equal(v, critic[k]), k
    for k, v in agent.critic_target.state_dict().items():
        assert not torch.equal(v, target[k]), k  # Polyak
    assert agent.alpha != cfg.init_alpha  # tuned
    assert agent.updates == 1


@pytest.mark.slow
def test_a_run_writes_a_policy_that_the_planner_runs_as_selected(tmp_path):
    out = tmp_path / "run"
    env = _env()
    cfg = _cfg()
    path = train_finetune(out, cfg, init="shipped", env_cfg=env, command="test", progress=False)
    _, tensors = read_run_state(out / STATE_FILE, FINETUNE_FORMAT)
    agent = tensors["agent"]
    # the head moved away from the student; its encoder did not
    init = torch.load(LIP_POLICY, weights_only=True)["state_dict"]
    assert any(not torch.equal(v, init[k]) for k, v in _head(agent["policy"]).items())
    assert all(torch.equal(agent["policy"][k], init[k]) for k in init if k.startswith("encoder"))
    history = json.loads((out / "history.json").read_text())
    assert [h["env_steps"] for h in history][:2] == [0, 16] and history[-1]["env_steps"] >= 40
    assert history[0]["updates"] == 0  # the starting point
    planner = PolicyPlanner(path)
    prov = planner.meta["provenance"]
    assert prov["route"] == "finetune" and prov["init_policy"] == str(LIP_POLICY)
    assert prov["init_provenance"]["route"] == "dagger"
    assert prov["selection_seeds"] == [600_000, 600_001]
    assert prov["config"] == _cfg().__dict__ and prov["env_config"]["episode"]["max_steps"] == 8
    assert set(prov["wall_seconds"]) == {"collect", "update", "eval"}
    selected = [h for h in history if h["selected"]][-1]
    assert prov["env_steps"] == selected["env_steps"] and prov["updates"] == selected["updates"]
    # the file, run by the planner on the selection seeds, gives the selection's result
    records = []
    for i in range(cfg.eval_episodes):
        world = NavigationWorld(
            sample_scenario(cfg.eval_seed_offset + i, env), env, goal_radius=cfg.goal_radius
        )
        outcome = None
        while outcome is None:
            command = planner.plan(world.planner_input())
            assert any(np.array_equal(command, c) for c in planner.commands)
            _, outcome = world.step(command)
        records.append(world.record)
    assert summarize(records) == prov["eval"] == selected["eval"]


@pytest.mark.slow
def test_with_the_warmup_covering_every_update_the_actor_stays(tmp_path):
    out = tmp_path / "run"
    train_finetune(out, _cfg(critic_warmup=10**6), init="shipped", env_cfg=_env(), progress=False)
    agent, _, _, _, updates, history = _result(out)
    assert updates == 32 and all(h["training"]["actor_updates"] == 0 for h in history)
    init = torch.load(LIP_POLICY, weights_only=True)["state_dict"]
    assert_equal_state(init, agent["policy"], "policy")
    assert float(agent["log_alpha"].exp()) == pytest.approx(0.01)
    assert all(h["alpha"] == history[0]["alpha"] for h in history)


# ------------------------------------------------------------------ Ctrl-C and resume


def _hooks(mp, calls, at=None):
    """Tag every world step (collect or eval) and update; a real SIGINT after call `at`."""
    phase = ["collect"]
    real_eval = finetune_mod._Run.evaluate

    def evaluate(self):
        phase[0] = "eval"
        try:
            return real_eval(self)
        finally:
            phase[0] = "collect"

    mp.setattr(finetune_mod._Run, "evaluate", evaluate)
    for cls, name, tag in ((NavigationWorld, "step", None), (DiscreteSac, "update", "update")):
        original = getattr(cls, name)

        def wrapped(self, *args, _original=original, _tag=tag, **kwargs):
            result = _original(self, *args, **kwargs)
            calls.append(_tag or phase[0])
            if len(calls) == at:
                signal.raise_signal(signal.SIGINT)
            return result

        mp.setattr(cls, name, wrapped)


def _digit_cfg():
    return _cfg(response="digit", temperature=1.5)


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    out = tmp_path_factory.mktemp("finetune_full")
    calls = []
    with pytest.MonkeyPatch.context() as mp:
        _hooks(mp, calls)
        train_finetune(out, _digit_cfg(), init="shipped", env_cfg=_env(), progress=False)
    return _result(out), calls


@pytest.mark.slow
@pytest.mark.parametrize("phase", ["collect", "update", "eval"])
def test_ctrl_c_then_resume_is_bit_exact(tmp_path, monkeypatch, reference, phase):
    expected, calls = reference
    assert {"collect", "update", "eval"} <= set(calls)
    rng = np.random.default_rng(31 + len(phase))
    k = 1 + int(rng.choice([i for i, c in enumerate(calls) if c == phase]))
    run_dir, seen = tmp_path / "run", []
    _hooks(monkeypatch, seen, at=k)
    handler = signal.getsignal(signal.SIGINT)
    with pytest.raises(RunInterrupted, match=f"state saved in {run_dir}.*--resume {run_dir}"):
        train_finetune(run_dir, _digit_cfg(), init="shipped", env_cfg=_env(), progress=False)
    assert signal.getsignal(signal.SIGINT) is handler
    monkeypatch.undo()
    _, saved, _ = read_finetune_state(run_dir / STATE_FILE)
    assert saved["replay"]["size"] == saved["progress"]["env_steps"]  # whole episodes only
    train_finetune(run_dir, _digit_cfg(), env_cfg=_env(), resume=True, progress=False)
    agent, replay, progress, policy, updates, history = _result(run_dir)
    assert_equal_state(expected[0], agent, "agent")  # networks, α, optimisers
    assert replay.keys() == expected[1].keys()
    for key, array in expected[1].items():
        assert np.array_equal(array, replay[key]), key
    assert_equal_state(expected[2], progress, "progress")
    assert_equal_state(expected[3], policy, "policy")
    assert (updates, history) == expected[4:]


# ------------------------------------------------------------------ the command line


def _yaml(path, fields):
    path.write_text("".join(f"{k}: {v}\n" for k, v in fields.items()))
    return path


TINY = dict(
    total_steps=20,
    learning_starts=5,
    batch_size=8,
    hidden=16,
    state_features=8,
    critic_warmup=5,
    eval_every=1000,
    eval_episodes=1,
    replay_size=500,
)


@pytest.mark.slow
def test_the_cli_runs_stops_and_resumes(tmp_path, capsys, monkeypatch):
    cfg, out = _yaml(tmp_path / "ft.yaml", TINY), tmp_path / "run"
    seen = []
    with monkeypatch.context() as mp:
        _hooks(mp, seen, at=30)  # inside the starting point's evaluation
        code, err = run(
            capsys,
            "train",
            "--algo",
            "finetune",
            "--init",
            "shipped",
            "--config",
            cfg,
            "--out",
            out,
        )
    assert code == 130, err
    (line,) = [x for x in err.splitlines() if x.startswith("emonav: interrupted")]
    hint = shlex.split(line.split("`")[1])
    assert hint == ["emonav", "train", "--algo", "finetune", "--config", str(cfg)] + [
        "--resume",
        str(out),
    ]
    assert main(hint[1:]) == 0
    assert "policy written to" in capsys.readouterr().out
    planner = PolicyPlanner(out / "policy.pt")
    world = NavigationWorld(sample_scenario(0, EmoNavConfig()), EmoNavConfig())
    assert planner.plan(world.planner_input()).shape == (2,)
    history = json.loads((out / "history.json").read_text())
    assert history[0]["env_steps"] == 0 and history[-1]["env_steps"] >= 20


def _gaussian_policy(path):
    enc = encoder_spec("scan", "cnn", 9, 100)
    actor = Actor(ScanEncoder(9, features=50, filters=32), hidden=8)
    meta = {
        "kind": "gaussian",
        "encoder": enc,
        "hidden": 8,
        "observation": {"grid_kind": "scan", "num_frames": 9, "grid_size": 100},
        "bounds": [0.4, 0.2],
    }
    save_policy(path, actor, meta)
    return path


def _one_frame_student(path):
    commands = torch.load(LIP_POLICY, weights_only=True)["commands"]
    enc = encoder_spec("lgm", "cnn", 1, 100, pool=4)
    model = CategoricalPolicy(LgmEncoder(1, 100, pool=4), len(commands), 16)
    meta = {
        "kind": "categorical",
        "encoder": enc,
        "hidden": 16,
        "commands": commands,
        "observation": {"grid_kind": "lgm", "num_frames": 1, "grid_size": 100},
        "bounds": [0.4, 0.2],
    }
    save_policy(path, model, meta)
    return path


@pytest.mark.parametrize(
    "argv, culprits",
    [
        (["--algo", "finetune"], ["--algo finetune needs --init"]),
        (["--algo", "finetune", "--init", "{missing}"], ["--init", "does not exist"]),
        (["--algo", "finetune", "--init", "{gaussian}"], ["gaussian", "categorical"]),
        (["--algo", "finetune", "--init", "{one_frame}"], ["1 frame(s)", "lidar.num_frames = 9"]),
        (["--algo", "dagger", "--init", "shipped"], ["--init applies to --algo finetune"]),
        (["--algo", "finetune", "--init", "shipped", "--plant", "lip"], ["--plant"]),
        (["--algo", "finetune", "--init", "shipped", "--steps", "0"], ["--steps 0"]),
        (["--algo", "finetune", "--init", "shipped", "--config", "{bad}"], ["bc_weight"]),
        (["--algo", "finetune", "--init", "shipped", "--config", "{overlap}"], ["overlap"]),
        (["--algo", "finetune", "--init", "shipped", "--device", "cuda:9"], ["--device"]),
    ],
)
def test_bad_cli_inputs_are_clear_errors(tmp_path, capsys, monkeypatch, argv, culprits):
    monkeypatch.setattr(finetune_mod, "train_finetune", _forbidden)
    files = {
        "{missing}": tmp_path / "nope.pt",
        "{gaussian}": _gaussian_policy(tmp_path / "sac.pt"),
        "{one_frame}": _one_frame_student(tmp_path / "one.pt"),
        "{bad}": _yaml(tmp_path / "bad.yaml", {"bc_weight": -1.0}),
        "{overlap}": _yaml(tmp_path / "o.yaml", {"train_seed_offset": 600_100}),
    }
    argv = [str(files.get(a, a)) for a in argv]
    assert_user_error(*run(capsys, "train", *argv, "--out", tmp_path / "run"), *culprits)
    assert not (tmp_path / "run").exists()


def _forbidden(*args, **kwargs):
    raise AssertionError("training started despite a bad input")


def test_resume_errors_are_clear(tmp_path, capsys):
    empty = tmp_path / "empty"
    empty.mkdir()
    code, err = run(capsys, "train", "--algo", "finetune", "--resume", empty)
    assert_user_error(code, err, "no fine-tuning state", str(empty))
    code, err = run(capsys, "train", "--algo", "finetune", "--init", "shipped", "--resume", empty)
    assert_user_error(code, err, "drop --init")
    assert list(empty.iterdir()) == []


def test_the_digit_route_file_holds_the_defaults_in_the_calibrated_world():
    from emonav_drake.configs import CONFIG_DIR
    from emonav_drake.typed_yaml import load_typed_yaml

    cfg = load_typed_yaml(FinetuneConfig, path=CONFIG_DIR / "finetune_digit.yaml").validate()
    assert cfg == FinetuneConfig(response="digit")


def test_init_names_and_worlds(tmp_path):
    assert resolve_init("shipped") == LIP_POLICY
    assert resolve_init("emobipednav_digit") == VARIANTS["emobipednav_digit"].checkpoint
    assert resolve_init(str(tmp_path / "x.pt")) == tmp_path / "x.pt"
    env = EmoNavConfig()
    env.robot.max_speed = 0.5
    with pytest.raises(ConfigError, match=r"command bounds \[0.4, 0.2\].*\[0.5, 0.2\]"):
        load_init("shipped", env)
    env = EmoNavConfig()
    env.lidar.grid_size = 50
    with pytest.raises(ConfigError, match=r"shape \(9, 100, 100\).*\(9, 50, 50\)"):
        load_init("shipped", env)


def test_seed_ranges_are_validated():
    with pytest.raises(ConfigError, match="eval_seed_offset = 100 .*evaluation seeds"):
        FinetuneConfig(eval_seed_offset=100).validate()
    with pytest.raises(ConfigError, match="train_seed_offset = 599999 .*overlap"):
        FinetuneConfig(train_seed_offset=599_999).validate()
    with pytest.raises(ConfigError, match="critic_loss"):
        FinetuneConfig(critic_loss="l1").validate()
    assert FinetuneConfig().validate().train_seed_offset == 2_000_000


BUILDINGS_STUDENT = (
    Path(__file__).resolve().parent.parent
    / "benchmarks/results/buildings_route/checkpoints/digit_r2.pt"
)


def test_the_run_learns_in_its_family_and_the_trackers_world_with_a_tracks_student(tmp_path):
    """Issue 53 item 3: the fine-tuning's world is its configuration's scenario family,
    LiDAR sensor and perception, and the student may read the tracks as a second input
    (`lgm_tracks`: the buildings route's output); another family in the environment's
    configuration is refused before any work."""
    cfg = _cfg(
        total_steps=10,
        learning_starts=4,
        eval_every=8,
        eval_episodes=1,
        family="doorway",
        sensor="vlp16",
        perception="tracks",
    )
    path = train_finetune(
        tmp_path / "run", cfg, init=str(BUILDINGS_STUDENT), env_cfg=_env(6), progress=False
    )
    meta = PolicyPlanner(path).meta
    assert meta["observation"]["grid_kind"] == "lgm_tracks"
    world = meta["provenance"]["env_config"]
    assert world["crowd"]["family"] == "doorway"
    assert world["perception"]["state_source"] == "lidar" and world["sensor"]["preset"] == "vlp16"
    with pytest.raises(ConfigError, match="family"):
        FinetuneConfig(family="hallways").validate()
    office = _env()
    office.crowd.family = "office"
    with pytest.raises(ConfigError, match="give one"):
        train_finetune(tmp_path / "other", cfg, init=str(BUILDINGS_STUDENT), env_cfg=office)
    assert not (tmp_path / "other").exists()
