"""The `emonav` CLI against hostile or careless input (issue 10; docs/reliability.md).

Every bad input must give exit code 2 and one line `emonav: error: ...` on stderr naming
the flag, file or field — no traceback, no output file, no temporary file left behind —
and fail *before* the long work starts (so most tests here take milliseconds). Ctrl-C
gives one line and exit code 130; `eval` keeps the finished episodes.
"""

import json
import math
import struct
import subprocess
import sys
import zlib

import cv2
import numpy as np
import pytest
import torch

from emonav_drake.atomic_io import atomic_output, write_json
from emonav_drake.cli import main
from emonav_drake.errors import RunInterrupted
from emonav_drake.planners.policy import DEFAULT_POLICY
from tests.cli_errors import assert_user_error, run

TINY = "episode: {max_steps: 2}\n"


@pytest.fixture
def tiny(tmp_path):
    """A configuration whose episodes end after 2 steps."""
    path = tmp_path / "tiny.yaml"
    path.write_text(TINY)
    return path


def assert_nothing_left(folder, *targets):
    """No temporary file in `folder`, and none of `targets` written."""
    assert not list(folder.glob("*.tmp*")), list(folder.iterdir())
    for t in targets:
        assert not t.is_file(), t


def _forbid(monkeypatch, module, name):
    """Make `module.name` fail the test if called: proves validation runs before the work."""

    def called(*_a, **_k):
        raise AssertionError(f"{name} ran although the input was invalid")

    monkeypatch.setattr(module, name, called)


# --- Output paths: a directory, a missing folder — checked before any work ------------------


@pytest.mark.parametrize(
    "argv, flag",
    [
        (["sim", "--json", "{dir}"], "--json"),
        (["sim", "--record", "{dir}"], "--record"),
        (["eval", "--episodes", "1", "--json", "{dir}"], "--json"),
        (["lgm", "--png", "{dir}"], "--png"),
        (["walk", "--seconds", "0.1", "--json", "{dir}"], "--json"),
        (["walk", "--seconds", "0.1", "--record", "{dir}"], "--record"),
        (["export", "--out", "{dir}"], "--out"),
    ],
)
def test_output_path_that_is_a_directory(tmp_path, capsys, monkeypatch, argv, flag):
    import emonav_drake.diagrams.navigation as nav

    _forbid(monkeypatch, nav, "build_episode")
    target = tmp_path / "out"
    target.mkdir()
    argv = [a.replace("{dir}", str(target)) for a in argv]
    assert_user_error(*run(capsys, *argv), flag, "is a directory")
    assert_nothing_left(tmp_path)
    assert not list(target.iterdir())


def test_emotion_annotate_and_json_at_a_directory(tmp_path, capsys):
    image = tmp_path / "gray.png"
    cv2.imwrite(str(image), np.full((64, 64, 3), 120, np.uint8))
    for flag in ("--annotate", "--json"):
        assert_user_error(*run(capsys, "emotion", image, flag, tmp_path), flag, "is a directory")
    assert_nothing_left(tmp_path)


@pytest.mark.parametrize("command", ["sim", "eval"])
def test_json_into_a_missing_folder_fails_before_the_episodes(
    tmp_path, capsys, monkeypatch, command
):
    import emonav_drake.diagrams.navigation as nav

    _forbid(monkeypatch, nav, "build_episode")
    out = tmp_path / "missing" / "r.json"
    assert_user_error(*run(capsys, command, "--json", out), "--json", "does not exist")
    assert not (tmp_path / "missing").exists()


def test_two_outputs_naming_the_same_file(tmp_path, capsys):
    out = tmp_path / "same.html"
    assert_user_error(*run(capsys, "sim", "--json", out, "--record", out), "--record", "--json")


def test_train_out_that_is_a_file(tmp_path, capsys):
    out = tmp_path / "run"
    out.write_text("not a directory")
    assert_user_error(*run(capsys, "train", "--algo", "dagger", "--out", out), "--out")
    assert out.read_text() == "not a directory"


# --- Devices and policy checkpoints ----------------------------------------------------------


@pytest.mark.parametrize(
    "argv",
    [
        ["sim", "--planner", "policy", "--device", "bogus"],
        ["train", "--algo", "dagger", "--device", "bogus", "--out", "{tmp}/run"],
    ],
)
def test_bogus_device(tmp_path, capsys, argv):
    argv = [a.replace("{tmp}", str(tmp_path)) for a in argv]
    assert_user_error(*run(capsys, *argv), "--device", "bogus", "cpu")
    assert not (tmp_path / "run").exists()


