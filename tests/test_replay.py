"""Meshcat replays tell the truth, and live viewing waits for the user.

The replays are real recordings of real episodes (Drake diagram, Meshcat server); the
tests decode the HTML the user opens — the msgpack commands `StaticHtml` embeds, which
the browser's Meshcat viewer plays — and compare what it would show at each walking
step with the simulation's own state at that step. Live viewing is tested against the
real CLI in a subprocess with a real websocket client (a raw HTTP Upgrade handshake).
"""

from __future__ import annotations

import base64
import math
import os
import queue
import re
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import msgpack
import numpy as np
import pytest
from pydrake.geometry import Meshcat, MeshcatParams
from pydrake.systems.analysis import Simulator

from emonav_drake.diagrams.meshcat_viewing import (
    ReplayCaption,
    make_meshcat,
    wait_for_browser,
    write_replay_html,
)
from emonav_drake.diagrams.navigation import build_navigation_diagram
from emonav_drake.params import EmoNavConfig
from emonav_drake.planners.dwa import DwaPlanner
from emonav_drake.scenarios.scenario import sample_scenario
from emonav_drake.systems.navigation_meshcat import (
    FOOTSTEPS_RECENT,
    HIT_LIFT,
    OVERVIEW_MIN_HFOV,
    RAY_STRIDE,
    TRAIL_RECENT_STEPS,
    set_overview_camera,
)
from emonav_drake.systems.navigation_meshcat_style import PREFIX

EMONAV = str(Path(sys.executable).parent / "emonav")
SEED = 5  # four pedestrians, three static discs
STEPS = 14  # 5.6 s: two emotion changes (every 2 s) and trail segments that fade


# ---------------------------------------------------------------------------------------
# Reading a replay: the commands embedded in the HTML, and the animation's tracks


def replay_commands(html: str) -> list[dict]:
    """The Meshcat commands a replay's HTML feeds its viewer, in order."""
    payloads = re.findall(
        r'fetch\("data:application/octet-binary;base64,([A-Za-z0-9+/=]*)"\)', html
    )
    assert payloads, "no embedded Meshcat commands"
    return [msgpack.unpackb(base64.b64decode(p), raw=False, strict_map_key=False) for p in payloads]


class Recording:
    """The replay's animation: tracks[path][".visible" | ".position" | ...] = keys."""

    def __init__(self, html: str) -> None:
        self.commands = replay_commands(html)
        animations = [c for c in self.commands if c["type"] == "set_animation"]
        assert len(animations) == 1
        self.tracks: dict[str, dict[str, list[dict]]] = {}
        self.fps = None
        for a in animations[0]["animations"]:
            self.fps = a["clip"]["fps"]
            self.tracks[a["path"]] = {t["name"]: t["keys"] for t in a["clip"]["tracks"]}
        self.objects = {c["path"]: c["object"] for c in self.commands if c["type"] == "set_object"}
        # the static scene: "visible" set without a time (before the animation starts)
        self.static_visible = {
            c["path"]: c["value"]
            for c in self.commands
            if c["type"] == "set_property" and c["property"] == "visible"
        }

    def value(self, path: str, track: str, t: float):
        """What the viewer shows for `track` of `path` at time t [s] (three.js: the last
        key at or before t's frame; before the first key, the first key's value)."""
        keys = self.tracks[path][track]
        frame = math.floor(t * self.fps + 1e-6)
        before = [k for k in keys if k["time"] <= frame]
        return (before[-1] if before else keys[0])["value"]

    def visible(self, path: str, t: float) -> bool:
        """Visibility of `path` at t: its own track, else its static value, else True;
        and all its ancestors visible."""
        parts = path.split("/")
        for n in range(2, len(parts) + 1):
            p = "/".join(parts[:n])
            if ".visible" in self.tracks.get(p, {}):
                if not self.value(p, ".visible", t):
                    return False
            elif not self.static_visible.get(p, True):
                return False
        return True

    def children(self, path: str) -> list[str]:
        """Numbered children `path`/0, `path`/1, ... that have objects below them."""
        pat = re.compile(re.escape(path) + r"/(\d+)(/|$)")
        ids = {int(m.group(1)) for p in self.objects if (m := pat.match(p))}
        return [f"{path}/{i}" for i in sorted(ids)]


def float32_points(obj: dict) -> np.ndarray:
    """The (N, 3) vertex positions of a line-segment object."""
    data = obj["geometries"][0]["data"]["attributes"]["position"]["array"]
    raw = data.data if isinstance(data, msgpack.ExtType) else data
    return np.frombuffer(raw, dtype="<f4").reshape(-1, 3)


