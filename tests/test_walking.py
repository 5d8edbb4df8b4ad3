"""The full-order Digit walking diagram: standing, walking, turning, clipping, falls."""

import json
import logging
import math
import re
import sys
from pathlib import Path

import numpy as np
import pytest

from emonav_drake.cli import main
from emonav_drake.diagrams.walking import run_walk
from emonav_drake.params import ConfigError, load_config

JSON_FIELDS = {
    "fell",
    "sim_seconds",
    "wall_seconds",
    "real_time_factor",
    "total_mass",
    "num_positions",
    "num_actuators",
    "mean_forward_speed",
    "tracking_rms",
    "seed",
}


@pytest.mark.slow
def test_standing_still_for_5_s():
    r = run_walk(5.0, command="stand")
    assert not r.fell and r.sim_seconds == pytest.approx(5.0)
    assert len(r.steps) == 0


@pytest.mark.slow
def test_10_s_of_seeded_random_walking_without_falling():
    r = run_walk(10.0, seed=7, command="random")
    out = r.to_json()
    assert set(out) >= JSON_FIELDS
    assert not r.fell, r.fall_reason
    assert out["sim_seconds"] == pytest.approx(10.0)
    assert len(r.steps) >= 23  # T = 0.4 s, after 0.4 s of standing
    # the commands really change every step and the robot follows them
    u = np.array([[s.u_speed, s.u_heading] for s in r.steps])
    assert len(np.unique(u[:, 0])) == len(u)
    assert r.tracking_rms["x"] < 0.08 and r.tracking_rms["y"] < 0.08
    assert r.tracking_rms["heading"] < 0.05
    # same seed, same walk
    r2 = run_walk(2.0, seed=7, command="random")
    assert [s.x for s in r2.steps] == [s.x for s in r.steps[: len(r2.steps)]]


@pytest.mark.slow
def test_straight_walking_at_the_commanded_speed():
    r = run_walk(8.0, command="straight", speed=0.4)
    assert not r.fell, r.fall_reason
    assert r.mean_forward_speed == pytest.approx(0.4, rel=0.10)
    assert abs(r.steps[-1].heading) < 0.05 and abs(r.steps[-1].y) < 0.3


@pytest.mark.slow
def test_turning_in_place_past_pi():
    # u_v = 0, u_Δθ = 0.2 rad per step: more than half a turn, through the ±π wrap of yaw
    r = run_walk(7.2, command="turn", heading_change=0.2)
    assert not r.fell, r.fall_reason
    last = r.steps[-1]
    turned = last.heading_target - last.u_heading  # the target the last step reached
    assert turned > math.pi
    assert last.heading - turned == pytest.approx(0.0, abs=0.05)  # logged yaw is unwrapped
    assert math.hypot(last.x, last.y) < 0.35  # it stayed where it was
    # the swing foot turns by one step's heading change, never the long way round
    assert max(abs(s.swing_yaw[1] - s.swing_yaw[0]) for s in r.steps[1:]) < 0.5


def test_out_of_bound_commands_are_clipped_with_a_warning(caplog):
    with caplog.at_level(logging.WARNING):
        r = run_walk(1.3, command="scripted", script=[(0.8, 0.5), (-0.2, -0.6)])
    assert not r.fell
    assert r.clipped_commands >= 2
    assert "clipped" in caplog.text
    first, second = r.steps[0], r.steps[1]
    assert (first.u_speed, first.u_heading) == (0.4, 0.2)
    assert (second.u_speed, second.u_heading) == (0.0, -0.2)


def test_a_fall_is_an_outcome_not_an_exception():
    r = run_walk(3.0, command="stand", push=(0.0, 2.5, 0.0))  # a hard shove sideways
    assert r.fell and r.fall_reason
    assert r.sim_seconds < 3.0


