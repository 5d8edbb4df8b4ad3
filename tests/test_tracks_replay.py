"""The LiDAR tracks in the Meshcat replays (`--state-source lidar`).

A real LIP episode whose planner reads the crowd tracked from the LiDAR scan is recorded;
the tests decode the replay's HTML (the commands `StaticHtml` embeds, `test_replay.py`'s
`Recording`) and compare what the viewer would show at each walking step t_k with the
tracker's own output at t_k: one ring and velocity arrow per tracked pedestrian, one
darker ring per tracked static disc, shown and hidden as tracks come and go. With the
true state (the default) a replay holds no track objects. Real diagrams, no mocks.
"""

from __future__ import annotations

import math
import subprocess

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator
from test_palette import CVD, EMOTIONS, OTHERS, _hue_gap, delta_e
from test_replay import EMONAV, Recording

from emonav_drake import palette
from emonav_drake.diagrams.meshcat_viewing import ReplayCaption, make_meshcat, write_replay_html
from emonav_drake.diagrams.navigation import build_navigation_diagram
from emonav_drake.params import EmoNavConfig
from emonav_drake.planners.dwa import DwaPlanner
from emonav_drake.scenarios.scenario import sample_scenario
from emonav_drake.systems.navigation_meshcat import set_overview_camera
from emonav_drake.systems.navigation_meshcat_style import PREFIX
from emonav_drake.systems.navigation_meshcat_tracks import (
    TRACK_ARROW_HORIZON,
    TRACK_SLOTS,
    TRACK_STATIC_SLOTS,
)

SEED = 7
STEPS = 20  # 8 s: tracks are born, confirmed, coast and die; static discs get confirmed
PEDS = f"{PREFIX}/tracks/pedestrians"
STATICS = f"{PREFIX}/tracks/static"


def _yaw(quaternion: list[float]) -> float:
    """Yaw [rad] of a three.js quaternion (x, y, z, w) that turns about z only."""
    x, y, z, w = quaternion
    assert abs(x) < 1e-9 and abs(y) < 1e-9
    return 2.0 * math.atan2(z, w)


@pytest.fixture(scope="module")
def tracked_replay(tmp_path_factory):
    """DWA on LIP, seed 7, planner reading the LiDAR tracks: the replay and the tracker's
    output at every t_k."""
    cfg = EmoNavConfig()
    cfg.perception.state_source = "lidar"
    scenario = sample_scenario(SEED, cfg)
    meshcat = make_meshcat(live=False)
    set_overview_camera(meshcat, cfg)
    nav = build_navigation_diagram(scenario, cfg, DwaPlanner(cfg), meshcat)
    tracker = nav.diagram.GetSubsystemByName("crowd_tracker")
    sim = Simulator(nav.diagram)
    ctx = sim.get_mutable_context()
    meshcat.StartRecording(set_visualizations_while_recording=False)
    sim.Initialize()
    seen = []
    T = cfg.robot.step_time
    for k in range(STEPS + 1):
        if k > 0:  # after AdvanceTo(t): what the visualizer published at t
            sim.AdvanceTo(k * T)
        snap = tracker.GetOutputPort("crowd").Eval(tracker.GetMyContextFromRoot(ctx))
        seen.append({"t": k * T, "snap": snap})
    meshcat.StopRecording()
    meshcat.PublishRecording()
    out = tmp_path_factory.mktemp("tracks") / "lidar.html"
    write_replay_html(meshcat, out, ReplayCaption("dwa", "LIP", SEED))
    return {"rec": Recording(out.read_text()), "seen": seen, "scenario": scenario}


def _shown(rec: Recording, root: str, slots: int, t: float) -> list[str]:
    return [f"{root}/{j}" for j in range(slots) if rec.visible(f"{root}/{j}", t)]


def test_each_tracked_pedestrian_has_a_ring_and_a_velocity_arrow(tracked_replay):
    rec, seen = tracked_replay["rec"], tracked_replay["seen"]
    for j in range(TRACK_SLOTS):  # a fixed pool of slots, drawn once
        assert f"{PEDS}/{j}/ring" in rec.objects
        assert f"{PEDS}/{j}/arrow/shaft" in rec.objects and f"{PEDS}/{j}/arrow/head" in rec.objects
        assert ".visible" in rec.tracks[f"{PEDS}/{j}"]  # animated: tracks come and go
    most = 0
    for k, s in enumerate(seen):
        snap, t = s["snap"], s["t"]
        shown = _shown(rec, PEDS, TRACK_SLOTS, t)
        assert len(shown) == len(snap.positions), (k, len(shown), len(snap.positions))
        most = max(most, len(shown))
        for path in shown:  # each shown slot is one of the tracks, with its velocity
            pos = np.asarray(rec.value(path, ".position", t))[:2]
            i = int(np.argmin(np.linalg.norm(snap.positions - pos, axis=1)))
            assert np.allclose(pos, snap.positions[i], atol=1e-6), (k, path)
            vx, vy = snap.velocities[i]
            if rec.visible(f"{path}/arrow", t):
                yaw = _yaw(rec.value(path, ".quaternion", t))
                gap = (yaw - math.atan2(vy, vx) + math.pi) % (2 * math.pi) - math.pi
                assert abs(gap) < 1e-6, (k, path)
                length = rec.value(f"{path}/arrow/shaft", ".scale", t)[0]
                assert length == pytest.approx(math.hypot(vx, vy) * TRACK_ARROW_HORIZON)
                head = rec.value(f"{path}/arrow/head", ".position", t)
                assert head[0] == pytest.approx(length)  # the head at the shaft's tip
    assert most >= 2  # several pedestrians tracked at once
    assert not _shown(rec, PEDS, TRACK_SLOTS, 0.0)  # nothing tracked before the first scan
    ring = rec.objects[f"{PEDS}/0/ring"]["materials"][0]["color"]
    assert ring == int(palette.css(palette.TRACK_RGB)[1:], 16)


