"""The training commands against damaged run directories and nonsense flags (issue 20).

`emonav train`, `digit-rounds` and `calibrate` on real (tiny) run directories: a state
that cannot be resumed is one line naming the file, exit 2, before any work; a flag that
would start a long run with a nonsense value is refused at once, naming the flag; a SAC
checkpoint grows with the transitions stored, not with the buffer's capacity; the command
printed after Ctrl-C is the one that continues the run.
"""

import json
import shlex
import shutil
import signal

import numpy as np
import pytest
import torch

from emonav_drake.cli import main
from emonav_drake.learning import dagger as dagger_mod
from emonav_drake.learning.config import DaggerConfig
from emonav_drake.learning.dagger import train_dagger
from emonav_drake.learning.dagger_state import read_dagger_state
from emonav_drake.learning.env import EmoNavLIPEnv
from emonav_drake.learning.replay import FrameReplayBuffer
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
from emonav_drake.planners.policy import PolicyError, load_policy
from emonav_drake.planners.specs import DwaSpec
from tests.cli_errors import assert_user_error, run
from tests.state_equality import assert_equal_state


def _forbid(monkeypatch, module, name):
    """Make `module.name` fail the test if called: proves the refusal comes first."""

    def called(*_a, **_k):
        raise AssertionError(f"{name} ran although the input was invalid")

    monkeypatch.setattr(module, name, called)


def _sigint_at(mp, cls, name, at):
    """Wrap `cls.name`: a real SIGINT after its `at`-th call."""
    original, calls = getattr(cls, name), []

    def wrapped(self, *args, **kwargs):
        result = original(self, *args, **kwargs)
        calls.append(1)
        if len(calls) == at:
            signal.raise_signal(signal.SIGINT)
        return result

    mp.setattr(cls, name, wrapped)


TINY_DAGGER = {
    "expert_episodes": 2,
    "rounds": 1,
    "episodes_per_round": 1,
    "grad_steps_first": 5,
    "grad_steps_per_round": 5,
    "batch_size": 8,
    "hidden": 16,
    "pool": 4,
    "eval_episodes": 1,
}
TINY_SAC = {
    "grid_kind": "scan",
    "total_steps": 30,
    "random_steps": 10,
    "replay_size": 400,
    "batch_size": 8,
    "hidden": 32,
    "eval_every": 1000,
    "eval_episodes": 1,
    "checkpoint_every": 10,
    "threads": 1,
}


def _yaml(path, fields):
    path.write_text("".join(f"{k}: {v}\n" for k, v in fields.items()))
    return path


# --- a DAgger state that cannot be resumed: train --resume and digit-rounds --from alike --


@pytest.fixture(scope="module")
def dagger_run(tmp_path_factory):
    """A finished tiny DAgger run (30-step episodes)."""
    out = tmp_path_factory.mktemp("dagger") / "run"
    env = EmoNavConfig()
    env.episode.max_steps = 30
    train_dagger(out, DaggerConfig(**TINY_DAGGER), env, command="test")
    return out


def _damaged_copy(src, dst, change):
    shutil.copytree(src, dst)
    state, tensors = read_run_state(dst / "dagger_state.pt", DAGGER_FORMAT)
    change(state)
    write_run_state(dst / "dagger_state.pt", DAGGER_FORMAT, state, tensors)
    return dst


def _as_an_earlier_version_saved_it(state: dict) -> None:
    """The expert as runs saved it before it was one spec: a name and flat fields."""
    state["config"].pop("expert")
    state["config"].update(
        expert="dwa",
        expert_margin=0.05,
        expert_clearance=0.0,
        expert_policy="",
        expert_cells=1,
        expert_shield=False,
    )


def test_a_dagger_state_an_earlier_version_saved_reads_with_its_expert(tmp_path, dagger_run):
    """`--resume` and the Digit rounds read a state with the earlier flat expert fields as
    the spec they meant: the same configuration as the run's own."""
    run_dir = _damaged_copy(dagger_run, tmp_path / "run", _as_an_earlier_version_saved_it)
    state, _ = read_run_state(run_dir / "dagger_state.pt", DAGGER_FORMAT)
    assert state["config"]["expert"] == "dwa"  # really the earlier form on disk
    old = read_dagger_state(run_dir / "dagger_state.pt")[0]
    assert old == read_dagger_state(dagger_run / "dagger_state.pt")[0]
    assert old.expert == DwaSpec(margin=0.05)


