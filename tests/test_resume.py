"""Run directories of the trainers: safe loading, exact resume after Ctrl-C, atomic saves.

Real trainers on tiny configurations. Ctrl-C is a real SIGINT raised inside the run (from
a wrapped method, at a call drawn from a seeded generator); the resumed run must end
with the same weights, bit for bit, as an uninterrupted one.
"""

import os
import pickle
import signal

import numpy as np
import pytest
import torch

from emonav_drake.errors import RunInterrupted
from emonav_drake.learning import dagger as dagger_mod
from emonav_drake.learning import run_state
from emonav_drake.learning.config import DaggerConfig
from emonav_drake.learning.dagger import train_dagger
from emonav_drake.learning.dagger_student import Student
from emonav_drake.learning.env import EmoNavLIPEnv
from emonav_drake.learning.run_state import (
    DAGGER_FORMAT,
    SAC_FORMAT,
    RunStateError,
    pack,
    read_run_state,
    unpack,
    write_run_state,
)
from emonav_drake.learning.sac_config import SacConfig
from emonav_drake.learning.sac_trainer import train_sac
from emonav_drake.navigation.lip_world import NavigationWorld
from emonav_drake.params import EmoNavConfig
from emonav_drake.planners.policy import load_policy
from emonav_drake.planners.specs import MpcNearbySpec, MpcSpec, ShieldSpec
from emonav_drake.scenarios.scenario import sample_scenario
from tests.state_equality import assert_equal_state

DEAD_PID = 2**22 + 12_345  # above Linux's largest pid_max: never a running process


# ------------------------------------------------------------------ crafted files


class _OpenPayload:
    """What an attacker leaves in a run directory: unpickling it creates `marker`."""

    def __init__(self, marker):
        self.marker = str(marker)

    def __reduce__(self):
        return (open, (self.marker, "w"))


class _SystemPayload(_OpenPayload):
    def __reduce__(self):
        return (os.system, (f"touch {self.marker}",))


def _craft(path, payload_cls, marker, wrapped):
    obj = payload_cls(marker)
    if wrapped:  # hidden inside a plausible checkpoint
        obj = {"format": SAC_FORMAT, "state": "{}", "arrays": {}, "torch": {"x": obj}}
    torch.save(obj, path)


def test_the_payload_is_live(tmp_path):
    """The crafted objects do run code when unpickled (so the tests below mean something)."""
    for cls in (_OpenPayload, _SystemPayload):
        marker = tmp_path / f"{cls.__name__}.marker"
        pickle.loads(pickle.dumps(cls(marker)))
        assert marker.exists()


@pytest.mark.parametrize("payload", [_OpenPayload, _SystemPayload])
@pytest.mark.parametrize("wrapped", [False, True])
def test_a_crafted_sac_checkpoint_is_refused_without_running_it(tmp_path, payload, wrapped):
    run, marker = tmp_path / "run", tmp_path / "pwned"
    run.mkdir()
    _craft(run / "checkpoint.pt", payload, marker, wrapped)
    with pytest.raises(RunStateError, match=r"checkpoint\.pt in .*run.*(run code|not an emonav)"):
        train_sac(run, _sac_cfg(), resume=True, progress=False)
    assert not marker.exists()


@pytest.mark.parametrize("payload", [_OpenPayload, _SystemPayload])
def test_a_crafted_dagger_state_is_refused_without_running_it(tmp_path, payload):
    run, marker = tmp_path / "run", tmp_path / "pwned"
    run.mkdir()
    _craft(run / "dagger_state.pt", payload, marker, wrapped=False)
    with pytest.raises(RunStateError, match=r"dagger_state\.pt in .*run code"):
        train_dagger(run, _dagger_cfg(), _dagger_env(), resume=True)
    assert not marker.exists()


def test_an_old_pickle_based_checkpoint_is_refused_clearly(tmp_path):
    # Format 1: numpy arrays and pickled objects inside a torch.save dict.
    old = {
        "config": {},
        "replay": {"frames": np.zeros((3, 4), np.uint8)},
        "rng": np.random.default_rng(0).bit_generator.state,
        "env": pickle.dumps([1, 2]),
        "step": 3,
    }
    torch.save(old, tmp_path / "checkpoint.pt")
    with pytest.raises(RunStateError, match=r"older emonav \(format 1.*start a new run"):
        train_sac(tmp_path, _sac_cfg(), resume=True, progress=False)
    torch.save(old | {"replay": {}, "rng": {}}, tmp_path / "dagger_state.pt")  # loadable
    with pytest.raises(RunStateError, match=r"older emonav \(format 1\)"):
        train_dagger(tmp_path, _dagger_cfg(), _dagger_env(), resume=True)


