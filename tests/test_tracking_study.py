"""The LiDAR tracking study (`evaluation/tracking_study.py`): real scans, the real
detector and tracker, the real MPC on the LIP world, CLEAR-MOT by py-motmetrics.

The hand checks build the truth of every scan directly (a stationary robot, a scripted
straight walk), so that every count is known in advance.
"""

from __future__ import annotations

import dataclasses as dc
import json
import math

import numpy as np
import pytest

from emonav_drake.evaluation.scan_visibility import (
    OCCLUDED,
    OUT_OF_RANGE,
    PARTLY_OCCLUDED,
    VISIBLE,
    visibility,
)
from emonav_drake.evaluation.tracking_evaluator import MATCH_DISTANCE, EpisodeEvaluator, ScanTruth
from emonav_drake.evaluation.tracking_report import tables_md
from emonav_drake.evaluation.tracking_study import study
from emonav_drake.evaluation.tracking_summary import summarise
from emonav_drake.params import EmoNavConfig
from emonav_drake.sensing.crowd_tracker import TrackerParams
from emonav_drake.sensing.lidar import beam_step
from emonav_drake.sensing.lidar_objects import DetectionParams

CFG = EmoNavConfig()
R_PED = CFG.crowd.pedestrian_radius
DT = CFG.crowd.dt
NO_DISCS = (np.zeros((0, 2)), np.zeros(0))


def walk(n: int, discs=NO_DISCS) -> list[ScanTruth]:
    """n scans (t = k·dt) from a robot standing at the origin facing +x of one
    pedestrian walking +y at 1 m/s along x = 3 m, from y = −1.5 m: always in full view."""
    return [
        ScanTruth(
            time=k / 10,
            robot_xy=np.zeros(2),
            heading=0.0,
            ped_positions=np.array([[3.0, -1.5 + 0.1 * k]]),
            ped_velocities=np.array([[0.0, 1.0]]),
            static_centers=discs[0],
            static_radii=discs[1],
        )
        for k in range(n)
    ]


def evaluate(scans: list[ScanTruth]):
    ev = EpisodeEvaluator(CFG)
    for s in scans:
        ev.observe(s)
    return ev.result(seed=1, outcome="none", steps=0)


def test_visibility_counts_own_beams_hidden_beams_and_range():
    robot = np.zeros(2)
    # Alone at 3 m: the beams within asin(r/d) of its bearing, none hidden.
    peds = np.array([[3.0, 0.0], [6.5, 0.0]])
    own, vis, cat = visibility(robot, 0.0, peds, R_PED, *NO_DISCS, CFG)
    expected = 2 * math.asin(R_PED / 3.0) / beam_step(CFG.lidar.num_beams)  # 57.4
    assert abs(own[0] - expected) <= 1 and vis[0] == own[0] and cat[0] == VISIBLE
    assert cat[1] == OUT_OF_RANGE  # its centre is beyond the 6 m range
    # A disc at 1.5 m, half-width asin(0.4/1.5) = 15.5°, hides it completely (5.7°).
    own, vis, cat = visibility(robot, 0.0, peds[:1], R_PED, np.array([[1.5, 0.0]]), [0.4], CFG)
    assert own[0] == pytest.approx(expected, abs=1) and vis[0] == 0 and cat[0] == OCCLUDED
    # A small disc in front of one half: the other half shows, more than min_points beams.
    own, vis, cat = visibility(robot, 0.0, peds[:1], R_PED, np.array([[1.5, 0.1]]), [0.1], CFG)
    assert DetectionParams().min_points <= vis[0] < own[0] and cat[0] == PARTLY_OCCLUDED


def test_one_pedestrian_in_full_view_misses_only_the_scans_before_confirmation():
    n = 20
    s = summarise([evaluate(walk(n))])
    m = s["clear_mot"]
    # Scans 1 and 2 hold tentative tracks (3 hits confirm): 2 misses, then 18 matches.
    hits = TrackerParams().confirm_hits
    assert hits == 3
    assert m["num_objects"] == n and m["num_frames"] == n
    assert m["num_misses"] == hits - 1 and m["num_matches"] == n - (hits - 1)
    assert m["num_false_positives"] == 0 and m["num_switches"] == 0
    assert s["switches_by_gap"] == {"swap": 0, "reacquired": 0, "after_deletion": 0}
    assert m["mota"] == pytest.approx(1 - (hits - 1) / n)  # 0.9
    assert s["misses_by_cause"] == {
        "out_of_range": 0,
        "occluded": 0,
        "unconfirmed": 2,
        "static": 0,
        "other": 0,
    }
    # Noise-free circles: the fitted centres are exact to millimetres, and the position
    # of a constant-velocity walk is tracked to the fit's error.
    assert m["motp"] < 0.005 and s["position_rmse"] < 0.005
    assert s["velocity_rmse"] < 0.5  # the first confirmed estimates still converge
    assert s["velocity_rmse_settled"] < 0.05  # tracks older than 1 s
    assert s["visibility"]["pedestrian_scans"] == {
        "visible": n,
        "partly_occluded": 0,
        "occluded": 0,
        "out_of_range": 0,
    }
    assert "| MOTA | 0.900 |" in tables_md(s)