@pytest.mark.slow
@pytest.mark.parametrize(
    "change, culprit",
    [
        (lambda s: s["config"].update(bogus=1), "configuration fields this emonav does not know"),
        (lambda s: s.pop("demos"), "no demos in it"),
        (lambda s: s["demos"].pop("labels"), "no demos.labels in it"),
        (lambda s: s["config"].update(beta=3.0), "beta"),
    ],
)
def test_digit_rounds_from_a_state_train_resume_refuses(
    tmp_path, capsys, monkeypatch, dagger_run, change, culprit
):
    run_dir = _damaged_copy(dagger_run, tmp_path / "run", change)
    # no long work may start if the state were accepted
    import emonav_drake.learning.digit_dagger as digit_dagger

    _forbid(monkeypatch, digit_dagger, "collect_round")
    import emonav_drake.planners.specs as specs

    for spec in specs.EXPERT_SPECS:  # no expert may be built either
        _forbid(monkeypatch, spec, "build")
    argv = ["digit-rounds", "--from", run_dir, "--rounds", "1", "--out", tmp_path / "out"]
    line = assert_user_error(*run(capsys, *argv), f"dagger_state.pt in {run_dir}", culprit)
    # the very same check, the same message, as `train --resume`
    argv = ["train", "--algo", "dagger", "--resume", run_dir]
    assert assert_user_error(*run(capsys, *argv)) == line
    with pytest.raises(RunStateError, match=culprit):
        read_dagger_state(run_dir / "dagger_state.pt")
    assert not (tmp_path / "out").exists()


def test_a_good_dagger_state_reads_back_with_its_configuration(dagger_run):
    cfg, saved, tensors = read_dagger_state(dagger_run / "dagger_state.pt")
    assert cfg == DaggerConfig(**TINY_DAGGER)
    assert saved["demos"]["labels"].shape[0] > 0 and "model" in tensors


# --- flags that would start a long run with a nonsense value ----------------------------------


@pytest.mark.parametrize(
    "argv, culprit",
    [
        (["--beta", "2"], "--beta 2.0"),
        (["--beta", "-0.1"], "--beta -0.1"),
        (["--beta", "nan"], "--beta nan"),
        (["--rounds", "0"], "--rounds 0"),
        (["--episodes", "0"], "--episodes 0"),
        (["--episodes", "1000001"], "--episodes 1000001"),
        (["--grad-steps", "-5"], "--grad-steps -5"),
        (["--workers", "0"], "--workers 0"),
        (["--first-seed", "-1"], "--first-seed -1"),
        (["--first-seed", str(2**64)], f"--first-seed {2**64}"),
        (["--first-seed", str(2**64 - 10), "--episodes", "20"], "--first-seed"),
    ],
)
def test_digit_rounds_flags(tmp_path, capsys, argv, culprit):
    # --from names no run: a flag accepted by mistake would be blamed on --from instead
    full = ["digit-rounds", "--from", tmp_path / "none", "--out", tmp_path / "out", *argv]
    assert_user_error(*run(capsys, *full), culprit)
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize(
    "argv, culprit",
    [
        (["collect", "--episodes", "0"], "--episodes 0"),
        (["collect", "--episodes", "100000000"], "--episodes 100000000"),
        (["collect", "--explore", "2"], "--explore 2.0"),
        (["collect", "--explore", "nan"], "--explore nan"),
        (["collect", "--workers", "0"], "--workers 0"),
        (["collect", "--first-seed", "-3"], "--first-seed -3"),
        (["collect", "--first-seed", str(2**64 - 1), "--episodes", "2"], "--first-seed"),
        (["fit", "{traces}", "--held-out", "1"], "--held-out 1.0"),
        (["fit", "{traces}", "--held-out", "0"], "--held-out 0.0"),
        (["fit", "{traces}", "--held-out", "nan"], "--held-out nan"),
    ],
)
def test_calibrate_flags(tmp_path, capsys, monkeypatch, argv, culprit):
    import emonav_drake.learning.calibration as calibration

    _forbid(monkeypatch, calibration, "_trace_episode")
    traces = tmp_path / "t.jsonl"
    traces.write_text(json.dumps({"method": "dwa", "seed": 0, "trace": []}) + "\n")
    argv = [a.replace("{traces}", str(traces)) for a in argv]
    out = tmp_path / ("m.json" if argv[0] == "fit" else "new.jsonl")
    assert_user_error(*run(capsys, "calibrate", *argv, "--out", out), culprit)
    assert not out.exists()