# ---------------------------------------------------------------------------------------
# One real LIP episode, recorded, with the simulation's own state at every step


@pytest.fixture(scope="module")
def lip_replay(tmp_path_factory):
    """DWA, seed 5, time-varying emotions, rays on: the replay and the truth at each t_k."""
    cfg = EmoNavConfig()
    cfg.crowd.time_varying_emotions = True
    scenario = sample_scenario(SEED, cfg)
    meshcat = make_meshcat(live=False)
    set_overview_camera(meshcat, cfg)
    nav = build_navigation_diagram(scenario, cfg, DwaPlanner(cfg), meshcat, show_rays=True)
    sim = Simulator(nav.diagram)
    ctx = sim.get_mutable_context()
    meshcat.StartRecording(set_visualizations_while_recording=False)
    sim.Initialize()
    truth = []
    T = cfg.robot.step_time
    for k in range(STEPS + 1):
        if k > 0:  # (AdvanceTo(0) would do the updates at t = 0: read before them)
            sim.AdvanceTo(k * T)
        crowd = nav.crowd.GetOutputPort("crowd").Eval(nav.crowd.GetMyContextFromRoot(ctx))
        robot = nav.robot.GetOutputPort("robot_state").Eval(nav.robot.GetMyContextFromRoot(ctx))
        truth.append(
            {
                "t": k * T,
                "emotions": crowd.emotions.copy(),
                "positions": crowd.positions.copy(),
                "robot": robot.copy(),
            }
        )
    meshcat.StopRecording()
    meshcat.PublishRecording()
    out = tmp_path_factory.mktemp("replay") / "lip.html"
    write_replay_html(meshcat, out, ReplayCaption("dwa", "LIP", SEED, rays=True))
    html = out.read_text()
    return {"html": html, "rec": Recording(html), "truth": truth, "scenario": scenario}


def test_every_pedestrian_body_and_ring_show_the_true_emotion_at_every_step(lip_replay):
    rec, truth = lip_replay["rec"], lip_replay["truth"]
    num_peds = len(lip_replay["scenario"].pedestrians)
    assert num_peds == 4
    # no animated "color" anywhere: three.js cannot bind it in a replay
    assert not any(".color" in tracks for tracks in rec.tracks.values())
    for i in range(num_peds):
        for part in ("body", "ring"):
            for e in range(3):
                assert ".visible" in rec.tracks[f"{PREFIX}/pedestrians/{i}/{part}{e}"]
    changes = 0
    for k, s in enumerate(truth):
        for i in range(num_peds):
            shown = [
                e for e in range(3) if rec.visible(f"{PREFIX}/pedestrians/{i}/body{e}", s["t"])
            ]
            rings = [
                e for e in range(3) if rec.visible(f"{PREFIX}/pedestrians/{i}/ring{e}", s["t"])
            ]
            assert shown == rings == [int(s["emotions"][i])], (k, i)
            pos = rec.value(f"{PREFIX}/pedestrians/{i}", ".position", s["t"])
            assert np.allclose(pos[:2], s["positions"][i], atol=1e-9), (k, i)
        if k > 0:
            changes += int(np.any(s["emotions"] != truth[k - 1]["emotions"]))
    assert changes >= 2  # the time-varying pedestrian changed emotion, and the replay too


def test_rays_are_recorded_per_walking_step_from_the_robot(lip_replay):
    rec, truth = lip_replay["rec"], lip_replay["truth"]
    rays = rec.children(f"{PREFIX}/rays")
    assert len(rays) == STEPS + 1
    beams = EmoNavConfig().lidar.num_beams // RAY_STRIDE
    for k, s in enumerate(truth):
        shown = [p for p in rays if rec.visible(p, s["t"])]
        assert shown == [f"{PREFIX}/rays/{k}"], (k, shown)
        pts = float32_points(rec.objects[shown[0]])
        assert len(pts) == 2 * beams
        # every segment starts at the robot's position at t_k
        assert np.allclose(pts[0::2, :2], s["robot"][:2], atol=1e-5)
    first = float32_points(rec.objects[f"{PREFIX}/rays/1"])
    later = float32_points(rec.objects[f"{PREFIX}/rays/{STEPS}"])
    assert np.abs(first - later).max() > 0.1  # the replay's rays move with the episode