def test_tracks_come_and_go_each_slot_shown_at_some_frames_only(tracked_replay):
    rec, seen = tracked_replay["rec"], tracked_replay["seen"]
    times = [s["t"] for s in seen]
    used = [j for j in range(TRACK_SLOTS) if any(rec.visible(f"{PEDS}/{j}", t) for t in times)]
    assert used
    for j in used:  # hidden at the start, shown once tracked
        assert not rec.visible(f"{PEDS}/{j}", 0.0)
    counts = [len(s["snap"].positions) for s in seen]
    # tracks end in this episode (deleted, or turned static: still discs at first) ...
    assert any(b < a for a, b in zip(counts, counts[1:], strict=False))
    ends = [
        j
        for j in used
        if any(
            rec.visible(f"{PEDS}/{j}", a) and not rec.visible(f"{PEDS}/{j}", b)
            for a, b in zip(times, times[1:], strict=False)
        )
    ]
    assert ends  # ... and their slots are hidden then


def test_each_tracked_static_disc_has_a_darker_ring_of_its_radius(tracked_replay):
    rec, seen = tracked_replay["rec"], tracked_replay["seen"]
    assert len(tracked_replay["scenario"].obstacles) >= 1
    for j in range(TRACK_STATIC_SLOTS):
        assert f"{STATICS}/{j}/ring" in rec.objects
    confirmed = False
    for k, s in enumerate(seen):
        snap, t = s["snap"], s["t"]
        shown = _shown(rec, STATICS, TRACK_STATIC_SLOTS, t)
        assert len(shown) == len(snap.static_centers), k
        for path in shown:
            pos = np.asarray(rec.value(path, ".position", t))[:2]
            i = int(np.argmin(np.linalg.norm(snap.static_centers - pos, axis=1)))
            assert np.allclose(pos, snap.static_centers[i], atol=1e-6), (k, path)
            scale = rec.value(path, ".scale", t)
            assert scale[0] == pytest.approx(scale[1]) and scale[2] == 1.0
            confirmed = True
    assert confirmed  # the static discs were confirmed within the episode
    assert not _shown(rec, STATICS, TRACK_STATIC_SLOTS, 0.0)
    ring = rec.objects[f"{STATICS}/0/ring"]["materials"][0]["color"]
    assert ring == int(palette.css(palette.TRACK_STATIC_RGB)[1:], 16)


def test_track_colours_are_no_emotion_nor_another_role():
    # as `test_palette.py` asks of the scene's other roles: apart from every emotion in
    # colour and hue, and from every role also under simulated colour blindness
    for rgb in (palette.TRACK_RGB, palette.TRACK_STATIC_RGB):
        for e in EMOTIONS.values():
            assert delta_e(rgb, e) > 40 and _hue_gap(rgb, e) > 30, (rgb, e)
        for other in [*EMOTIONS.values(), *OTHERS.values()]:
            for vision in CVD:
                assert delta_e(rgb, other, vision) > 15, (rgb, other, vision)
    assert delta_e(palette.TRACK_RGB, palette.TRACK_STATIC_RGB) > 20


# ---------------------------------------------------------------------------------------
# The CLI: the truth draws no tracks, the LiDAR state does


def _record(tmp_path, state_source: str):
    cfg = tmp_path / "c.yaml"
    cfg.write_text("episode: {max_steps: 8}\n")
    html = tmp_path / f"{state_source}.html"
    argv = ["sim", "--planner", "dwa", "--seed", str(SEED), "--record", str(html)]
    p = subprocess.run(
        [EMONAV, *argv, "--state-source", state_source, "--config", str(cfg)],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert p.returncode == 0, p.stderr
    return Recording(html.read_text())


@pytest.mark.slow
def test_sim_record_draws_tracks_only_with_the_lidar_state(tmp_path):
    truth = _record(tmp_path, "truth")
    assert not [p for p in truth.objects if p.startswith(f"{PREFIX}/tracks")]
    lidar = _record(tmp_path, "lidar")
    assert f"{PEDS}/0/ring" in lidar.objects and f"{STATICS}/0/ring" in lidar.objects
    end = 8 * EmoNavConfig().robot.step_time
    assert _shown(lidar, PEDS, TRACK_SLOTS, end)


def test_digit_visualizer_reads_the_tracker_with_the_lidar_state():
    from emonav_drake.diagrams.navigation_digit import build_digit_navigation_diagram

    for source in ("truth", "lidar"):
        cfg = EmoNavConfig()
        cfg.perception.state_source = source
        meshcat = make_meshcat(live=False)
        nav = build_digit_navigation_diagram(
            sample_scenario(SEED, cfg), cfg, DwaPlanner(cfg), meshcat=meshcat
        )
        vis = nav.diagram.GetSubsystemByName("navigation_visualizer")
        fed = {
            (dst.get_name(), i): (src.get_name(), o)
            for (dst, i), (src, o) in nav.diagram.connection_map().items()
        }
        tracks = vis.GetInputPort("tracks").get_index()
        if source == "lidar":
            tracker = nav.diagram.GetSubsystemByName("crowd_tracker")
            crowd = tracker.GetOutputPort("crowd").get_index()
            assert fed[("navigation_visualizer", tracks)] == ("crowd_tracker", crowd)
        else:
            assert ("navigation_visualizer", tracks) not in fed