@pytest.mark.parametrize(
    "argv, culprit",
    [
        (["--algo", "sac", "--envs", "5000"], "--envs 5000"),
        (["--algo", "sac", "--seed", str(2**64)], f"--seed {2**64}"),
        (["--algo", "dagger", "--seed", "-1"], "--seed -1"),
        (["--variant", "lidar_sac", "--algo", "sac"], "--algo sac"),
    ],
)
def test_train_flags(tmp_path, capsys, monkeypatch, argv, culprit):
    import emonav_drake.learning.sac_trainer as sac_trainer

    _forbid(monkeypatch, sac_trainer, "train_sac")
    _forbid(monkeypatch, dagger_mod, "train_dagger")
    assert_user_error(*run(capsys, "train", *argv, "--out", tmp_path / "run"), culprit)
    assert not (tmp_path / "run").exists()


# --- trace files: every decode error names the file and line ---------------------------------


@pytest.mark.parametrize(
    "line, culprit",
    [
        ({"method": "dwa", "seed": 3}, "has no 'trace'"),
        ({"seed": 3, "trace": []}, "has no 'method'"),
        ({"method": "dwa", "seed": "3", "trace": []}, "'seed' is not a int"),
        ("not json", "not a JSON trace line"),
        ([1, 2], "not a trace line"),
        ({"method": "dwa", "seed": 3, "trace": [{"robot": [1, 2]}]}, "the trace is malformed"),
    ],
)
def test_calibrate_fit_names_the_file_and_line(tmp_path, capsys, line, culprit):
    good = json.dumps({"method": "dwa", "seed": 1, "trace": []})
    text = line if isinstance(line, str) else json.dumps(line)
    traces = tmp_path / "traces.jsonl"
    traces.write_text(f"{good}\n{text}\n")
    out = tmp_path / "m.json"
    assert_user_error(
        *run(capsys, "calibrate", "fit", traces, "--out", out), f"{traces}:2", culprit
    )
    assert not out.exists()


def test_calibrate_fit_on_a_binary_file(tmp_path, capsys):
    traces = tmp_path / "traces.jsonl"
    traces.write_bytes(b"\xff\xfe\x00garbage")
    assert_user_error(
        *run(capsys, "calibrate", "fit", traces, "--out", tmp_path / "m.json"),
        str(traces),
        "not UTF-8",
    )


def test_calibrate_collect_on_a_damaged_trace_file_runs_nothing(tmp_path, capsys, monkeypatch):
    import emonav_drake.learning.calibration as calibration

    _forbid(monkeypatch, calibration, "_trace_episode")
    traces = tmp_path / "traces.jsonl"
    traces.write_text(json.dumps({"seed": 3, "trace": [], "explore": 0.3}) + "\n")
    argv = ["calibrate", "collect", "--planners", "dwa", "--episodes", "1", "--out", traces]
    assert_user_error(*run(capsys, *argv), f"{traces}:1", "'method'")


# --- SAC checkpoints: the filled part of the replay buffer only ------------------------------


def _sac_cfg(**kw):
    return SacConfig(**(TINY_SAC | {"seed": 5} | kw))