@pytest.mark.skipif(torch.cuda.is_available(), reason="needs a machine without a GPU")
def test_cuda_without_a_gpu_blames_the_device_not_the_checkpoint(capsys):
    line = assert_user_error(*run(capsys, "sim", "--planner", "policy", "--device", "cuda"))
    assert "--device cuda" in line and "no CUDA GPU" in line and "checkpoint" not in line


def test_device_or_checkpoint_with_a_planner_that_ignores_them(tmp_path, capsys):
    assert_user_error(
        *run(capsys, "sim", "--planner", "dwa", "--device", "cuda"), "--device", "dwa"
    )
    assert_user_error(
        *run(capsys, "sim", "--planner", "dwa", "--checkpoint", tmp_path), "--checkpoint"
    )


def _broken_policy(tmp_path, edit):
    blob = torch.load(DEFAULT_POLICY, weights_only=True)
    edit(blob)
    path = tmp_path / "broken.pt"
    torch.save(blob, path)
    return path


@pytest.mark.parametrize("field", ["observation", "bounds", "kind", "commands"])
@pytest.mark.parametrize("command", ["sim", "export"])
def test_policy_file_missing_a_field(tmp_path, capsys, tiny, field, command):
    path = _broken_policy(tmp_path, lambda b: b.pop(field))
    out = tmp_path / "p.ts"
    if command == "sim":
        argv = ["sim", "--planner", "policy", "--checkpoint", path, "--config", tiny]
    else:
        argv = ["export", path, "--out", out]
    assert_user_error(*run(capsys, *argv), str(path), field)
    assert_nothing_left(tmp_path, out)


@pytest.mark.parametrize(
    "key, value, named",
    [
        ("grid_size", 50, "observation.grid_size"),
        ("num_frames", 4, "observation.num_frames"),
    ],
)
def test_checkpoint_whose_observation_does_not_fit_its_encoder_fails_at_load(
    tmp_path, capsys, key, value, named
):
    from emonav_drake.planners.policy import PolicyError, load_policy

    path = _broken_policy(tmp_path, lambda b: b["observation"].__setitem__(key, value))
    with pytest.raises(PolicyError, match=named.replace(".", r"\.")):
        load_policy(path)  # at load, not at the first inference
    assert_user_error(*run(capsys, "export", path, "--out", tmp_path / "p.ts"), named)
    assert_nothing_left(tmp_path, tmp_path / "p.ts")


# --- Walking flags -----------------------------------------------------------------------


@pytest.mark.parametrize(
    "argv, culprits",
    [
        (["--seconds", "inf"], ["--seconds inf"]),
        (["--seconds", "nan"], ["--seconds nan"]),
        (["--seconds", "0"], ["--seconds 0"]),
        (["--seconds", "-2"], ["--seconds -2"]),
        (["--seed", "-1"], ["--seed -1", ">= 0"]),
        (["--command", "straight", "--speed", "5"], ["--speed 5", "robot.max_speed"]),
        (["--command", "straight", "--speed", "-0.1"], ["--speed -0.1"]),
        (["--command", "turn", "--speed", "0.2"], ["--speed", "--command straight"]),
    ],
)
def test_walk_flags_are_validated_up_front(tmp_path, capsys, monkeypatch, argv, culprits):
    import emonav_drake.diagrams.walking as walking

    _forbid(monkeypatch, walking, "run_walk")
    out = tmp_path / "w.json"
    assert_user_error(*run(capsys, "walk", *argv, "--json", out), *culprits)
    assert_nothing_left(tmp_path, out)


def test_very_short_walk_writes_null_not_nan(tmp_path, capsys):
    out = tmp_path / "w.json"
    assert main(["walk", "--seconds", "0.05", "--json", str(out)]) == 0
    text = out.read_text()
    assert "NaN" not in text
    r = json.loads(text, parse_constant=lambda c: pytest.fail(f"{c} in the JSON"))
    assert r["tracking_rms"] == {"x": None, "y": None, "heading": None}
    assert "n/a" in capsys.readouterr().out
    assert_nothing_left(tmp_path)


def test_json_is_strict_everywhere(tmp_path):
    out = tmp_path / "r.json"
    write_json(out, {"a": float("nan"), "b": [float("inf"), 1.5], "c": np.float32(2.0)})
    assert json.loads(out.read_text()) == {"a": None, "b": [None, 1.5], "c": 2.0}


