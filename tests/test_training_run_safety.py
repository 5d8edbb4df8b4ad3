"""Issue 36, the third hostile probe: training runs and checkpoints (docs/reliability.md).

A finished training run is never replaced without `--overwrite`, one process trains into a
directory at a time, `--resume` continues with the run's own configuration, and a damaged
(CRC), non-finite or absurd checkpoint is refused in one line naming its file.
"""

import io
import logging
import random
import zipfile

import pytest
import torch

from emonav_drake.learning.run_state import SAC_FORMAT, RunStateError, write_run_state
from emonav_drake.planners.policy import DEFAULT_POLICY, PolicyError, load_policy
from emonav_drake.planners.sarl import load_sarl
from emonav_drake.planners.variants import resolve_policy_file
from emonav_drake.run_lock import locked_directory
from tests.cli_errors import assert_user_error, run
from tests.test_learning_inputs import TINY_SAC as TINY_SAC_30
from tests.test_learning_inputs import _yaml

TINY_SAC = TINY_SAC_30 | {"total_steps": 20}


def _snapshot(folder):
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir()) if p.is_file()}


# --- 1. a finished run is not overwritten; one writer at a time ---------------------------


@pytest.fixture(scope="module")
def sac_run(tmp_path_factory):
    """A finished tiny SAC run (20 steps, hidden 32, seed 4), by the command line."""
    base = tmp_path_factory.mktemp("sac")
    cfg = _yaml(base / "sac.yaml", TINY_SAC)
    out = base / "run"
    code = _main("train", "--algo", "sac", "--config", cfg, "--seed", "4", "--out", out)
    assert code == 0
    return out


def _main(*argv):
    from emonav_drake.cli import main

    return main([str(a) for a in argv])


def test_train_into_a_finished_run_is_refused_and_touches_nothing(sac_run, tmp_path, capsys):
    before = _snapshot(sac_run)
    assert {"checkpoint.pt", "policy.pt"} <= set(before)
    cfg = _yaml(tmp_path / "sac.yaml", TINY_SAC)
    line = assert_user_error(
        *run(capsys, "train", "--algo", "sac", "--config", cfg, "--out", sac_run),
        f"--out {sac_run}",
        "not empty",
        f"--resume {sac_run}",
        "--overwrite",
    )
    assert "checkpoint.pt" in line
    assert _snapshot(sac_run) == before