def test_missing_and_truncated_state_give_clear_errors(tmp_path):
    empty = tmp_path / "empty"
    empty.mkdir()
    with pytest.raises(RunStateError, match="no DAgger state .* nothing to resume .*--out"):
        train_dagger(empty, _dagger_cfg(), _dagger_env(), resume=True)
    with pytest.raises(RunStateError, match="no SAC checkpoint .* nothing to resume"):
        train_sac(empty, _sac_cfg(), resume=True, progress=False)
    assert list(empty.iterdir()) == []  # nothing was started

    run = tmp_path / "sac"
    train_sac(run, _sac_cfg(total_steps=12, checkpoint_every=6), progress=False)
    data = (run / "checkpoint.pt").read_bytes()
    (run / "checkpoint.pt").write_bytes(data[: len(data) // 2])
    with pytest.raises(RunStateError, match=r"checkpoint\.pt in .*sac is damaged or truncated"):
        train_sac(run, _sac_cfg(total_steps=12, checkpoint_every=6), resume=True, progress=False)

    run = tmp_path / "dagger"
    run.mkdir()
    write_run_state(run / "dagger_state.pt", DAGGER_FORMAT, {"x": np.zeros(1000)}, {})
    data = (run / "dagger_state.pt").read_bytes()
    (run / "dagger_state.pt").write_bytes(data[:-200])
    with pytest.raises(RunStateError, match=r"dagger_state\.pt in .*damaged or truncated"):
        train_dagger(run, _dagger_cfg(), _dagger_env(), resume=True)


def test_stale_temp_files_of_killed_saves_are_removed(tmp_path):
    run = tmp_path / "run"
    run.mkdir()
    stale = [
        run / f"checkpoint.tmp-{DEAD_PID}-a1b2c3.pt",  # our naming, process gone
        run / f"policy.tmp-{os.getpid()}-x9y8z7.pt",  # this process saves nothing yet
        run / f"checkpoint.pt.emonav-{DEAD_PID}.tmp",  # the writer before, process gone
        run / "checkpoint.ptk3_9xq2a.tmp",  # the pickle-era writer's naming
    ]
    kept = [
        run / f"checkpoint.tmp-{os.getppid()}-q1w2e3.pt",  # a live process may be saving
        run / f"checkpoint.pt.emonav-{os.getppid()}.tmp",
        run / "notes.tmp",  # not ours
        run / "policy.pt.tmp",
    ]
    for p in stale + kept:
        p.write_bytes(b"partial")
    train_sac(run, _sac_cfg(total_steps=4), progress=False)
    assert not any(p.exists() for p in stale)
    assert all(p.exists() for p in kept)
    assert (run / "checkpoint.pt").is_file() and (run / "policy.pt").is_file()


def test_rounds_below_zero_never_report_an_unwritten_policy(tmp_path):
    with pytest.raises(RunStateError, match="no DAgger round was trained"):
        train_dagger(tmp_path, _dagger_cfg(rounds=-1), _dagger_env())
    assert not (tmp_path / "policy.pt").exists()


# ------------------------------------------------------------------ plain state


def test_plain_data_round_trip_is_exact():
    tree = {
        "f": 0.1 + 0.2,
        "inf": float("inf"),
        "big": 2**127 + 3,
        "t": (1, "a", None, True),
        "a": np.arange(6, dtype=np.float32).reshape(2, 3)[:, 1:],  # a view
        "s": np.float32(0.3),
        "u8": np.full((2, 2), 7, np.uint8),
    }
    back = unpack(*pack(tree))
    assert back["f"] == tree["f"] and back["big"] == tree["big"] and back["inf"] == np.inf
    assert back["t"] == [1, "a", None, True]
    assert back["a"].dtype == np.float32 and np.array_equal(back["a"], tree["a"])
    assert type(back["s"]) is np.float32 and back["s"] == tree["s"]
    assert back["u8"].dtype == np.uint8
    with pytest.raises(TypeError, match="not plain data"):
        pack({"x": object()})
    with pytest.raises(TypeError, match="plain string key"):
        pack({1: 2})


@pytest.mark.parametrize("kind", ["lgm", "scan", "drlvo"])
def test_a_restored_world_continues_exactly(kind):
    cfg = EmoNavConfig()
    world = NavigationWorld(sample_scenario(7, cfg), cfg, grid_kind=kind)
    commands = np.random.default_rng(1).uniform([0.0, -0.2], [0.4, 0.2], (12, 2))
    for u in commands[:5]:
        world.step(u)
    clone = NavigationWorld.from_state_dict(unpack(*pack(world.state_dict())), cfg)
    for u in commands[5:]:
        (ev_a, out_a), (ev_b, out_b) = world.step(u), clone.step(u)
        assert ev_a == ev_b and out_a == out_b
        assert np.array_equal(world.planner_input().lgm_stack, clone.planner_input().lgm_stack)
    assert world.record == clone.record and world.robot == clone.robot


def test_env_state_round_trip():
    env = EmoNavLIPEnv(grid_kind="ogm")
    env.reset(seed=4)
    env.step(np.array([0.3, 0.1], np.float32))
    other = EmoNavLIPEnv(grid_kind="ogm")
    other.load_state_dict(unpack(*pack(env.state_dict())))
    a, ra, *_ = env.step(np.array([0.2, -0.1], np.float32))
    b, rb, *_ = other.step(np.array([0.2, -0.1], np.float32))
    assert ra == rb and all(np.array_equal(a[k], b[k]) for k in a)
    assert env.np_random.random() == other.np_random.random()
    with pytest.raises(ValueError, match="map kind"):
        EmoNavLIPEnv(grid_kind="lgm").load_state_dict(env.state_dict())


# ------------------------------------------------------------------ Ctrl-C, SAC


def _sac_cfg(**kw):
    base = dict(
        grid_kind="scan",
        total_steps=110,
        random_steps=30,
        replay_size=400,
        batch_size=8,
        hidden=32,
        eval_every=50,
        eval_episodes=1,
        checkpoint_every=40,
        seed=11,
        threads=1,
    )
    return SacConfig(**(base | kw))


def _sigint_hook(mp, cls, name, calls, at=None, tag=None):
    """Wrap `cls.name`: record each call (its tag) and raise a real SIGINT after call `at`."""
    original = getattr(cls, name)

    def wrapped(self, *args, **kwargs):
        result = original(self, *args, **kwargs)
        calls.append(tag(self) if tag else name)
        if len(calls) == at:
            signal.raise_signal(signal.SIGINT)
        return result

    mp.setattr(cls, name, wrapped)


def _second_ctrl_c_during_saves(mp, pressed):
    """Another SIGINT in the middle of every save once the first was `pressed()`."""
    real_save = torch.save

    def save(*args, **kwargs):
        if pressed():
            signal.raise_signal(signal.SIGINT)
        return real_save(*args, **kwargs)

    mp.setattr(run_state.torch, "save", save)


@pytest.fixture(scope="module")
def sac_reference(tmp_path_factory):
    """The uninterrupted run, and which environment steps were training or evaluation."""
    out = tmp_path_factory.mktemp("sac_full")
    calls, envs = [], []

    def tag(env):
        if not envs:
            envs.append(env)  # the first environment stepped is the training one
        return "train" if env is envs[0] else "eval"

    with pytest.MonkeyPatch.context() as mp:
        _sigint_hook(mp, EmoNavLIPEnv, "step", calls, tag=tag)
        agent = train_sac(out, _sac_cfg(), progress=False)
    return agent.state_dict(), calls, (out / "learning_curve.csv").read_text()


@pytest.mark.slow
@pytest.mark.parametrize("phase", ["train", "eval"])
def test_sac_ctrl_c_at_a_random_step_then_resume_is_bit_exact(
    tmp_path, monkeypatch, sac_reference, phase
):
    reference, calls, curve = sac_reference
    assert calls.count("eval") > 0 and calls.count("train") == 110
    rng = np.random.default_rng(20250 + len(phase))
    k = 1 + int(rng.choice([i for i, c in enumerate(calls) if c == phase]))
    run = tmp_path / "run"
    seen = []
    _sigint_hook(monkeypatch, EmoNavLIPEnv, "step", seen, at=k)
    _second_ctrl_c_during_saves(monkeypatch, lambda: len(seen) >= k)
    handler = signal.getsignal(signal.SIGINT)
    with pytest.raises(RunInterrupted, match=f"checkpoint saved in {run}.*--resume {run}"):
        train_sac(run, _sac_cfg(), progress=False)
    assert signal.getsignal(signal.SIGINT) is handler  # restored
    monkeypatch.undo()

    state, _ = read_run_state(run / "checkpoint.pt", SAC_FORMAT)
    assert state["step"] == state["replay"]["size"] > 0  # a whole step, never half of one
    # the evaluation due at the step it stopped at is still to run (first on resume)
    assert state["eval_pending"] == (phase == "eval" or state["step"] % 50 == 0)
    assert list(run.glob("*.tmp")) == []
    resumed = train_sac(run, _sac_cfg(), resume=True, progress=False)
    assert_equal_state(reference, resumed.state_dict())
    assert (run / "learning_curve.csv").read_text() == curve


def test_sigterm_stops_like_ctrl_c_and_the_handlers_are_restored(tmp_path, monkeypatch):
    handlers = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)}
    original = EmoNavLIPEnv.step
    steps = []

    def step(self, action):
        steps.append(1)
        if len(steps) == 5:
            signal.raise_signal(signal.SIGTERM)
        return original(self, action)

    monkeypatch.setattr(EmoNavLIPEnv, "step", step)
    with pytest.raises(RunInterrupted, match="interrupted at step 5 of 30"):
        train_sac(tmp_path, _sac_cfg(total_steps=30), progress=False)
    assert {s: signal.getsignal(s) for s in handlers} == handlers
    state, _ = read_run_state(tmp_path / "checkpoint.pt", SAC_FORMAT)
    assert state["step"] == state["replay"]["size"] == 5