# --- Training configurations -------------------------------------------------------------


@pytest.mark.parametrize(
    "algo, yaml_text, culprit",
    [
        ("sac", "eval_every: 0\n", "eval_every"),
        ("sac", "checkpoint_every: 0\n", "checkpoint_every"),
        ("sac", "batch_size: -1\n", "batch_size"),
        ("sac", "replay_size: -5\n", "replay_size"),
        ("sac", "grid_size: 7\n", "grid_size"),
        ("sac", "encoder: lstm\n", "encoder"),
        ("sac", "grid_kind: drlvo\n", "num_frames"),
        ("sac", "env: {max_steps: 10}\n", "env"),
        ("sac", "total_steps: many\n", "total_steps"),
        ("sac", "plant: atlas\n", "plant"),
        ("dagger", "rounds: -1\n", "rounds"),
        ("dagger", "rounds: 0\n", "rounds"),
        ("dagger", "episodes_per_round: -3\n", "episodes_per_round"),
        ("dagger", "batch_size: 0\n", "batch_size"),
        ("dagger", "beta: 1.5\n", "beta"),
        ("dagger", "", "empty"),
    ],
)
def test_training_config_values_name_the_field(
    tmp_path, capsys, monkeypatch, algo, yaml_text, culprit
):
    import emonav_drake.learning.dagger as dagger
    import emonav_drake.learning.sac_trainer as sac_trainer

    _forbid(monkeypatch, dagger, "train_dagger")
    _forbid(monkeypatch, sac_trainer, "train_sac")
    cfg = tmp_path / "train.yaml"
    cfg.write_text(yaml_text)
    out = tmp_path / "run"
    argv = ["train", "--algo", algo, "--config", cfg, "--out", out]
    assert_user_error(*run(capsys, *argv), str(cfg), culprit)
    assert not out.exists()


@pytest.mark.parametrize(
    "argv, culprit",
    [
        (["--algo", "sac", "--steps", "-1"], "--steps -1"),
        (["--algo", "sac", "--steps", "0"], "--steps 0"),
        (["--algo", "dagger", "--steps", "10"], "--steps"),
        (["--algo", "dagger", "--plant", "digit"], "--plant"),
        (["--algo", "dagger", "--ray-address", "auto"], "--ray-address"),
        (["--algo", "dagger", "--envs", "4"], "--envs"),
        (["--algo", "sac", "--envs", "0"], "--envs 0"),
        (["--algo", "sac", "--seed", "-4"], "--seed -4"),
        (["--algo", "sac", "--resume", "{tmp}/nowhere"], "--resume"),
    ],
)
def test_training_flags(tmp_path, capsys, monkeypatch, argv, culprit):
    import emonav_drake.learning.sac_trainer as sac_trainer

    _forbid(monkeypatch, sac_trainer, "train_sac")
    argv = [a.replace("{tmp}", str(tmp_path)) for a in argv]
    assert_user_error(*run(capsys, "train", *argv, "--out", tmp_path / "run"), culprit)
    assert not (tmp_path / "run").exists()


def test_train_help_matches_what_the_loader_accepts(capsys):
    with pytest.raises(SystemExit):
        main(["train", "--help"])
    assert "env:" not in capsys.readouterr().out


# --- Scenarios -------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "yaml_text, culprits",
    [
        ("obstacles:\n  - {radius: 0.3}\n", ["obstacles[0].center", "required"]),
        ("obstacles:\n  - {center: [1.0, 1.0]}\n", ["obstacles[0].radius", "required"]),
        ("pedestrians:\n  - {start: [0, 4], goal: [0, -4]}\n", ["pedestrians[0].emotion"]),
        ("pedestrians:\n  - {goal: [0, -4], emotion: happy}\n", ["pedestrians[0].start"]),
        ("obstacles:\n  - {center: [-4.0, 0.1], radius: 0.3}\n", ["robot_start", "obstacles[0]"]),
        ("obstacles:\n  - {center: [4.2, 0.0], radius: 0.4}\n", ["robot_goal", "obstacles[0]"]),
        (
            "robot_start: [0, 0]\nrobot_goal: [5, 0]\n"
            "pedestrians:\n  - {start: [0.3, 0], goal: [0, -4], emotion: happy}\n",
            ["robot_start", "pedestrians[0].start"],
        ),
        ("obstacles:\n  - {center: [1, two], radius: 0.3}\n", ["obstacles[0].center[1]"]),
        ("robot_heading: north\n", ["robot_heading", "a number"]),
        ("obstacle: []\n", ["obstacle", "unknown field"]),
        ("", ["empty"]),
        ("# only a comment\n", ["empty"]),
        ("- 1\n- 2\n", ["mapping"]),
        ("robot_start: [1.0, 2.0\n", ["invalid YAML", "line"]),
    ],
)
def test_bad_scenario_files(tmp_path, capsys, monkeypatch, yaml_text, culprits):
    import emonav_drake.diagrams.navigation as nav

    _forbid(monkeypatch, nav, "build_episode")
    sc = tmp_path / "scene.yaml"
    sc.write_text(yaml_text)
    out = tmp_path / "r.json"
    assert_user_error(*run(capsys, "sim", "--scenario", sc, "--json", out), str(sc), *culprits)
    assert_nothing_left(tmp_path, out)


