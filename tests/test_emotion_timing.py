"""Emotion known when it matters (`navigation/emotion_timing.py`) and the trace's perceived
column (`navigation/episode_trace.py::perceived_emotions`, filled by the episode loop)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from emonav_drake.navigation.emotion_timing import (
    CameraView,
    approach_samples,
    summarise_approaches,
)
from emonav_drake.navigation.episode_trace import EpisodeTrace, perceived_emotions

DIST = np.array([0.2, 0.35, 0.5])  # happy, neutral, negative
R_PED, R_ROBOT = 0.3, 0.3
VIEW = CameraView(half_fov=math.radians(51), max_range=6.0, period=2.0)


def trace_of(peds_by_row, emotions, perceived_by_row, dt=0.4):
    tr = EpisodeTrace()
    for k, (peds, seen) in enumerate(zip(peds_by_row, perceived_by_row, strict=True)):
        tr.append(k, k * dt, [0, 0, 0, 0], [0, 0], peds, emotions, perceived=seen)
    return tr


def test_perceived_emotions_match_by_position_each_once():
    truth = np.array([[1.0, 0.0], [3.0, 0.0], [5.0, 5.0]])
    seen = np.array([[3.05, 0.0], [1.02, 0.01], [1.1, 0.0]])
    codes = perceived_emotions(truth, seen, np.array([2, 0, 1]))
    assert codes.tolist() == [0, 2, -1]  # nearest first; the far one is not perceived
    assert perceived_emotions(truth, np.zeros((0, 2)), np.zeros(0)).tolist() == [-1, -1, -1]


def test_the_approach_is_the_first_instant_within_the_zone_plus_a_metre():
    # a negative pedestrian walks towards the robot from 6 m at 1 m/s (0.4 m per row),
    # facing it; the robot believes neutral, then negative from row 5 (t = 2 s)
    rows = 15
    peds = [np.array([[6.0 - 0.4 * k, 0.0]]) for k in range(rows)]
    seen = [np.array([1 if k < 5 else 2]) for k in range(rows)]
    tr = trace_of(peds, [2], seen)
    (s,) = approach_samples(tr, DIST, R_PED, R_ROBOT, VIEW)
    # centre distance < 0.3 + 0.5 + 0.3 + 1 = 2.1 m first at 6 − 0.4 k < 2.1: k = 10
    assert s["t"] == pytest.approx(4.0) and s["true"] == 2 and s["perceived"] == 2
    assert s["known"] and s["face_seen_before"]  # at t = 0, 2, 4 in view, facing it
    # believed neutral until the approach: not known
    seen = [np.array([1]) for _ in range(rows)]
    (s,) = approach_samples(trace_of(peds, [2], seen), DIST, R_PED, R_ROBOT, VIEW)
    assert not s["known"] and s["perceived"] == 1


def test_a_person_walking_away_or_behind_shows_no_face_and_one_never_close_gives_no_sample():
    rows = 10
    away = [
        np.array([[1.5 + 0.4 * k, 0.0], [-3.0, 0.0 + 0.0 * k], [9.0, 9.0]]) for k in range(rows)
    ]
    seen = [np.array([-1, -1, -1]) for _ in range(rows)]
    samples = approach_samples(trace_of(away, [0, 2, 1], seen), DIST, R_PED, R_ROBOT, VIEW)
    assert [s["pedestrian"] for s in samples] == [0]  # the one behind is 3 m off, the far one 12 m
    assert not samples[0]["face_seen_before"] and samples[0]["perceived"] == -1
    summary = summarise_approaches(samples)
    assert summary["all"] == {"known": 0, "n": 1, "share": 0.0}
    assert summary["never_perceived"] == 1 and summary["negative"]["n"] == 0


def test_a_trace_without_perceived_emotions_is_refused():
    tr = EpisodeTrace()
    tr.append(0, 0.0, [0, 0, 0, 0], [0, 0], [[1.0, 0.0]], [1])
    with pytest.raises(ValueError, match="perceived"):
        approach_samples(tr, DIST, R_PED, R_ROBOT, VIEW)


def test_a_lip_episode_records_what_the_planner_perceived():
    """The episode loop fills the column: with the simulator's crowd every pedestrian is
    perceived with its true emotion at every instant."""
    from emonav_drake.diagrams.episode import EpisodeRequest
    from emonav_drake.diagrams.plants import plant_named
    from emonav_drake.params import EmoNavConfig
    from emonav_drake.planners import make_planner
    from emonav_drake.scenarios.scenario import sample_scenario

    cfg = EmoNavConfig()
    cfg.episode.max_steps = 20
    request = EpisodeRequest(sample_scenario(3, cfg), cfg, make_planner("dwa", cfg), trace=True)
    _, trace = plant_named("lip").simulate(request)
    assert len(trace.perceived) == len(trace.t) > 5
    for seen, truth in zip(trace.perceived, trace.emotions, strict=True):
        assert np.array_equal(seen, truth)


@pytest.mark.slow
def test_the_study_on_ray_equals_the_serial_run_and_the_script_writes_its_table(tmp_path, capsys):
    from emonav_drake.evaluation.emotion_timing_study import study
    from scripts.emotion_timing_study import main

    args = ([800_001], ["paper"], ["truth", "camera_tracks_blazeface"])
    serial = study(*args, workers=1)
    assert study(*args, workers=2) == serial
    assert [r["variant"] for r in serial] == ["truth", "camera_tracks_blazeface"]
    assert all(r["samples"] for r in serial)
    out = tmp_path / "timing"
    argv = ["--episodes", "1", "--first-seed", "800001", "--families", "paper"]
    assert main([*argv, "--variants", "truth", "--out", str(out)]) == 0
    assert "| paper | truth |" in (out / "table.md").read_text()
    first = (out / "episodes.jsonl").read_text()
    assert first.count("\n") == 1
    argv[1] = "2"  # the same command with one more seed: continues, the first episode kept
    assert main([*argv, "--variants", "truth", "--out", str(out)]) == 0
    both = (out / "episodes.jsonl").read_text()
    assert both.startswith(first) and both.count("\n") == 2
    assert (
        "(2/" in (out / "table.md").read_text()
        or "| paper | truth |" in (out / "table.md").read_text()
    )
    capsys.readouterr()
    assert main(["--episodes", "3", "--first-seed", "498", "--out", str(tmp_path / "x")]) == 2
    assert "0-499" in capsys.readouterr().err and not (tmp_path / "x").exists()
