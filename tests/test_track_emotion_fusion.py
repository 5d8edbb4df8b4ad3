"""Emotions kept per LiDAR track in the diagram (`--emotion-source camera_tracks`).

A real LIP episode: the head camera renders the faces, BlazeFace and the CNN classify
them every 0.4 s (the cascade every 2 s for the per-frame camera), `TrackEmotionFusion`
assigns them to the tracker's tracks and the tracker's crowd carries each track's kept
emotion. Against the per-frame camera on the same seed the emotions outlive the frame they
were seen in, and every emotion a track carries is one the classifier read on its own
person's face (assignment by track: the CNN itself errs, e.g. a
happy face read as negative). Real diagrams, the real classifier.
"""

from __future__ import annotations

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator

from emonav_drake.diagrams.navigation import build_navigation_diagram
from emonav_drake.params import NEUTRAL, ConfigError, EmoNavConfig
from emonav_drake.perception.face_emotion import three_way_probabilities
from emonav_drake.perception.noisy_emotions import EmotionEstimateParams
from emonav_drake.planners import make_planner
from emonav_drake.scenarios.scenario import sample_scenario

SEED = 1  # two happy pedestrians walk towards the robot: their faces are found


def run(mode: str, until: float = 20.0) -> list[dict]:
    """Every 0.5 s: the tracker's pedestrians (positions, emotions), the true crowd, the
    last classification's faces assigned to pedestrians and, per true pedestrian, the
    emotions read on their face so far (argmax of the 3-way probabilities)."""
    cfg = EmoNavConfig()
    cfg.perception.state_source = "lidar"
    scenario = sample_scenario(SEED, cfg)
    estimate = (  # what --emotion-source camera_tracks runs; the paper's camera otherwise
        EmotionEstimateParams.tracked_faces()
        if mode == "camera_tracks"
        else EmotionEstimateParams(mode=mode)
    )
    nav = build_navigation_diagram(
        scenario, cfg, make_planner("mpc", cfg), emotion_estimate=estimate
    )
    d = nav.diagram
    tracker = d.GetSubsystemByName("crowd_tracker")
    classifier = d.GetSubsystemByName("emotion_classifier")
    sim = Simulator(d)
    ctx = sim.get_mutable_context()
    sim.Initialize()
    out, t, read = [], 0.0, {}
    while t < until:
        t += 0.5
        sim.AdvanceTo(t)
        snap = tracker.GetOutputPort("crowd").Eval(tracker.GetMyContextFromRoot(ctx))
        truth = nav.crowd.GetOutputPort("crowd").Eval(nav.crowd.GetMyContextFromRoot(ctx))
        faces = classifier.GetOutputPort("detections").Eval(classifier.GetMyContextFromRoot(ctx))
        for f, p in enumerate(faces.face_pedestrian.tolist()):
            if p >= 0:
                code = int(np.argmax(three_way_probabilities(faces.probabilities[f])))
                read.setdefault(p, set()).add(code)
        out.append(
            {
                "t": t,
                "positions": snap.positions.copy(),
                "emotions": snap.emotions.copy(),
                "true_positions": truth.positions.copy(),
                "true_emotions": truth.emotions.copy(),
                "faces": int((faces.face_pedestrian >= 0).sum()),
                "read": {p: set(c) for p, c in read.items()},
            }
        )
    return out


@pytest.fixture(scope="module")
def tracks_run():
    return run("camera_tracks")


@pytest.mark.slow
def test_a_tracks_emotion_outlives_the_frame_its_face_was_in(tracks_run):
    kept = [s for s in tracks_run if (s["emotions"] != NEUTRAL).any() and s["faces"] == 0]
    assert kept, "no emotion was kept through a classification without a face"
    per_frame = run("camera")
    known = lambda steps: sum(int((s["emotions"] != NEUTRAL).sum()) for s in steps)  # noqa: E731
    assert known(tracks_run) > known(per_frame)


def test_every_kept_emotion_was_read_on_its_own_persons_face(tracks_run):
    checked = 0
    for s in tracks_run:
        for pos, code in zip(s["positions"], s["emotions"], strict=True):
            if code == NEUTRAL:
                continue
            person = int(np.argmin(np.hypot(*(s["true_positions"] - pos).T)))
            assert code in s["read"].get(person, set()), (s["t"], person, code)
            checked += 1
    assert checked >= 10


@pytest.mark.slow
def test_the_same_episode_twice_gives_the_same_emotions(tracks_run):
    again = run("camera_tracks", until=10.0)
    for a, b in zip(tracks_run, again, strict=False):
        assert np.array_equal(a["emotions"], b["emotions"]) and np.array_equal(
            a["positions"], b["positions"]
        )