def test_scenario_without_heading_faces_its_goal(tmp_path):
    from emonav_drake.scenarios.scenario import load_scenario

    sc = tmp_path / "scene.yaml"
    sc.write_text("robot_start: [0.0, 0.0]\nrobot_goal: [0.0, 5.0]\n")
    assert load_scenario(sc).robot_heading == pytest.approx(math.pi / 2)


def test_crowd_that_does_not_fit_is_an_error_not_fewer_objects(tmp_path, capsys):
    from emonav_drake.params import load_config
    from emonav_drake.scenarios.scenario import ScenarioSamplingError, sample_scenario

    text = (
        "crowd: {min_static: 12, max_static: 12, static_x_range: [-1.0, 1.0], "
        "static_y_range: [-1.0, 1.0]}\n"
    )
    with pytest.raises(ScenarioSamplingError, match="static discs"):
        sample_scenario(0, load_config(data=text))
    cfg = tmp_path / "crowded.yaml"
    cfg.write_text(text)
    out = tmp_path / "e.json"
    line = assert_user_error(
        *run(capsys, "eval", "--episodes", "3", "--config", cfg, "--json", out),
        f"--config {cfg}",
        "crowd.static_x_range",
        "crowd.max_static",
    )
    assert "placed only" in line
    assert_nothing_left(tmp_path, out)


def test_time_varying_with_a_scenario_file(tmp_path, capsys, tiny):
    import argparse

    from emonav_drake.cli.resolve import resolve_config, resolve_scenario

    sc = tmp_path / "scene.yaml"
    sc.write_text("pedestrians:\n  - {start: [0.0, 4.0], goal: [0.0, -4.0], emotion: negative}\n")
    args = argparse.Namespace(scenario=sc, seed=3, time_varying=True, config=None)
    scenario = resolve_scenario(args, resolve_config(args))
    schedule = scenario.pedestrians[0].emotion_schedule
    assert schedule[0] == "negative" and len(schedule) >= 25
    assert all(a != b for a, b in zip(schedule, schedule[1:], strict=False))
    out = tmp_path / "r.json"
    argv = ["sim", "--scenario", sc, "--time-varying", "--config", tiny, "--json", out]
    assert run(capsys, *argv)[0] == 0 and out.is_file()
    sc.write_text("obstacles:\n  - {center: [1.0, 1.0], radius: 0.3}\n")  # no pedestrian
    assert_user_error(*run(capsys, "sim", "--scenario", sc, "--time-varying"), "--time-varying")


# --- Configuration files: empty, wrong types, reversed ranges -------------------------------


@pytest.mark.parametrize(
    "yaml_text, culprits",
    [
        ("", ["empty", "EmoNavConfig"]),
        ("robot: {max_speed: fast}\n", ["robot.max_speed", "a number"]),
        ("lidar: {num_frames: 2.5}\n", ["lidar.num_frames", "an integer"]),
        ("crowd: {time_varying_emotions: maybe}\n", ["crowd.time_varying_emotions"]),
        ("robot: {start: 3}\n", ["robot.start", "a list"]),
        ("robot: 5\n", ["robot", "mapping"]),
        ("crowd: {static_x_range: [3.0, -3.0]}\n", ["crowd.static_x_range", "low <= high"]),
        ("crowd: {static_y_range: [1.0, -1.0]}\n", ["crowd.static_y_range"]),
        ("crowd: {circle_radius_min: 5.0, circle_radius_max: 4.0}\n", ["crowd.circle_radius_min"]),
        ("robot: {max_sped: 1}\n", ["robot.max_sped", "unknown field"]),
    ],
)
def test_bad_config_files_name_the_field(tmp_path, capsys, yaml_text, culprits):
    cfg = tmp_path / "c.yaml"
    cfg.write_text(yaml_text)
    out = tmp_path / "g.png"
    assert_user_error(*run(capsys, "lgm", "--config", cfg, "--png", out), str(cfg), *culprits)
    assert_nothing_left(tmp_path, out)


