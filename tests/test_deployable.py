"""The deployable setting: `--deployable` = LiDAR state on a real sensor's scan.

What a robot could run: the state-based planners read the crowd tracked in a scan with the
faults of the VLP-16 (or another real preset given with `--sensor`), the learned policies
their grid maps of that scan. Tests: the resolved configuration, the refusals (one line,
nothing written), what a run's settings record, that a replay command rebuilds the flags,
and that an episode really runs on the noisy scan (its result differs from the exact one).
"""

from __future__ import annotations

import argparse
import json

import pytest
from cli_errors import assert_user_error, run

from emonav_drake.cli import main
from emonav_drake.cli.resolve import resolve_config
from emonav_drake.diagrams.trials import MethodSpec
from emonav_drake.evaluation.failures import config_flags
from emonav_drake.evaluation.run_settings import check_settings, make_settings
from emonav_drake.params import (
    DEPLOYABLE_SENSOR,
    ConfigError,
    apply_deployable,
    is_deployable,
    load_config,
)


def resolved(**flags):
    base = dict(setting=None, config=None, time_varying=False, state_source=None)
    base.update(family=None, sensor=None, deployable=False)
    base.update(flags)
    return resolve_config(argparse.Namespace(**base))


def test_deployable_is_lidar_state_on_the_vlp16():
    r = resolved(setting="var_dd", deployable=True)
    cfg = r.config
    assert DEPLOYABLE_SENSOR == "vlp16"
    assert cfg.perception.state_source == "lidar"
    assert cfg.sensor.preset == "vlp16" and not cfg.sensor.is_exact()
    assert cfg.sensor.people_as == "legs" and cfg.sensor.range_noise_std > 0
    assert is_deployable(cfg)
    assert r.source == "--setting var_dd --deployable"
    # the emotions are the setting's: deployable changes only what is sensed of positions
    plain = resolved(setting="var_dd").config
    assert cfg.reward == plain.reward and cfg.crowd == plain.crowd
    assert not is_deployable(plain)


def test_another_real_sensor_and_a_configured_one_are_kept(tmp_path):
    r = resolved(deployable=True, sensor="ust10lx")
    assert r.config.sensor.preset == "ust10lx" and is_deployable(r.config)
    assert r.source.endswith("--deployable --sensor ust10lx")
    file = tmp_path / "noisier.yaml"
    file.write_text("sensor: {preset: vlp16, range_noise_std: 0.05}\n")
    cfg = resolved(config=file, deployable=True).config  # the file's sensor, not the preset
    assert cfg.sensor.range_noise_std == 0.05 and cfg.perception.state_source == "lidar"
    cfg = load_config(file)
    apply_deployable(cfg, "vlp16")  # a sensor named explicitly: the whole preset
    assert cfg.sensor.range_noise_std != 0.05


def test_the_ideal_scan_is_not_deployable():
    with pytest.raises(ConfigError, match=r"--deployable --sensor ideal: sensor\.preset"):
        resolved(deployable=True, sensor="ideal")
    with pytest.raises(ConfigError, match="--state-source truth"):
        resolved(deployable=True, state_source="truth")
    assert not is_deployable(resolved(state_source="lidar").config)  # exact scan: upper bound


@pytest.mark.parametrize(
    "flags,culprit",
    [
        (["--sensor", "ideal"], "sensor.preset"),
        (["--state-source", "truth"], "--state-source truth"),
    ],
)
def test_contradicting_flags_are_one_line_and_nothing_is_written(tmp_path, capsys, flags, culprit):
    out = tmp_path / "run"
    code, err = run(capsys, "benchmark", "--planners", "dwa", "--deployable", *flags, "--out", out)
    assert_user_error(code, err, culprit, "--deployable")
    assert not out.exists()
    sim = ["sim", "--planner", "dwa", "--deployable", *flags, "--json", tmp_path / "t.json"]
    code, err = run(capsys, *sim)
    assert_user_error(code, err, culprit, "--deployable")
    assert not (tmp_path / "t.json").exists()