def test_a_static_disc_is_a_false_pedestrian_until_its_still_time():
    n = 30
    disc = (np.array([[-2.0, 0.0]]), np.array([0.3]))  # behind the robot: hides nothing
    s = summarise([evaluate(walk(n, disc))])
    m = s["clear_mot"]
    # The disc's track is born at t = 0 at rest (still since then), confirmed at scan 3
    # (t = 0.2) and static from t = still_duration = 2.0 s: a moving confirmed track,
    # i.e. a false pedestrian, at t = 0.2 … 1.9, 18 scans.
    assert TrackerParams().still_duration == 2.0
    assert m["num_false_positives"] == 18 and m["num_misses"] == 2
    assert m["num_switches"] == 0
    assert m["mota"] == pytest.approx(1 - (2 + 18) / n)
    assert s["false_positives_by_cause"] == {"static_disc": 18, "coasting": 0, "other": 0}
    d = s["static_discs"]
    assert d["discs"] == 1 and d["seen"] == 1 and d["reported_static"] == 1
    assert d["delay_s"]["median"] == pytest.approx(2.0)
    # After the still time (t = 2.0 … 2.9) it is a static obstacle at every scan.
    assert d["scans_after_still_time"] == 10 and d["reported_after_still_time"] == 1.0


def test_a_pedestrian_hidden_behind_a_disc_coasts_is_deleted_and_comes_back_as_a_switch():
    # Walking +y at 0.25 m/s along x = 3 m behind a disc at (1.5, 0): hidden (fewer than
    # min_points visible beams) from scan a to scan b − 1, about 4.5 s.
    disc = (np.array([[1.5, 0.0]]), np.array([0.4]))
    n = 101
    slow = np.array([[0.0, 0.25]])
    scans = [
        dc.replace(scan, ped_positions=np.array([[3.0, -1.5 + 0.025 * k]]), ped_velocities=slow)
        for k, scan in enumerate(walk(n, disc))
    ]
    r = evaluate(scans)
    hidden = np.flatnonzero(r.peds["category"] == OCCLUDED)
    a, b = int(hidden[0]), int(hidden[-1]) + 1
    assert np.array_equal(hidden, np.arange(a, b)) and b - a > 20
    coast = round(TrackerParams().max_coast / DT)  # 15 scans of coasting, then deleted
    s = summarise([r])
    m = s["clear_mot"]
    # The constant-velocity prediction is exact: tracked while coasting (scans a … a+14),
    # missed from the deletion to b − 1; back at b as a new track, confirmed at b + 2.
    assert r.peds["tracked"][a : a + coast].all() and not r.peds["tracked"][a + coast : b + 2].any()
    assert s["misses_by_cause"]["occluded"] == b - a - coast
    assert s["misses_by_cause"]["unconfirmed"] == 2 + 2
    assert m["num_switches"] == 1
    assert s["switches_by_gap"] == {"swap": 0, "reacquired": 0, "after_deletion": 1}
    assert m["num_false_positives"] == 18  # the disc until its still time, as above
    misses = b - a - coast + 4
    assert m["num_misses"] == misses and m["num_matches"] == n - misses - 1
    assert m["mota"] == pytest.approx(1 - (misses + 18 + 1) / n)
    rows = {row["scans_hidden"]: row for row in s["by_hidden_time"]}
    assert all(rows[k]["tracked_rate"] == 1.0 for k in range(1, coast + 1))
    assert rows[f">={coast + 1}"]["tracked_rate"] == 0.0
    assert rows[f">={coast + 1}"]["samples"] == b - a - coast