# ------------------------------------------------------------------ Ctrl-C, DAgger


def _dagger_cfg(**kw):
    base = dict(
        expert_episodes=2,
        rounds=1,
        episodes_per_round=2,
        grad_steps_first=15,
        grad_steps_per_round=15,
        batch_size=8,
        hidden=16,
        pool=4,
        eval_episodes=1,
        seed=3,
    )
    return DaggerConfig(**(base | kw))


def _dagger_env():
    cfg = EmoNavConfig()
    cfg.episode.max_steps = 30
    return cfg


def _dagger_hooks(mp, calls, at=None):
    """SIGINT from inside a collected episode's step, an update, or an evaluation step."""
    phase = ["collect"]
    real_eval = dagger_mod.evaluate_student

    def evaluate(*args, **kwargs):
        phase[0] = "eval"
        try:
            return real_eval(*args, **kwargs)
        finally:
            phase[0] = "collect"

    mp.setattr(dagger_mod, "evaluate_student", evaluate)
    _sigint_hook(mp, NavigationWorld, "step", calls, at, tag=lambda _: phase[0])
    _sigint_hook(mp, Student, "loss", calls, at, tag=lambda _: "train")


def _dagger_result(out):
    state, tensors = read_run_state(out / "dagger_state.pt", DAGGER_FORMAT)
    policy = torch.load(out / "policy.pt", weights_only=True)
    history = [{k: v for k, v in e.items() if not k.endswith("_s")} for e in state["history"]]
    return tensors["model"], tensors["optim"], policy["state_dict"], history, state["demos"]