def test_lidar_returns_are_recorded_per_walking_step_on_the_surfaces(lip_replay):
    """Every beam's return as a point above the heads, one object per step shown from t_k
    to t_{k+1}; with the exact scan each lies on a pedestrian's or a disc's outline."""
    rec, truth, scenario = lip_replay["rec"], lip_replay["truth"], lip_replay["scenario"]
    cfg = EmoNavConfig()
    hits = rec.children(f"{PREFIX}/hits")
    assert len(hits) == STEPS + 1
    centres = np.array([d.center for d in scenario.obstacles]).reshape(-1, 2)
    radii = np.array([d.radius for d in scenario.obstacles])
    on_surface = total = 0
    for k, s in enumerate(truth):
        shown = [p for p in hits if rec.visible(p, s["t"])]
        assert shown == [f"{PREFIX}/hits/{k}"], (k, shown)
        pts = float32_points(rec.objects[shown[0]])
        assert len(pts) > 20 and np.allclose(pts[:, 2], 1.7 + HIT_LIFT)
        reach = np.hypot(*(pts[:, :2] - s["robot"][:2]).T)
        assert reach.max() < cfg.lidar.max_range
        gap_ped = np.abs(
            np.hypot(*(pts[:, None, :2] - s["positions"][None]).transpose(2, 0, 1))
            - cfg.crowd.pedestrian_radius
        ).min(axis=1)
        gap_disc = np.abs(
            np.hypot(*(pts[:, None, :2] - centres[None]).transpose(2, 0, 1)) - radii[None]
        ).min(axis=1)
        # a pedestrian moves ≤ 0.15 m between the scan and the step's state
        on_surface += int((np.minimum(gap_ped, gap_disc) < 0.15).sum())
        total += len(pts)
    assert on_surface >= 0.97 * total


def test_trail_appears_step_by_step_and_fades(lip_replay):
    rec, truth = lip_replay["rec"], lip_replay["truth"]
    trail = rec.children(f"{PREFIX}/trail")
    assert len(trail) >= STEPS - 2  # one segment per step the robot moved
    for s in truth:
        shown = [p for p in trail if rec.visible(p, s["t"])]
        assert len(shown) <= round(s["t"] / 0.4)
        for p in shown:
            bright = rec.visible(f"{p}/new", s["t"])
            assert bright != rec.visible(f"{p}/old", s["t"])
    end = truth[-1]["t"]
    assert [p for p in trail if rec.visible(p, end)] == trail  # the whole path at the end
    assert not rec.visible(f"{trail[0]}/new", end) and rec.visible(f"{trail[0]}/old", end)
    assert rec.visible(f"{trail[-1]}/new", end)
    assert sum(rec.visible(f"{p}/new", end) for p in trail) == TRAIL_RECENT_STEPS
    assert not any(rec.visible(p, 0.0) for p in trail)  # nothing walked yet at t = 0


def test_goal_stands_above_rays_and_pedestrians(lip_replay):
    rec = lip_replay["rec"]
    pole = rec.objects[f"{PREFIX}/goal/pole"]["geometries"][0]
    assert pole["type"] == "CylinderGeometry" and pole["height"] >= 1.8
    assert f"{PREFIX}/goal/top" in rec.objects and f"{PREFIX}/goal/pad" in rec.objects
    assert not any(p.startswith(f"{PREFIX}/goal") for p in rec.tracks)  # never hidden


def test_replay_opens_on_the_whole_arena(lip_replay):
    rec, cfg = lip_replay["rec"], EmoNavConfig()
    camera = rec.objects["/Cameras/default/rotated"]["object"]
    fov = math.radians(camera["fov"])
    pos = [
        c["value"]
        for c in rec.commands
        if c["type"] == "set_property" and c["path"] == "/Cameras/default/rotated/<object>"
    ][-1]
    target = [c["value"] for c in rec.commands if c["type"] == "set_target"][-1]
    # three.js (y up) → Drake (z up)
    eye = np.array([pos[0], -pos[2], pos[1]])
    at = np.array([target[0], -target[2], target[1]])
    fwd = (at - eye) / np.linalg.norm(at - eye)
    right = np.cross(fwd, [0, 0, 1])
    right /= np.linalg.norm(right)
    up = np.cross(right, fwd)
    assert eye[2] > 5.0 and math.degrees(math.asin(-fwd[2])) > 35  # above, looking down
    # the crowd's circle (pedestrians start and aim on it), with their heads, and the
    # robot's start and goal: inside the view of a square and of a 16:10 window, the
    # vertical field of view widened in the square one as the replay's script does
    # (horizontal at least OVERVIEW_MIN_HFOV) — and filling most of the landscape one
    r = cfg.crowd.circle_radius_max
    points = [
        [r * math.cos(a), r * math.sin(a), z]
        for a in np.linspace(0, 2 * np.pi, 16)
        for z in (0, 1.7)
    ]
    points += [[*cfg.robot.start, 0], [*cfg.robot.goal, 0]]
    for aspect in (1.0, 1.6):
        tan_h = max(math.tan(fov / 2) * aspect, math.tan(math.radians(OVERVIEW_MIN_HFOV) / 2))
        tan_v = tan_h / aspect
        fill = 0.0
        for point in points:
            d = np.asarray(point) - eye
            depth = d @ fwd
            assert depth > 0 and abs(d @ right) / depth < tan_h, (aspect, point)
            assert abs(d @ up) / depth < tan_v, (aspect, point)
            fill = max(fill, abs(d @ up) / depth / tan_v)
        if aspect > 1:
            assert fill > 0.85  # no wide band of empty floor above or below the arena


