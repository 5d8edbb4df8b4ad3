"""The third hostile probe's command-line findings (issue 46, item 5), each refused with one
line that names the flag: symbolic-link loops as inputs and outputs, `compare --out` an
existing file, Python tags in a YAML file, and flags that would have no effect."""

from __future__ import annotations

import json
import os

import pytest

from tests.cli_errors import assert_user_error, run

SYMLINK_LOOP = "symlink loop"


@pytest.fixture
def loop(tmp_path):
    """A symbolic link that points to itself."""
    path = tmp_path / "loop"
    os.symlink(path, path)
    return path


@pytest.mark.parametrize(
    "argv",
    [
        ("compare", "--out", "{loop}", "{tmp}/r1", "{tmp}/r2"),
        ("benchmark", "--plant", "lip", "--planners", "dwa", "--trials", "1", "--out", "{loop}"),
        ("train", "--algo", "dagger", "--out", "{loop}"),
        ("sim", "--json", "{loop}"),
        ("sim", "--json", "{loop}/r.json"),
        ("sim", "--config", "{loop}"),
        ("train", "--algo", "dagger", "--config", "{loop}", "--out", "{tmp}/run"),
        ("sim", "--scenario", "{loop}"),
    ],
    ids=[
        "compare-out",
        "benchmark-out",
        "train-out",
        "sim-json",
        "sim-json-inside",
        "config",
        "train-config",
        "scenario",
    ],
)
def test_a_symlink_loop_is_named_with_its_flag(capsys, tmp_path, loop, argv):
    """Before: `compare` an internal RuntimeError, `benchmark`/`train` '[Errno 17] File
    exists', `--config` 'no such file', `sim --json` replaced the link with the file."""
    argv = [a.format(loop=loop, tmp=tmp_path) for a in argv]
    flag = next(a for a, b in zip(argv, argv[1:], strict=False) if str(loop) in b)
    code, err = run(capsys, *argv)
    assert_user_error(code, err, flag, SYMLINK_LOOP)
    assert os.path.islink(loop)  # the link is left as it was


def test_compare_out_an_existing_file_names_the_flag(capsys, tmp_path):
    out = tmp_path / "tables.md"
    out.write_text("mine\n")
    code, err = run(capsys, "compare", "--out", out, tmp_path / "r1", tmp_path / "r2")
    assert_user_error(code, err, "--out", "not a directory")
    assert out.read_text() == "mine\n"


@pytest.mark.slow
def test_diagnose_out_an_existing_file_names_the_flag(capsys, tmp_path):
    """Before: the run was read and its trials looked at first ('no failed trials …'), and
    with failures the file would have been replaced by a folder's worth of output."""
    run_dir = tmp_path / "b"
    argv = ("benchmark", "--plant", "lip", "--planners", "dwa", "--trials", "1")
    code, err = run(capsys, *argv, "--out", run_dir, "--quiet")
    assert code == 0, err
    out = tmp_path / "diagnosis"
    out.write_text("mine\n")
    code, err = run(capsys, "diagnose", run_dir, "--out", out)
    assert_user_error(code, err, "--out", "not a directory")
    assert out.read_text() == "mine\n"


@pytest.mark.parametrize(
    "text",
    [
        '!!python/object/apply:os.system ["touch {marker}"]\n',
        'robot: !!python/object/apply:os.system ["touch {marker}"]\n',
        "robot: {{max_speed: !!python/name:os.getcwd ''}}\n",
    ],
)
@pytest.mark.parametrize("command", ["config", "scenario", "train"])
def test_python_tags_in_yaml_are_refused_by_name(capsys, tmp_path, text, command):
    """Before: 'expected a mapping node' (true, but no word of why)."""
    marker = tmp_path / "ran"
    path = tmp_path / "evil.yaml"
    path.write_text(text.format(marker=marker))
    argv = {
        "config": ("sim", "--config", path),
        "scenario": ("sim", "--scenario", path),
        "train": ("train", "--algo", "dagger", "--config", path, "--out", tmp_path / "run"),
    }[command]
    code, err = run(capsys, *argv)
    assert_user_error(code, err, "evil.yaml", "Python tag !!python/", "refused")
    assert not marker.exists() and not (tmp_path / "run").exists()


def test_family_with_a_scenario_file_is_refused(capsys):
    """Before: --family silently ignored (the file's scene ran)."""
    code, err = run(capsys, "sim", "--family", "corridor_head_on", "--scenario", "crossing")
    assert_user_error(code, err, "--family corridor_head_on", "--scenario crossing")


@pytest.mark.parametrize("command", ["sim", "eval"])
def test_state_source_with_a_map_policy_is_refused(capsys, command):
    """Before: `sim --planner policy --state-source lidar` ran the policy on its maps and
    said nothing (the state source changes nothing for it)."""
    code, err = run(capsys, command, "--planner", "policy", "--state-source", "lidar")
    assert_user_error(code, err, "--state-source lidar", "--planner policy")


@pytest.mark.slow
def test_sim_json_records_the_state_source(capsys, tmp_path):
    for source in ("truth", "lidar"):
        out = tmp_path / f"{source}.json"
        argv = ("sim", "--plant", "lip", "--planner", "dwa", "--seed", "3")
        code, err = run(capsys, *argv, "--state-source", source, "--json", out)
        assert code == 0, err
        assert json.loads(out.read_text())["state_source"] == source