def test_camera_tracks_needs_the_lidar_tracker():
    cfg = EmoNavConfig()  # truth state source: no tracker
    with pytest.raises(ConfigError, match="camera_tracks.*--state-source lidar"):
        build_navigation_diagram(
            sample_scenario(SEED, cfg),
            cfg,
            make_planner("mpc", cfg),
            emotion_estimate=EmotionEstimateParams(mode="camera_tracks"),
        )


@pytest.mark.slow
def test_a_benchmark_with_kept_emotions_on_ray_equals_the_serial_run(tmp_path):
    from emonav_drake.diagrams.trials import method_specs
    from emonav_drake.evaluation.benchmark import run_benchmark
    from emonav_drake.evaluation.run_directory import comparable, read_trials
    from emonav_drake.params import load_config
    from emonav_drake.typed_yaml import dump_typed_yaml

    cfg = load_config()
    cfg.perception.state_source = "lidar"
    estimate = dump_typed_yaml(EmotionEstimateParams(mode="camera_tracks"))
    kwargs = dict(methods=method_specs("mpc"), plant="lip", trials=2, first_seed=SEED, config=cfg)
    kwargs.update(emotion_estimate_yaml=estimate, progress=False)
    run_benchmark(out=tmp_path / "serial", workers=1, **kwargs)
    run_benchmark(out=tmp_path / "ray", workers=2, **kwargs)

    def records(run):
        return [comparable(t) for t in read_trials(run / "trials.jsonl")]

    serial = sorted(records(tmp_path / "serial"), key=lambda t: t["seed"])
    assert serial == sorted(records(tmp_path / "ray"), key=lambda t: t["seed"])
    assert len(serial) == 2


def test_the_maps_ring_the_perceived_pedestrians_and_scan_the_true_ones():
    """`observation_frame(..., inflation=)`: the real scan (the maps' 255 cells) is the
    true crowd's, the discomfort rings (127 cells) are the perceived crowd's."""
    import dataclasses as dc

    from emonav_drake.crowd.crowd import CrowdSnapshot
    from emonav_drake.navigation.observations import observation_frame
    from emonav_drake.params import apply_sensor_preset
    from emonav_drake.robot.lip import LipState

    cfg = EmoNavConfig()
    apply_sensor_preset(cfg, "vlp16")
    truth = CrowdSnapshot(
        positions=np.array([[2.5, 0.0]]),
        velocities=np.zeros((1, 2)),
        radius=0.3,
        emotions=np.array([1]),
        discomfort=np.array([0.35]),
        static_centers=np.zeros((0, 2)),
        static_radii=np.zeros(0),
        static_discomfort=0.2,
    )
    robot = LipState(0.0, 0.0, 0.0, 0.0)
    plain = observation_frame(robot, truth, cfg, "lgm")
    same = observation_frame(robot, truth, cfg, "lgm", inflation=truth)
    assert np.array_equal(plain, same)
    negative = dc.replace(truth, emotions=np.array([2]), discomfort=np.array([0.5]))
    wider = observation_frame(robot, truth, cfg, "lgm", inflation=negative)
    assert np.array_equal(wider == 255, plain == 255)  # the same real scan
    assert (wider == 127).sum() > (plain == 127).sum()  # a wider ring
    gone = dc.replace(
        truth,
        positions=np.zeros((0, 2)),
        velocities=np.zeros((0, 2)),
        emotions=np.zeros(0, np.int64),
        discomfort=np.zeros(0),
    )
    unseen = observation_frame(robot, truth, cfg, "lgm", inflation=gone)
    assert (
        np.array_equal(unseen == 255, plain == 255) and (unseen == 127).sum() < (plain == 127).sum()
    )
    with pytest.raises(ValueError, match="drlvo"):
        observation_frame(robot, truth, cfg, "drlvo", inflation=truth)


def test_a_policy_runs_deployable_with_kept_emotions_in_its_maps():
    """The learned policy in the deployable setting with camera_tracks: its maps' rings
    come from the tracker's crowd (the maps' perceived_crowd input is connected)."""
    from emonav_drake.params import apply_deployable

    cfg = EmoNavConfig()
    apply_deployable(cfg)
    cfg.episode.max_steps = 15
    nav = build_navigation_diagram(
        sample_scenario(SEED, cfg),
        cfg,
        make_planner("policy", cfg),
        emotion_estimate=EmotionEstimateParams(mode="camera_tracks"),
    )
    maps = nav.diagram.GetSubsystemByName("grid_maps")
    ctx = nav.diagram.CreateDefaultContext()
    assert maps.GetInputPort("perceived_crowd").HasValue(maps.GetMyContextFromRoot(ctx))
    sim = Simulator(nav.diagram)
    sim.AdvanceTo(3.0)
    stack = maps.GetOutputPort("lgm_stack").Eval(maps.GetMyContextFromRoot(sim.get_context()))
    assert stack.shape[0] == cfg.lidar.num_frames and (stack == 255).any()