@pytest.mark.slow
def test_study_on_two_short_episodes_runs_and_repeats_exactly():
    cfg = dc.replace(CFG, episode=dc.replace(CFG.episode, max_steps=15))
    seeds = [700_000, 700_001]
    a = summarise(study(seeds, cfg), cfg)
    b = summarise(study(seeds, cfg), cfg)
    assert json.dumps(a, sort_keys=True) == json.dumps(b, sort_keys=True)
    assert a["episodes"] == 2 and a["seeds"] == seeds
    # 15 steps of 4 scans each (an episode that ends earlier has fewer).
    assert 0 < a["scans"] <= 2 * 15 * 4
    m = a["clear_mot"]
    assert m["num_objects"] == m["num_matches"] + m["num_switches"] + m["num_misses"]
    assert -1.0 <= m["mota"] <= 1.0 and 0.0 <= m["motp"] <= MATCH_DISTANCE
    cats = a["visibility"]["pedestrian_scans"]
    # CLEAR-MOT scores the pedestrians within the LiDAR's range (6 m): out of range, none
    assert sum(cats.values()) - cats["out_of_range"] == m["num_objects"]
    assert a["misses_by_cause"]["out_of_range"] == 0
    assert sum(a["misses_by_cause"].values()) == m["num_misses"]
    assert sum(a["false_positives_by_cause"].values()) == m["num_false_positives"]


def test_script_refuses_evaluation_seeds(tmp_path, capsys):
    from scripts.tracking_study import main

    assert main(["--episodes", "2", "--first-seed", "498", "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--first-seed" in err[0] and "0-499" in err[0]
    assert list(tmp_path.iterdir()) == []  # nothing written


@pytest.mark.slow
def test_script_writes_every_result_and_the_tables_the_docs_quote(tmp_path, capsys):
    from emonav_drake.evaluation.results_doc import section_of
    from scripts.tracking_study import main

    out, png = tmp_path / "run", tmp_path / "fig" / "tracking.png"
    argv = ["--episodes", "1", "--first-seed", "700000", "--out", str(out), "--png", str(png)]
    assert main(argv) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["seeds"] == [700_000] and summary["episodes"] == 1
    assert summary["command"].startswith("python scripts/tracking_study.py --episodes 1")
    for name in ("episodes.csv", "scans.csv", "by_distance.csv", "by_hidden_time.csv"):
        assert (out / name).stat().st_size > 0
    scans = (out / "scans.csv").read_text().splitlines()
    assert len(scans) == 1 + summary["scans"]
    for section in ("Tracking quality", "Visibility", "Static discs"):
        assert section_of(out / "tables.md", section).startswith("| ")
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert not list(out.glob("*.tmp*")) and not list(png.parent.glob("*.tmp*"))


def test_a_track_of_a_pedestrian_outside_the_scored_region_is_dont_care():
    """CLEAR-MOT's scored region (range and field of view): a hypothesis within the match
    distance of a pedestrian takes that pedestrian's side of the border; others count
    where they are."""
    from emonav_drake.evaluation.tracking_evaluator import _scored_hypotheses

    ped_scored = np.array([True, False])
    # hypotheses: 0 follows the scored pedestrian from just outside the view; 1 follows
    # the unscored one from just inside; 2 is alone inside, 3 alone outside
    gap = np.array([[0.1, 5.0, 5.0, 5.0], [5.0, 0.2, 5.0, 5.0]])
    in_view = np.array([False, True, True, False])
    scored = _scored_hypotheses(gap, ped_scored, in_view, MATCH_DISTANCE)
    assert scored.tolist() == [True, False, True, False]
    assert MATCH_DISTANCE < 5.0
    # nearest pedestrian decides when two are within reach
    gap = np.array([[0.4], [0.1]])
    assert _scored_hypotheses(gap, ped_scored, np.array([True]), 0.5).tolist() == [False]
    empty = _scored_hypotheses(np.zeros((0, 2)), np.zeros(0, bool), np.array([True, False]), 0.5)
    assert empty.tolist() == [True, False]


@pytest.mark.slow
def test_the_sensor_table_runs_each_study_once_and_refuses_the_tuning_seeds(tmp_path, capsys):
    from scripts.tracking_sensors import main

    out = tmp_path / "sensors"
    argv = ["--episodes", "1", "--first-seed", "800000", "--out", str(out)]
    argv += ["--presets", "vlp16", "--families", "paper"]
    assert main(argv) == 0
    table = (out / "table.md").read_text()
    assert "| vlp16 | paper | 1 (" in table and "--presets vlp16" in table
    rows = json.loads((out / "table.json").read_text())["rows"]
    summary = json.loads((out / "vlp16_paper" / "summary.json").read_text())
    assert rows[0]["mota"] == summary["clear_mot"]["mota"]
    assert summary["sensor"]["preset"] == "vlp16" and summary["family"] == "paper"
    capsys.readouterr()
    assert main(argv) == 0  # the study is kept, not run again
    assert "done before, kept" in capsys.readouterr().out
    bad = ["--episodes", "5", "--first-seed", "700010", "--out", str(tmp_path / "bad")]
    assert main(bad) == 2
    assert "tuning seeds" in capsys.readouterr().err and not (tmp_path / "bad").exists()