@pytest.fixture(scope="module")
def dagger_reference(tmp_path_factory):
    out = tmp_path_factory.mktemp("dagger_full")
    calls = []
    with pytest.MonkeyPatch.context() as mp:
        _dagger_hooks(mp, calls)
        train_dagger(out, _dagger_cfg(), _dagger_env())
    return _dagger_result(out), calls


@pytest.mark.slow
@pytest.mark.parametrize("phase", ["collect", "train", "eval"])
def test_dagger_ctrl_c_at_a_random_point_then_resume_is_bit_exact(
    tmp_path, monkeypatch, dagger_reference, phase
):
    reference, calls = dagger_reference
    rng = np.random.default_rng(777 + len(phase))
    k = 1 + int(rng.choice([i for i, c in enumerate(calls) if c == phase]))
    run = tmp_path / "run"
    seen = []
    _dagger_hooks(monkeypatch, seen, at=k)
    _second_ctrl_c_during_saves(monkeypatch, lambda: len(seen) >= k)
    with pytest.raises(RunInterrupted, match=f"state saved in {run}.*--resume {run}"):
        train_dagger(run, _dagger_cfg(), _dagger_env())
    monkeypatch.undo()
    state, _ = read_run_state(run / "dagger_state.pt", DAGGER_FORMAT)
    stopped_in = state["progress"]["phase"]  # after a round's last update: its evaluation
    assert stopped_in == phase or (phase, stopped_in) == ("train", "eval")
    stale = run / f"dagger_state.pt.emonav-{DEAD_PID}.tmp"
    stale.write_bytes(b"half a save")
    train_dagger(run, _dagger_cfg(), _dagger_env(), resume=True)
    assert not stale.exists()
    model, optim, policy, history, demos = _dagger_result(run)
    assert_equal_state(reference[0], model, "model")
    assert_equal_state(reference[1], optim, "optim")
    assert_equal_state(reference[2], policy, "policy")
    assert history == reference[3]
    for key, array in reference[4].items():
        assert np.array_equal(array, demos[key]), key