@pytest.mark.parametrize(
    "argv, culprit",
    [
        (["sim", "--seed", "-1"], "--seed -1"),
        (["eval", "--episodes", "0"], "--episodes 0"),
        (["eval", "--first-seed", "-5"], "--first-seed -5"),
        (["lgm", "--steps", "-1", "--png", "{tmp}/g.png"], "--steps -1"),
        (["sim", "--config", "{tmp}/none.yaml"], "no such file"),
        (["sim", "--config", "{tmp}"], "is a directory"),
    ],
)
def test_bad_numbers_and_missing_files(tmp_path, capsys, argv, culprit):
    argv = [a.replace("{tmp}", str(tmp_path)) for a in argv]
    assert_user_error(*run(capsys, *argv), culprit)
    assert_nothing_left(tmp_path, tmp_path / "g.png")


# --- Large images ----------------------------------------------------------------------------


def test_large_image_is_downscaled_and_says_so(tmp_path, capsys):
    image, out = tmp_path / "big.png", tmp_path / "r.json"
    cv2.imwrite(str(image), np.full((600, 800, 3), 90, np.uint8))
    argv = ["emotion", image, "--max-pixels", 120_000, "--json", out]
    code, err = run(capsys, *argv)
    assert code == 0 and "downscaled" in err and "--max-pixels 120000" in err
    r = json.loads(out.read_text())
    assert (r["width"], r["height"]) == (800, 600) and r["scale"] == pytest.approx(0.5, abs=0.01)


def test_image_beyond_the_hard_limit_is_refused_from_its_header(tmp_path, capsys):
    def chunk(kind, data):
        crc = zlib.crc32(kind + data) & 0xFFFFFFFF
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", crc)

    header = struct.pack(">IIBBBBB", 20000, 20000, 8, 2, 0, 0, 0)
    bomb = tmp_path / "bomb.png"
    bomb.write_bytes(
        b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", zlib.compress(b""))
    )
    assert_user_error(*run(capsys, "emotion", bomb), str(bomb), "20000x20000", "megapixels")


@pytest.mark.parametrize(
    "flags, culprit",
    [
        (["--every", "0"], "--every 0"),
        (["--max-frames", "0"], "--max-frames 0"),
        (["--smooth", "0"], "--smooth 0"),
        (["--detection-scale", "3"], "--detection-scale 3"),
        (["--max-pixels", "-1"], "--max-pixels -1"),
        (["--annotate", "{tmp}/a.mp4"], "an image input needs an image suffix"),
        (["--annotate", "{tmp}/gray.png"], "PATH"),
    ],
)
def test_emotion_flags_are_validated_up_front(tmp_path, capsys, flags, culprit):
    image = tmp_path / "gray.png"
    cv2.imwrite(str(image), np.full((64, 64, 3), 120, np.uint8))
    before = image.read_bytes()
    flags = [f.replace("{tmp}", str(tmp_path)) for f in flags]
    assert_user_error(*run(capsys, "emotion", image, *flags), culprit)
    assert image.read_bytes() == before
    assert_nothing_left(tmp_path, tmp_path / "a.mp4")


# --- Atomic writes and interruptions ---------------------------------------------------------


def test_a_write_that_fails_midway_leaves_the_old_file_and_no_temporary(tmp_path):
    out = tmp_path / "r.json"
    out.write_text("old")
    with pytest.raises(KeyboardInterrupt), atomic_output(out) as tmp:
        assert ".tmp-" in tmp.name and tmp.suffix == ".json" and tmp.parent == tmp_path
        tmp.write_text('{"half":')
        raise KeyboardInterrupt
    assert out.read_text() == "old"
    assert_nothing_left(tmp_path)


def test_png_interrupted_while_rendering(tmp_path, capsys, monkeypatch, tiny):
    import emonav_drake.evaluation.grid_map_figure as fig

    def half_written(path, *_a, **_k):
        path.write_bytes(b"\x89PNG half")
        raise KeyboardInterrupt

    monkeypatch.setattr(fig, "render_grid_map_figure", half_written)
    png = tmp_path / "g.png"
    code, err = run(capsys, "lgm", "--config", tiny, "--steps", "0", "--png", png)
    assert code == 130 and "interrupted" in err and "Traceback" not in err
    assert_nothing_left(tmp_path, png)