def test_replay_caption_names_planner_plant_seed_and_the_legend(lip_replay):
    html = lip_replay["html"]
    overlay = html[html.index('<div id="emonav-caption"') :]
    assert "dwa on LIP, seed 5" in overlay
    for label in ("happy", "neutral", "negative", "static disc", "LiDAR rays"):
        assert label in overlay
    assert overlay.index("</div>") < overlay.index("</body>")
    assert "emonavFov" in overlay  # the view widens in a narrow window
    # the clock and the controls at hand: play / pause, a time slider, "t = … s / … s",
    # driven by Meshcat's animator (checked in headless Chromium: a click pauses and plays,
    # the slider at 75 % shows t = 26.7 s of 35.6 s: benchmarks/results/screenshots/)
    bar = overlay[overlay.index('<div id="emonav-playback"') :]
    for element in ('id="emonav-play"', 'type="range"', 'id="emonav-clock"'):
        assert element in bar
    assert "viewer.animator" in bar and "a.seek(" in bar


# ---------------------------------------------------------------------------------------
# The CLI: a record-only run, live viewing


def _config_file(tmp_path: Path, steps: int) -> Path:
    cfg = tmp_path / "c.yaml"
    cfg.write_text(f"episode: {{max_steps: {steps}}}\n")
    return cfg