@pytest.mark.slow
def test_a_sac_checkpoint_grows_with_the_filled_buffer_not_its_capacity(tmp_path):
    capacity = 5000
    sizes = {}
    for steps in (15, 45):  # after the first update (random_steps 10): Adam's moments exist
        out = tmp_path / f"run{steps}"
        train_sac(out, _sac_cfg(total_steps=steps, replay_size=capacity), progress=False)
        sizes[steps] = (out / "checkpoint.pt").stat().st_size
    full = FrameReplayBuffer(capacity, (1800,), np.float32, 9)
    full_bytes = sum(a.nbytes for a in vars(full).values() if isinstance(a, np.ndarray))
    assert full_bytes > 70e6
    assert sizes[45] < full_bytes / 10, sizes  # before: the whole buffer, ~73 MB
    # 30 more transitions cost 30 frames (1800 float32 each) and their rows, give or take
    # the frames of an episode start
    per_step = (sizes[45] - sizes[15]) / 30
    row = 2 * 8 * 9 + 48
    assert 7200 + row - 100 < per_step < 2 * 7200 + row, per_step


def _filled(capacity, steps, episode=7, seed=0):
    """A buffer fed like the trainer feeds it: one frame per step, a new window per episode."""
    rng = np.random.default_rng(seed)
    buf = FrameReplayBuffer(capacity, (3,), np.float32, 2)
    window = np.full(2, buf.add_frame(rng.random(3)), np.int64)
    for k in range(steps):
        ids = window.copy()
        window = np.r_[window[1:], buf.add_frame(rng.random(3))]
        buf.add(ids, rng.random(4), rng.random(2), float(k), window, rng.random(4), k % 5 == 0)
        if k % episode == episode - 1:  # an episode starts: its first frame
            window = np.full(2, buf.add_frame(rng.random(3)), np.int64)
    return buf, window