def test_the_default_out_is_not_overwritten_by_a_second_train(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    default = tmp_path / "runs" / "train"
    default.mkdir(parents=True)
    (default / "policy.pt").write_bytes(b"a finished run's policy")
    cfg = _yaml(tmp_path / "sac.yaml", TINY_SAC)
    argv = ["train", "--algo", "sac", "--config", cfg]
    assert_user_error(*run(capsys, *argv), "--out runs/train", "not empty")
    assert (default / "policy.pt").read_bytes() == b"a finished run's policy"


def test_any_file_makes_out_not_empty_and_a_refused_new_folder_is_not_left(tmp_path, capsys):
    out = tmp_path / "d"
    out.mkdir()
    (out / "notes.txt").write_text("mine")
    cfg = _yaml(tmp_path / "sac.yaml", TINY_SAC)
    argv = ["train", "--algo", "sac", "--config", cfg, "--out", out]
    line = assert_user_error(*run(capsys, *argv), "not empty", "notes.txt")
    assert "--resume" not in line  # no run to continue there
    # a refusal for another reason leaves no new, empty --out behind
    new = tmp_path / "new"
    assert_user_error(*run(capsys, "train", "--out", new, "--steps", "0"), "--steps 0")
    assert not new.exists()


def test_overwrite_replaces_the_runs_files_and_keeps_the_others(sac_run, tmp_path, capsys):
    import shutil

    out = tmp_path / "copy"
    shutil.copytree(sac_run, out)
    (out / "notes.txt").write_text("mine")
    (out / "policy_round7.pt").write_bytes(b"of the previous run")
    old_policy = (out / "policy.pt").read_bytes()
    cfg = _yaml(tmp_path / "sac.yaml", TINY_SAC | {"total_steps": 12, "checkpoint_every": 6})
    code, err = run(capsys, "train", "--algo", "sac", "--config", cfg, "--out", out, "--overwrite")
    assert code == 0, err
    assert (out / "notes.txt").read_text() == "mine"
    assert not (out / "policy_round7.pt").exists()
    assert f"--overwrite: removed {out / 'policy_round7.pt'}" in err
    assert (out / "policy.pt").read_bytes() != old_policy
    assert torch.load(out / "checkpoint.pt", weights_only=True)["format"] == SAC_FORMAT
    assert_user_error(
        *run(capsys, "train", "--resume", out, "--overwrite"), "--overwrite", "--resume"
    )


def test_a_second_training_into_a_busy_directory_is_refused(tmp_path, capsys):
    out = tmp_path / "busy"
    cfg = _yaml(tmp_path / "sac.yaml", TINY_SAC)
    with locked_directory(out, what="training run"):  # as a first `train --out` holds it
        line = assert_user_error(
            *run(capsys, "train", "--algo", "sac", "--config", cfg, "--out", out),
            f"--out {out}",
            "another emonav training run is running",
        )
        assert_user_error(*run(capsys, "train", "--resume", out), "--resume")
    assert list(out.iterdir()) == [], line


def test_resume_without_config_continues_with_the_runs_own(sac_run, tmp_path, capsys, caplog):
    import shutil

    out = tmp_path / "again"
    shutil.copytree(sac_run, out)
    # no --algo, no --config, no --seed: all of them are the run's (sac, hidden 32, seed 4);
    # before, the route defaulted to SAC's default configuration (hidden 256, seed 0)
    with caplog.at_level(logging.WARNING):
        code, err = run(capsys, "train", "--resume", out, "--steps", "30")
    assert code == 0, err
    # the one change is the flag given (before: hidden, seed, ... differed too)
    assert "total_steps: 20 → 30" in caplog.text
    assert "hidden" not in caplog.text and "seed" not in caplog.text, caplog.text
    state = torch.load(out / "checkpoint.pt", weights_only=True)
    import json

    saved = json.loads(state["state"])
    assert saved["config"]["hidden"] == 32 and saved["config"]["seed"] == 4
    assert saved["config"]["total_steps"] == 30  # the flag given overrides the run's
    assert saved["step"] == 30


def test_resume_of_a_folder_without_a_state_names_the_states(tmp_path, capsys):
    assert_user_error(
        *run(capsys, "train", "--resume", tmp_path),
        f"--resume {tmp_path}",
        "checkpoint.pt",
        "dagger_state.pt",
    )


# --- 2. damaged or absurd checkpoints ------------------------------------------------------


def _flipped(data: bytes, n: int = 64, seed: int = 0) -> bytes:
    """`data` with `n` bytes of its stored tensors inverted (the zip headers kept)."""
    out = bytearray(data)
    with zipfile.ZipFile(io.BytesIO(data)) as z:
        info = max(z.infolist(), key=lambda i: i.file_size)  # the largest weight tensor
    start = info.header_offset + 30 + len(info.filename) + len(info.extra)
    rng = random.Random(seed)
    for i in rng.sample(range(start, start + info.compress_size), n):
        out[i] ^= 0xFF
    return bytes(out)


def _altered_policy(path, change):
    blob = torch.load(DEFAULT_POLICY, weights_only=True)
    name = next(k for k, v in blob["state_dict"].items() if v.is_floating_point())
    blob["state_dict"][name] = change(blob["state_dict"][name])
    torch.save(blob, path)
    return name


def test_a_policy_with_flipped_bytes_is_refused_by_its_crc(tmp_path, capsys):
    bad = tmp_path / "flipped.pt"
    bad.write_bytes(_flipped(DEFAULT_POLICY.read_bytes()))
    with pytest.raises(PolicyError, match="CRC-32") as e:
        load_policy(bad)
    assert str(bad) in str(e.value) and "\n" not in str(e.value)
    argv = ["eval", "--planner", "policy", "--checkpoint", bad, "--episodes", "1"]
    assert_user_error(*run(capsys, *argv), str(bad), "CRC-32", "changed after it was written")
    assert_user_error(*run(capsys, "export", bad, "--out", tmp_path / "p.ts"), str(bad))
    assert not (tmp_path / "p.ts").exists()


@pytest.mark.parametrize(
    "change, why",
    [
        (lambda w: w.clone().fill_(float("nan")), "NaN or infinite"),
        (lambda w: w * float("inf"), "NaN or infinite"),
        (lambda w: w * 1e30, "a damaged or altered file"),
    ],
    ids=["nan", "inf", "x1e30"],
)
def test_non_finite_or_absurd_weights_are_refused(tmp_path, capsys, change, why):
    bad = tmp_path / "bad.pt"
    name = _altered_policy(bad, change)
    with pytest.raises(PolicyError, match=why) as e:
        load_policy(bad)
    assert str(bad) in str(e.value) and name in str(e.value)
    argv = ["sim", "--planner", "policy", "--checkpoint", bad]
    assert_user_error(*run(capsys, *argv), str(bad), why)


def test_every_shipped_checkpoint_still_loads():
    from emonav_drake.planners.variants import VARIANTS

    for name in VARIANTS:
        load_policy(resolve_policy_file(name, "test"))
    load_policy(DEFAULT_POLICY)
    for name in ("sarl", "rgl"):
        load_sarl(DEFAULT_POLICY.parent / f"{name}.pt")


def test_a_sarl_checkpoint_that_would_run_code_says_so_without_torchs_advice(tmp_path, capsys):
    class Payload:
        def __reduce__(self):
            return (print, ("pwned",))

    evil = tmp_path / "evil.pt"
    torch.save({"format": "emonav-sarl/1", "state_dict": Payload()}, evil)
    line = assert_user_error(
        *run(capsys, "sim", "--planner", "sarl", "--checkpoint", evil),
        str(evil),
        "would run code (print)",
    )
    assert "weights_only" not in line and "Re-running" not in line
    flipped = tmp_path / "sarl_flipped.pt"
    flipped.write_bytes(_flipped((DEFAULT_POLICY.parent / "sarl.pt").read_bytes(), seed=1))
    assert_user_error(
        *run(capsys, "sim", "--planner", "sarl", "--checkpoint", flipped), str(flipped), "CRC-32"
    )


def test_resume_of_random_bytes_says_why_in_our_words(tmp_path, capsys):
    out = tmp_path / "run"
    out.mkdir()
    (out / "checkpoint.pt").write_bytes(random.Random(0).randbytes(5000))
    line = assert_user_error(
        *run(capsys, "train", "--algo", "sac", "--resume", out), "checkpoint.pt", "zip archive"
    )
    assert "weights_only" not in line and "Re-running" not in line and len(line) < 400


def test_a_run_state_with_nan_is_refused_naming_the_tensor(tmp_path):
    from emonav_drake.learning.run_state import read_run_state

    path = tmp_path / "checkpoint.pt"
    write_run_state(path, SAC_FORMAT, {"x": 1}, {"actor": {"w": torch.tensor([1.0, float("nan")])}})
    with pytest.raises(RunStateError, match=r"checkpoint\.pt in .*torch\.actor\.w holds NaN"):
        read_run_state(path, SAC_FORMAT)


# --- 7. every numeric field of a training configuration has a two-sided range ---------------


@pytest.mark.parametrize("schema", ["DaggerConfig", "SacConfig", "FinetuneConfig", "SarlConfig"])
def test_every_numeric_training_field_has_a_bounded_range(schema):
    # a new numeric field without a range in its `setting(...)` fails here (or without a doc)
    from emonav_drake.config_fields import field_range
    from emonav_drake.learning import config, sac_config
    from tests.test_input_limits import field_problems

    cls = getattr(config, schema, None) or getattr(sac_config, schema)
    problems = field_problems(cls)
    assert not problems, f"{schema}: {problems}"
    assert field_range(cls, "seed") == (0, 2**64 - 1)


def test_a_training_seed_beyond_64_bits_is_refused(tmp_path, capsys):
    cfg = _yaml(tmp_path / "s.yaml", TINY_SAC | {"seed": 2**70})
    assert_user_error(
        *run(capsys, "train", "--algo", "sac", "--config", cfg, "--out", tmp_path / "o"),
        "seed",
        "out of range",
    )


def test_digit_rounds_into_a_finished_run_is_refused(tmp_path, capsys):
    out = tmp_path / "rounds"
    out.mkdir()
    (out / "digit_rounds.pt").write_bytes(b"the rounds of an earlier run")
    source = tmp_path / "calibrated"
    source.mkdir()
    (source / "dagger_state.pt").write_bytes(b"checked later")
    argv = ["digit-rounds", "--from", source, "--rounds", "1", "--out", out]
    assert_user_error(*run(capsys, *argv), f"--out {out}", "not empty", "--resume")
    assert (out / "digit_rounds.pt").read_bytes() == b"the rounds of an earlier run"
    with locked_directory(out, what="training run"):
        assert_user_error(*run(capsys, *argv, "--resume"), "another emonav training run")