@pytest.mark.slow
@pytest.mark.parametrize(
    "expert",
    [
        dict(expert=MpcSpec()),
        dict(
            expert=ShieldSpec(checkpoint="emobipednav_digit_mpc", response="digit"),
            soft_labels=True,
        ),
        dict(
            expert=MpcNearbySpec(checkpoint="emobipednav_digit_mpc", response="digit"),
            soft_labels=True,
        ),
        dict(
            expert=MpcNearbySpec(
                checkpoint="emobipednav_digit_mpc", response="digit", shielded=True
            ),
            soft_labels=True,
        ),
    ],
    ids=["mpc", "shield_soft", "mpc_nearby_soft", "mpc_nearby_shield_soft"],
)
def test_an_expert_route_stopped_in_its_rollouts_resumes_bit_exact(tmp_path, monkeypatch, expert):
    """The routes of the MPC route's policy (MPC expert), of its distilled successor (the
    shield's soft labels) and of the MPC-steered policy's soft labels, calibrated world, at
    tiny scale: one expert round and one
    DAgger round write a loadable policy; Ctrl-C inside a rollout, then resume, gives the
    same weights, optimiser, history and demonstrations (soft labels included)."""
    cfg = _dagger_cfg(response="digit", **expert)
    reference = tmp_path / "reference"
    calls = []
    with pytest.MonkeyPatch.context() as mp:
        _dagger_hooks(mp, calls)
        policy_path = train_dagger(reference, cfg, _dagger_env())
    _, meta = load_policy(policy_path)
    saved = DaggerConfig.from_saved(meta["provenance"]["config"])
    assert saved.expert == expert["expert"]  # the policy records its teacher, typed
    expected = _dagger_result(reference)
    targets = expected[4].get("targets")
    if cfg.soft_labels:  # a distribution per sample, whose argmax is the hard label
        assert targets.shape == (len(expected[4]["labels"]), 99)
        np.testing.assert_allclose(targets.sum(axis=1), 1.0, atol=1e-5)
        assert (targets.argmax(axis=1) == expected[4]["labels"]).all()
    else:
        assert targets is None
    last_rollout_step = max(i for i, c in enumerate(calls) if c == "collect")  # round 1
    run, seen = tmp_path / "run", []
    _dagger_hooks(monkeypatch, seen, at=last_rollout_step)
    with pytest.raises(RunInterrupted):
        train_dagger(run, cfg, _dagger_env())
    monkeypatch.undo()
    train_dagger(run, cfg, _dagger_env(), resume=True)
    got = _dagger_result(run)
    for i, name in enumerate(("model", "optim", "policy")):
        assert_equal_state(expected[i], got[i], name)
    assert got[3] == expected[3]
    for key, array in expected[4].items():
        assert np.array_equal(array, got[4][key]), key