@pytest.mark.parametrize("steps", [0, 5, 30, 95, 400])  # empty, filling, wrapped, many times
def test_the_saved_buffer_restores_exactly_what_sampling_reads(steps):
    buf, window = _filled(20, steps)
    state = unpack(*pack(buf.state_dict(windows=[window])))
    assert len(state["frames"]) <= min(steps + steps // 7 + 1, 20 + 20 // 7 + 4)
    assert len(state["obs_ids"]) == min(steps, 20)
    back = FrameReplayBuffer(20, (3,), np.float32, 2)
    back.load_state_dict(state)
    assert (back.next_frame, back.size, back.pos) == (buf.next_frame, buf.size, buf.pos)
    for k in buf._ROWS:
        assert np.array_equal(getattr(back, k)[: buf.size], getattr(buf, k)[: buf.size])
    referenced = np.concatenate(
        [buf.obs_ids[: buf.size].ravel(), buf.next_ids[: buf.size].ravel(), window]
    )
    assert np.array_equal(back.frames[referenced], buf.frames[referenced])
    if buf.size:
        a = buf.sample(16, np.random.default_rng(1), torch.device("cpu"))
        b = back.sample(16, np.random.default_rng(1), torch.device("cpu"))
        assert all(torch.equal(a[k], b[k]) for k in a)


def test_a_checkpoint_of_the_whole_buffer_still_loads():
    """The layout before: every array whole, no `frame_start`."""
    buf, _ = _filled(20, 12)
    old = {k: getattr(buf, k) for k in ("frames", *buf._ROWS)}
    old |= {"next_frame": buf.next_frame, "size": buf.size, "pos": buf.pos}
    back = FrameReplayBuffer(20, (3,), np.float32, 2)
    back.load_state_dict(unpack(*pack(old)))
    assert np.array_equal(back.frames, buf.frames) and np.array_equal(back.reward, buf.reward)


@pytest.mark.parametrize(
    "change, match",
    [
        (lambda s: s.update(frames=s["frames"][1:]), "do not fit the ring|not saved"),
        (lambda s: s.update(reward=s["reward"][:-1]), "transition rows"),
        (lambda s: s.update(pos=3), "counters"),
        (lambda s: s["obs_ids"].__setitem__((0, 0), 10**6), "not saved"),
    ],
)
def test_a_damaged_saved_buffer_is_refused(change, match):
    buf, window = _filled(20, 12)
    state = unpack(*pack(buf.state_dict(windows=[window])))
    change(state)
    with pytest.raises(ValueError, match=match):
        FrameReplayBuffer(20, (3,), np.float32, 2).load_state_dict(state)


@pytest.mark.slow
def test_sac_resume_across_a_wrapped_buffer_is_bit_exact(tmp_path):
    cfg = _sac_cfg(total_steps=90, replay_size=25, checkpoint_every=1000)
    reference = train_sac(tmp_path / "full", cfg, progress=False).state_dict()
    run_dir = tmp_path / "split"
    train_sac(run_dir, cfg, stop_at=60, progress=False)
    state, _ = read_run_state(run_dir / "checkpoint.pt", SAC_FORMAT)
    assert state["step"] == 60 and state["replay"]["size"] == 25
    assert len(state["replay"]["frames"]) < 2 * 25  # the ring holds 2 * 25 + 2 * 9 + 2
    resumed = train_sac(run_dir, cfg, resume=True, progress=False)
    assert_equal_state(reference, resumed.state_dict())


# --- SAC resume: the learning curve and a changed configuration ------------------------------


@pytest.fixture(scope="module")
def sac_run(tmp_path_factory):
    """A tiny SAC run stopped at step 20 with two evaluations in its learning curve."""
    out = tmp_path_factory.mktemp("sac") / "run"
    train_sac(out, _sac_cfg(eval_every=10), stop_at=20, progress=False)
    return out


@pytest.mark.slow
@pytest.mark.parametrize(
    "damage, culprit",
    [
        (lambda p: p.write_bytes(b"step,episodes\n\xff\xfe\x00\x81"), "is damaged"),
        (lambda p: p.write_text("a,b,c\n1,2,3\n"), "first line is not the header"),
        (lambda p: p.write_text(p.read_text().splitlines()[0] + "\n"), "has 0 evaluations"),
    ],
)
def test_a_damaged_learning_curve_is_named_before_the_run_starts(
    tmp_path, capsys, monkeypatch, sac_run, damage, culprit
):
    run_dir = tmp_path / "run"
    shutil.copytree(sac_run, run_dir)
    damage(run_dir / "learning_curve.csv")
    import emonav_drake.learning.sac_trainer as sac_trainer

    _forbid(monkeypatch, sac_trainer, "make_envs")
    with pytest.raises(RunStateError, match=f"learning_curve.csv in {run_dir}.*{culprit}"):
        train_sac(run_dir, _sac_cfg(eval_every=10), resume=True, progress=False)
    cfg = _yaml(tmp_path / "sac.yaml", TINY_SAC | {"seed": 5, "eval_every": 10})
    argv = ["train", "--algo", "sac", "--config", cfg, "--seed", "5", "--resume", run_dir]
    assert_user_error(*run(capsys, *argv), "learning_curve.csv", str(run_dir), culprit)


def test_a_resume_with_a_changed_configuration_names_the_fields(tmp_path, caplog, sac_run):
    run_dir = tmp_path / "run"
    shutil.copytree(sac_run, run_dir)
    train_sac(run_dir, _sac_cfg(eval_every=10, total_steps=24), resume=True, progress=False)
    assert "differs from the checkpoint's: total_steps: 30 → 24" in caplog.text
    shutil.rmtree(run_dir)
    shutil.copytree(sac_run, run_dir)
    with pytest.raises(RunStateError, match=r"(?s)does not fit.*differs.*: hidden: 32 → 48"):
        train_sac(run_dir, _sac_cfg(eval_every=10, hidden=48), resume=True, progress=False)


def test_a_dagger_resume_with_a_changed_configuration_names_the_fields(
    tmp_path, caplog, dagger_run
):
    run_dir = tmp_path / "run"
    shutil.copytree(dagger_run, run_dir)
    env = EmoNavConfig()
    env.episode.max_steps = 30
    cfg = DaggerConfig(**(TINY_DAGGER | {"hidden": 24}))
    with pytest.raises(RunStateError, match=r"(?s)does not fit.*config\.hidden: 16 → 24"):
        train_dagger(run_dir, cfg, env, resume=True)
    assert "config.hidden: 16 → 24" in caplog.text


# --- the command printed after Ctrl-C continues the run ---------------------------------------


def _hint(err):
    """The command of an interruption's one line (between backquotes)."""
    (line,) = [x for x in err.splitlines() if x.startswith("emonav: interrupted")]
    return shlex.split(line.split("`")[1])


def test_the_resume_hint_of_a_variant_is_the_variant(tmp_path, capsys, monkeypatch):
    out = tmp_path / "lidar"
    with monkeypatch.context() as mp:
        _sigint_at(mp, NavigationWorld, "step", 3)
        code, err = run(capsys, "train", "--variant", "lidar_sac", "--out", out)
    assert code == 130, err
    hint = _hint(err)
    assert hint == ["emonav", "train", "--variant", "lidar_sac", "--resume", str(out)]
    # the hint resumes: the scan student's state loads (before: --algo dagger built the
    # LGM student and failed with a size mismatch); stopped again after a step
    with monkeypatch.context() as mp:
        _sigint_at(mp, NavigationWorld, "step", 1)
        code, err = run(capsys, *hint[1:])
    assert code == 130 and "does not fit" not in err, err
    assert _hint(err) == hint


@pytest.mark.slow
def test_the_resume_hint_of_a_dagger_config_runs_to_the_end(tmp_path, capsys, monkeypatch):
    cfg = _yaml(tmp_path / "tiny.yaml", TINY_DAGGER | {"grid_kind": "scan"})
    out = tmp_path / "run"
    with monkeypatch.context() as mp:
        _sigint_at(mp, NavigationWorld, "step", 40)
        code, err = run(capsys, "train", "--algo", "dagger", "--config", cfg, "--out", out)
    assert code == 130, err
    hint = _hint(err)
    assert hint == ["emonav", "train", "--algo", "dagger", "--config", str(cfg)] + [
        "--resume",
        str(out),
    ]
    assert main(hint[1:]) == 0
    assert read_dagger_state(out / "dagger_state.pt")[0].grid_kind == "scan"
    assert load_policy(out / "policy.pt")[1]["observation"]["grid_kind"] == "scan"


def test_the_resume_hint_of_sac_keeps_the_overrides(tmp_path, capsys, monkeypatch):
    cfg = _yaml(tmp_path / "sac.yaml", TINY_SAC)
    out = tmp_path / "run"
    argv = ["train", "--algo", "sac", "--config", str(cfg), "--steps", "25", "--seed", "4"]
    with monkeypatch.context() as mp:
        _sigint_at(mp, EmoNavLIPEnv, "step", 12)
        code, err = run(capsys, *argv, "--out", out)
    assert code == 130, err
    hint = _hint(err)
    assert hint == ["emonav", *argv, "--resume", str(out)]
    assert main(hint[1:]) == 0
    assert read_run_state(out / "checkpoint.pt", SAC_FORMAT)[0]["step"] == 25


# --- a refused policy checkpoint: one line, as the run-state loader says it ------------------


class _Payload:
    def __init__(self, marker):
        self.marker = str(marker)

    def __reduce__(self):
        return (open, (self.marker, "w"))


def test_a_policy_that_would_run_code_is_refused_in_one_short_line(tmp_path, capsys):
    evil, marker = tmp_path / "evil.pt", tmp_path / "pwned"
    torch.save({"format": "emonav-policy/1", "state_dict": _Payload(marker)}, evil)
    with pytest.raises(PolicyError) as e:
        load_policy(evil)
    assert str(e.value) == (
        f"{evil} is not an emonav policy checkpoint: loading it would run code (io.open); refused"
    )
    argv = ["eval", "--planner", "policy", "--checkpoint", evil, "--episodes", "1"]
    line = assert_user_error(*run(capsys, *argv), str(evil), "would run code", "refused")
    assert "weights_only" not in line and len(line) < 200 + len(str(evil))
    assert not marker.exists()


def test_a_truncated_policy_says_why_in_one_short_line(tmp_path):
    from emonav_drake.planners.policy import DEFAULT_POLICY

    cut = tmp_path / "cut.pt"
    cut.write_bytes(DEFAULT_POLICY.read_bytes()[:5000])
    with pytest.raises(PolicyError, match=f"{cut} is not a readable policy checkpoint") as e:
        load_policy(cut)
    assert "\n" not in str(e.value) and len(str(e.value)) < 300