def test_cli_walk_writes_the_json(tmp_path, capsys):
    out = tmp_path / "w.json"
    assert main(["walk", "--seconds", "1", "--seed", "2", "--json", str(out)]) == 0
    r = json.loads(out.read_text())
    assert set(r) >= JSON_FIELDS
    assert r["seed"] == 2 and not r["fell"] and 44 <= r["total_mass"] <= 50
    assert r["num_positions"] == 19 and r["num_actuators"] == 12
    assert "walked" in capsys.readouterr().out


def test_walking_params_load_from_yaml_and_bad_values_name_the_field():
    cfg = load_config(data="walking:\n  step_width: 0.25\n  kd_leg: [50, 20, 50, 50, 5, 5]\n")
    assert cfg.walking.step_width == 0.25 and cfg.walking.kd_leg[0] == 50
    with pytest.raises(ConfigError, match="walking.step_width"):
        load_config(data="walking:\n  step_width: 2.0\n")
    with pytest.raises(ConfigError, match="walking.arms"):
        load_config(data="walking:\n  arms: floppy\n")
    with pytest.raises(ConfigError, match="walking.kd_leg"):
        load_config(data="walking:\n  kd_leg: [1, 2]\n")


def test_no_mujoco_anywhere_in_the_package():
    root = Path(__file__).resolve().parent.parent / "emonav_drake"
    offenders = [
        str(f)
        for f in root.rglob("*.py")
        if re.search(r"^\s*(import|from)\s+mujoco", f.read_text(), re.MULTILINE)
    ]
    assert offenders == []


def test_meshcat_html_replay(tmp_path):
    out = tmp_path / "walk.html"
    r = run_walk(0.3, command="stand", record_html=out)
    assert not r.fell
    text = out.read_text()
    assert text.lstrip().lower().startswith("<!doctype html") or "<html" in text[:2000].lower()
    assert len(text) > 10_000


def _walk_fields(r) -> str:
    """A walk's result, bit for bit (floats by repr), but its wall time."""
    import dataclasses as dc

    fields = dc.asdict(r)
    del fields["wall_seconds"]
    return json.dumps(fields, sort_keys=True)


@pytest.mark.slow
def test_the_progress_bar_changes_no_walk(capsys):
    """`progress=True` advances the simulator in chunks under a bar on stderr: the same
    walk bit for bit, also when a fall ends it early (the bar then ends at the fall)."""
    for kwargs, note in (
        ({"seconds": 2.3, "seed": 4}, "walked"),  # 0.5, 1.0, …, 2.0, 2.3
        ({"seconds": 3.0, "command": "stand", "push": (0.0, 2.5, 0.0)}, "fall"),
    ):
        quiet = run_walk(**kwargs)
        assert capsys.readouterr().err == ""
        shown = run_walk(**kwargs, progress=True)
        bar = capsys.readouterr().err
        assert _walk_fields(shown) == _walk_fields(quiet)
        end = f"{shown.sim_seconds:.1f}/{shown.sim_seconds:.1f} s simulated"
        assert "walk: 100%" in bar and end in bar and "x real time" in bar and note in bar
        assert shown.fell == (note == "fall")
    assert quiet.sim_seconds < 3.0  # the fall ended the last one early


def test_cli_walk_shows_its_bar_on_a_terminal_only(tmp_path, capsys, monkeypatch):
    outs = {}
    for name, tty, extra in (("pipe", False, []), ("tty", True, []), ("quiet", True, ["--quiet"])):
        monkeypatch.setattr(sys.stderr, "isatty", lambda tty=tty: tty)
        outs[name] = tmp_path / f"{name}.json"
        argv = ["walk", "--seconds", "1.2", "--seed", "3", "--json", str(outs[name])]
        assert main([*argv, *extra]) == 0
        err = capsys.readouterr().err
        assert ("s simulated" in err) == (name == "tty"), (name, err)
    results = [json.loads(p.read_text()) for p in outs.values()]
    for r in results:
        del r["wall_seconds"], r["real_time_factor"]
    assert results[0] == results[1] == results[2]