@pytest.mark.slow
def test_sim_record_is_quiet_and_the_caption_has_the_outcome(tmp_path):
    html = tmp_path / "r.html"
    args = ["sim", "--planner", "dwa", "--seed", "3", "--rays", "--record", str(html)]
    p = subprocess.run(
        [EMONAV, "--verbose", *args, "--config", str(_config_file(tmp_path, 4))],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert p.returncode == 0, p.stderr
    assert "listening" not in p.stdout + p.stderr and "http://" not in p.stdout + p.stderr
    page = html.read_text()
    assert "dwa on LIP, seed 3" in page and "outcome: timeout after 4 steps (1.6 s)" in page
    rec = Recording(page)
    assert len(rec.children(f"{PREFIX}/rays")) == 5


def connect_websocket(port: int) -> socket.socket:
    """A websocket client of Meshcat's server: the HTTP Upgrade handshake on a raw
    socket; a thread drains what the server sends (the scene)."""
    s = socket.create_connection(("127.0.0.1", port), timeout=10)
    key = base64.b64encode(os.urandom(16)).decode()
    s.sendall(
        (
            f"GET / HTTP/1.1\r\nHost: localhost:{port}\r\nUpgrade: websocket\r\n"
            f"Connection: Upgrade\r\nSec-WebSocket-Key: {key}\r\n"
            "Sec-WebSocket-Version: 13\r\n\r\n"
        ).encode()
    )
    reply = b""
    while b"\r\n\r\n" not in reply:
        chunk = s.recv(4096)
        assert chunk, "connection closed during the handshake"
        reply += chunk
    assert reply.startswith(b"HTTP/1.1 101"), reply[:100]

    def drain() -> None:
        try:
            while s.recv(65536):
                pass
        except OSError:
            pass

    threading.Thread(target=drain, daemon=True).start()
    return s


@pytest.mark.slow
def test_wait_for_browser_times_out_then_sees_a_client():
    # an ephemeral port: a browser tab left open on another Meshcat's URL (they
    # reconnect) cannot connect to this one
    meshcat = Meshcat(MeshcatParams(port=0))
    t0 = time.monotonic()
    assert wait_for_browser(meshcat, timeout=0.3) is False
    assert time.monotonic() - t0 >= 0.3
    clients, port = [], meshcat.port()  # (Meshcat's methods: from this thread only)
    timer = threading.Timer(0.3, lambda: clients.append(connect_websocket(port)))
    timer.start()
    try:
        t0 = time.monotonic()
        assert wait_for_browser(meshcat, timeout=60.0) is True
        assert time.monotonic() - t0 >= 0.25
        assert meshcat.GetNumActiveConnections() >= 1
    finally:
        timer.join()
        for c in clients:
            c.close()


@pytest.mark.slow
def test_sim_meshcat_no_wait_returns_at_once(tmp_path):
    t0 = time.monotonic()
    p = subprocess.run(
        [EMONAV, "sim", "--planner", "dwa", "--seed", "3", "--meshcat", "--no-wait"]
        + ["--config", str(_config_file(tmp_path, 3))],
        capture_output=True,
        text=True,
        timeout=300,  # a wait for a browser would never end: the timeout fails the test
    )
    assert p.returncode == 0, p.stderr
    assert re.search(r"Meshcat: http://\S+:\d+", p.stdout)
    assert "seed 3, dwa on LIP: timeout after 3 steps" in p.stdout
    assert "waiting" not in p.stdout and "still serving" not in p.stdout
    assert time.monotonic() - t0 < 300


def _lines(proc: subprocess.Popen) -> queue.Queue:
    q: queue.Queue = queue.Queue()

    def read() -> None:
        for line in proc.stdout:
            q.put(line)
        q.put(None)

    threading.Thread(target=read, daemon=True).start()
    return q


def _read_until(q: queue.Queue, text: str, timeout: float) -> list[str]:
    seen, deadline = [], time.monotonic() + timeout
    while time.monotonic() < deadline:
        try:
            line = q.get(timeout=0.2)
        except queue.Empty:
            continue
        if line is None:
            raise AssertionError(f"process ended before {text!r}: {seen}")
        seen.append(line)
        if text in line:
            return seen
    raise AssertionError(f"no {text!r} within {timeout} s: {seen}")


@pytest.mark.slow
def test_sim_meshcat_waits_for_a_browser_and_serves_until_ctrl_c(tmp_path):
    proc = subprocess.Popen(
        [EMONAV, "sim", "--planner", "dwa", "--seed", "3", "--meshcat"]
        + ["--config", str(_config_file(tmp_path, 3))],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    client = None
    try:
        q = _lines(proc)
        seen = _read_until(q, "waiting for a browser", 300)
        port = int(re.search(r"Meshcat: http://\S+:(\d+)", "".join(seen)).group(1))
        time.sleep(1.0)
        assert proc.poll() is None  # still waiting: no episode without a browser
        assert q.empty()
        client = connect_websocket(port)
        seen = _read_until(q, "still serving", 300)
        assert any("seed 3, dwa on LIP: timeout after 3 steps" in line for line in seen)
        time.sleep(1.0)
        assert proc.poll() is None  # the scene is still served after the episode
        proc.send_signal(signal.SIGINT)
        assert proc.wait(timeout=60) == 0
    finally:
        if client is not None:
            client.close()
        if proc.poll() is None:
            proc.kill()
            proc.wait()


# ---------------------------------------------------------------------------------------
# Digit: footstep targets (a short episode: standing 0.4 s, then a few steps)


def test_digit_replay_marks_each_footstep_target(tmp_path):
    from emonav_drake.diagrams.navigation_digit import run_digit_episode

    cfg = EmoNavConfig()
    cfg.episode.max_steps = 4
    out = tmp_path / "digit.html"
    meshcat = make_meshcat(live=False)
    record, _ = run_digit_episode(
        sample_scenario(1, cfg), cfg, DwaPlanner(cfg), meshcat=meshcat, record_html=out
    )
    assert record.outcome == "timeout" and record.steps == 4
    rec = Recording(out.read_text())
    steps = rec.children(f"{PREFIX}/footsteps")
    assert len(steps) >= 3  # 1.2 s of walking at T = 0.4 s (earlier on early touchdowns)
    colours = [rec.objects[f"{p}/new"]["materials"][0]["color"] for p in steps]
    assert all(a != b for a, b in zip(colours, colours[1:], strict=False))  # left, right, ...
    end = record.nav_time
    for n, p in enumerate(steps):
        assert not rec.visible(p, 0.0)  # Digit stands at t = 0: no footstep yet
        assert rec.visible(p, end)
        assert rec.visible(f"{p}/new", end) == (n >= len(steps) - FOOTSTEPS_RECENT)
        keys = rec.tracks[p][".position"]
        assert keys[0]["time"] > 0 and abs(keys[-1]["value"][2] - 0.004) < 1e-9
    # the pedestrians' emotions are visibility tracks on Digit too, Digit's links move
    assert ".visible" in rec.tracks[f"{PREFIX}/pedestrians/0/body0"]
    assert any(p.startswith("/drake/visualizer/digit") for p in rec.tracks)
    assert "on Digit, seed 1" in out.read_text()