def test_eval_ctrl_c_keeps_the_finished_episodes(tmp_path, capsys, monkeypatch, tiny):
    import emonav_drake.diagrams.navigation as nav

    real, calls = nav.build_episode, []

    def interrupted_at_the_third(*a, **k):  # the LIP plant builds each episode's diagram
        calls.append(1)
        if len(calls) == 3:
            raise KeyboardInterrupt
        return real(*a, **k)

    monkeypatch.setattr(nav, "build_episode", interrupted_at_the_third)
    out = tmp_path / "e.json"
    argv = ["eval", "--episodes", "10", "--first-seed", "4", "--config", tiny, "--json", out]
    code = main([str(a) for a in argv])
    captured = capsys.readouterr()
    assert code == 130
    lines = [line for line in captured.err.splitlines() if line.startswith("emonav: ")]
    assert len(lines) == 1 and "2 of 10 episodes" in lines[0] and str(out) in lines[0]
    assert "Traceback" not in captured.err
    assert "(2 episodes)" in captured.out  # the summary of the finished ones
    r = json.loads(out.read_text())
    assert r["interrupted"] is True and r["seeds_done"] == [4, 5]
    assert r["summary"]["episodes"] == 2 and len(r["episodes"]) == 2
    assert_nothing_left(tmp_path)


def test_run_interrupted_from_a_trainer_is_one_line_and_130(tmp_path, capsys, monkeypatch):
    import emonav_drake.learning.dagger as dagger

    def stopped(out, *_a, **_k):
        raise RunInterrupted(f"interrupted in round 2; saved in {out}; continue with --resume")

    monkeypatch.setattr(dagger, "train_dagger", stopped)
    code, err = run(capsys, "train", "--algo", "dagger", "--out", tmp_path / "run")
    assert code == 130 and err.strip().splitlines() == [
        f"emonav: interrupted in round 2; saved in {tmp_path / 'run'}; continue with --resume"
    ]


# --- The error path itself -------------------------------------------------------------------


def test_debug_shows_the_traceback(tmp_path):
    from emonav_drake.params import ConfigError

    cfg = tmp_path / "c.yaml"
    cfg.write_text("")
    with pytest.raises(ConfigError, match="empty"):
        main(["--debug", "sim", "--config", str(cfg)])
    with pytest.raises(ConfigError, match="empty"):
        main(["sim", "--debug", "--config", str(cfg)])


def test_an_unexpected_exception_is_one_line_exit_1(capsys, monkeypatch):
    import emonav_drake.cli.lgm as lgm

    monkeypatch.setattr(lgm, "cmd_lgm", lambda args: [][1])  # a bug
    code, err = run(capsys, "lgm", "--png", "x.png")
    assert code == 1 and "Traceback" not in err
    assert err.strip().startswith("emonav: internal error: IndexError") and "--debug" in err


@pytest.mark.slow
def test_exit_code_and_streams_of_the_real_process(tmp_path):
    cfg = tmp_path / "c.yaml"
    cfg.write_text("")
    out = tmp_path / "r.json"
    p = subprocess.run(
        [sys.executable, "-m", "emonav_drake.cli", "sim", "--config", cfg, "--json", out],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert p.returncode == 2 and p.stdout == ""
    assert p.stderr.splitlines() == [
        f"emonav: error: {cfg}: the file is empty; expected a YAML mapping of EmoNavConfig fields"
    ]
    assert_nothing_left(tmp_path, out)


def test_a_temp_file_left_by_a_killed_writer_is_removed_on_the_next_write(tmp_path):
    from emonav_drake.atomic_io import write_json

    target = tmp_path / "out.json"
    dead = subprocess.run(
        [sys.executable, "-c", "import os; print(os.getpid())"],
        capture_output=True,
        text=True,
        check=True,
    )
    stale = tmp_path / f"out.tmp-{int(dead.stdout)}-abc.json"  # a SIGKILLed save
    stale.write_text('{"half')
    live = tmp_path / "out.tmp-1-xyz.json"  # pid 1 runs: another writer's file stays
    live.write_text("")
    write_json(target, {"a": 1})
    assert not stale.exists() and live.exists()
    assert json.loads(target.read_text()) == {"a": 1}