def test_a_run_records_the_sensor_and_rebuilds_its_flags():
    r = resolved(setting="no_emotion", deployable=True)
    methods = [MethodSpec("mpc", "mpc", None, None, "state")]
    settings = make_settings(methods, "lip", 3, 0, r.config, r.setting, r.source)
    assert settings["deployable"] is True
    assert settings["sensor"]["preset"] == "vlp16"
    assert settings["sensor"]["range_noise_std"] == r.config.sensor.range_noise_std
    assert "deployable (lidar state, sensor vlp16)" in settings["setting_label"]
    check_settings(json.loads(json.dumps(settings)), "settings.json")
    assert config_flags(settings) == ["--setting", "no_emotion", "--deployable"]
    r = resolved(deployable=True, sensor="ust10lx", family="dense_20")
    settings = make_settings(methods, "lip", 3, 0, r.config, None, r.source)
    assert config_flags(settings) == [
        "--deployable",
        "--family",
        "dense_20",
        "--sensor",
        "ust10lx",
    ]
    # an exact scan: the settings a run always had (no sensor, no deployable field)
    plain = resolved(setting="var_dd")
    old = make_settings(methods, "lip", 3, 0, plain.config, plain.setting, plain.source)
    assert "sensor" not in old and "deployable" not in old


@pytest.mark.slow
@pytest.mark.parametrize("planner", ["mpc", "policy"])
def test_an_episode_runs_on_the_noisy_scan(tmp_path, capsys, planner):
    """The same seed with the exact scan and deployable: the planner sees another crowd
    (or other maps), so the robot walks another path; sim --json says what it sensed."""
    config = tmp_path / "short.yaml"
    config.write_text("episode: {max_steps: 30}\n")
    results = {}
    for name, flags in (("exact", []), ("deployable", ["--deployable"])):
        out = tmp_path / f"{name}.json"
        argv = ["sim", "--planner", planner, "--seed", "5", "--config", str(config), *flags]
        if planner == "mpc" and not flags:
            argv += ["--state-source", "lidar"]
        assert main([*argv, "--json", str(out)]) == 0
        capsys.readouterr()
        results[name] = json.loads(out.read_text())
    exact, deployable = results["exact"], results["deployable"]
    assert exact["sensor"] == "ideal" and not exact["deployable"]
    assert deployable["sensor"] == "vlp16" and deployable["deployable"]
    assert exact["emotion_source"] == "truth" and deployable["emotion_source"] == "camera_tracks"
    assert deployable["state_source"] == "lidar"
    assert deployable["path_length"] != exact["path_length"]


@pytest.mark.slow
def test_eval_says_what_the_robot_sensed(tmp_path, capsys):
    config = tmp_path / "short.yaml"
    config.write_text("episode: {max_steps: 10}\n")
    out = tmp_path / "eval.json"
    argv = ["eval", "--planner", "dwa", "--episodes", "1", "--first-seed", "900000"]
    assert main([*argv, "--config", str(config), "--deployable", "--json", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "sensed: short [0.2, 0.35, 0.5] m, deployable (lidar state, sensor vlp16)" in printed
    assert "emotions: camera_tracks" in printed  # a robot's own camera, kept per track
    result = json.loads(out.read_text())
    assert result["deployable"] is True and result["sensor"] == "vlp16"
    assert result["state_source"] == "lidar" and result["emotion_source"] == "camera_tracks"
    argv += ["--config", str(config), "--deployable", "--emotion-source", "truth"]
    assert main([*argv, "--json", str(out)]) == 0
    assert "emotions: ground truth" in capsys.readouterr().out


def test_deployable_sees_emotions_with_its_camera_unless_told_otherwise():
    from emonav_drake.cli.common import emotion_estimate_of
    from emonav_drake.evaluation.failures import rerun_command

    def estimate(**flags):
        base = dict(emotion_source=None, emotion_estimate=None, deployable=False)
        return emotion_estimate_of(argparse.Namespace(**{**base, **flags}))

    assert estimate() is None
    kept = estimate(deployable=True)
    assert kept.mode == "camera_tracks" and kept.camera.face_detector == "blazeface"
    assert estimate(deployable=True, emotion_source="truth") is None
    assert estimate(deployable=True, emotion_source="camera").mode == "camera"
    # a deployable run made with the simulator's emotions replays with them
    r = resolved(setting="var_dd", deployable=True)
    methods = [MethodSpec("mpc", "mpc", None, None, "state")]
    settings = make_settings(methods, "digit", 3, 0, r.config, r.setting, r.source)
    command = rerun_command(settings, "mpc", 2)
    assert command.endswith("--setting var_dd --deployable --emotion-source truth")
