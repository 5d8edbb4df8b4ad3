"""`EmotionClassifier` and `EmotionEstimateSource` in Drake diagrams."""

import dataclasses as dc

import numpy as np
import pytest
from pydrake.common.value import AbstractValue
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantValueSource, ConstantVectorSource

from emonav_drake.crowd.crowd import CrowdSnapshot
from emonav_drake.navigation.observations import observation_frame
from emonav_drake.params import HAPPY, NEGATIVE, NEUTRAL, EmoNavConfig
from emonav_drake.perception.face_assignment import face_bearings
from emonav_drake.perception.face_emotion import FaceEmotionClassifier
from emonav_drake.perception.noisy_emotions import EmotionEstimateParams
from emonav_drake.perception.sample_photos import camera_frame
from emonav_drake.planners.dwa import DwaPlanner
from emonav_drake.robot.lip import LipState
from emonav_drake.scenarios.scenario import sample_scenario
from emonav_drake.systems.crowd_system import CrowdSystem
from emonav_drake.systems.emotion_classifier import (
    EmotionClassifier,
    EmotionEstimate,
    image_from_bgr,
)
from emonav_drake.systems.emotion_estimate_source import (
    AddEmotionEstimateSource,
    EmotionEstimateSource,
)
from emonav_drake.systems.episode_monitor import EpisodeMonitor
from emonav_drake.systems.lidar_grid_map_builder import LidarGridMapBuilder
from emonav_drake.systems.lip_robot_plant import LipRobotPlant
from emonav_drake.systems.navigation_planner import NavigationPlanner

pytest.importorskip("skimage", reason="the astronaut photo ships with scikit-image")

ROBOT = np.array([1.0, -1.0, 0.3, 0.0])  # x, y, θ, v


class CountingClassifier(FaceEmotionClassifier):
    """Counts frames so the test can check the 0.5 Hz rate."""

    calls = 0

    def classify(self, image, channel_order="bgr"):
        CountingClassifier.calls += 1
        return super().classify(image, channel_order)


@pytest.fixture(scope="module")
def classifier():
    return CountingClassifier()


def _crowd(positions, emotions, config):
    d = np.asarray(config.reward.emotion_distances())
    e = np.asarray(emotions, np.int64)
    return CrowdSnapshot(
        positions=np.asarray(positions, float),
        velocities=np.zeros((len(e), 2)),
        radius=config.crowd.pedestrian_radius,
        emotions=e,
        discomfort=d[e],
        static_centers=np.zeros((0, 2)),
        static_radii=np.zeros(0),
        static_discomfort=config.reward.static_discomfort,
    )


def _scene(classifier, config):
    """A camera frame with the astronaut's face, and pedestrians placed around the robot."""
    frame = camera_frame("astronaut", "coffee", left=200, height=400)
    faces = classifier.classify(frame)
    assert [f.label for f in faces] == [HAPPY]
    system = EmotionClassifier(classifier=classifier)
    cam = system.camera
    bearing = face_bearings(np.array([faces[0].box]), cam.focal_x(), cam.center_x())[0]
    heading = ROBOT[2]

    def at(b, r):
        return ROBOT[:2] + r * np.array([np.cos(heading + b), np.sin(heading + b)])

    positions = [
        at(bearing, 2.5),  # where the face is: gets its emotion
        at(bearing - 0.35, 2.0),  # in view, no face there: neutral
        at(np.pi, 1.5),  # behind the robot: neutral
    ]
    truth = _crowd(positions, [NEGATIVE, NEGATIVE, NEGATIVE], config)
    return frame, system, truth


def _diagram(system, frame, crowd, config, mode="classifier"):
    b = DiagramBuilder()
    cls = b.AddNamedSystem("classifier", system)
    image = b.AddSystem(ConstantValueSource(AbstractValue.Make(image_from_bgr(frame))))
    robot = b.AddSystem(ConstantVectorSource(ROBOT))
    truth = b.AddSystem(ConstantValueSource(AbstractValue.Make(crowd)))
    maps = b.AddNamedSystem("grid_maps", LidarGridMapBuilder(config))
    b.Connect(image.get_output_port(0), cls.GetInputPort("image"))
    b.Connect(robot.get_output_port(0), cls.GetInputPort("robot_state"))
    b.Connect(truth.get_output_port(0), cls.GetInputPort("crowd"))
    b.Connect(robot.get_output_port(0), maps.GetInputPort("robot_state"))
    source = AddEmotionEstimateSource(
        b,
        truth.get_output_port(0),
        [maps.GetInputPort("crowd")],
        config,
        EmotionEstimateParams(mode=mode),
        estimated_emotions=cls.GetOutputPort("pedestrian_emotions"),
    )
    return b.Build(), cls, source, maps


def test_classifier_runs_at_half_a_hertz_and_assigns_faces_by_bearing(classifier):
    config = EmoNavConfig()
    frame, system, truth = _scene(classifier, config)
    diagram, cls, source, maps = _diagram(system, frame, truth, config)
    sim = Simulator(diagram)
    ctx = sim.get_mutable_context()
    cctx = cls.GetMyContextFromRoot(ctx)
    # before the first classification: nobody's face seen, everybody neutral
    assert cls.GetOutputPort("pedestrian_emotions").Eval(cctx).tolist() == [NEUTRAL] * 3
    CountingClassifier.calls = 0
    sim.Initialize()
    sim.AdvanceTo(0.5)
    det = cls.GetOutputPort("detections").Eval(cctx)
    assert isinstance(det, EmotionEstimate) and det.time == 0.0
    assert det.labels.tolist() == [HAPPY] and det.face_pedestrian.tolist() == [0]
    assert det.bearings[0] == pytest.approx(0.0, abs=0.6)
    assert cls.GetOutputPort("pedestrian_emotions").Eval(cctx).tolist() == [HAPPY, NEUTRAL, NEUTRAL]
    assert np.array_equal(cls.GetOutputPort("face_boxes").Eval(cctx), det.boxes)
    assert cls.GetOutputPort("face_probabilities").Eval(cctx).shape == (1, 7)
    assert cls.GetOutputPort("face_labels").Eval(cctx).tolist() == [HAPPY]
    sim.AdvanceTo(4.5)
    assert cls.GetOutputPort("detections").Eval(cctx).time == 4.0
    assert CountingClassifier.calls == 3  # t = 0, 2, 4 s

    # the estimate replaces the ground truth (all negative) in the crowd the LGM sees
    est = source.GetOutputPort("crowd").Eval(source.GetMyContextFromRoot(ctx))
    assert est.emotions.tolist() == [HAPPY, NEUTRAL, NEUTRAL]
    assert np.allclose(est.discomfort, [0.2, 0.35, 0.35])
    lgm = maps.GetOutputPort("lgm_stack").Eval(maps.GetMyContextFromRoot(ctx))[-1]
    robot = LipState(*ROBOT)
    assert np.array_equal(lgm, observation_frame(robot, est, config))
    assert not np.array_equal(lgm, observation_frame(robot, truth, config))


def test_no_image_or_no_face_means_neutral(classifier):
    config = EmoNavConfig()
    frame, _, truth = _scene(classifier, config)
    blank = np.full_like(frame, 90)
    system = EmotionClassifier(classifier=classifier)
    diagram, cls, _, _ = _diagram(system, blank, truth, config)
    sim = Simulator(diagram)
    sim.AdvanceTo(0.1)
    cctx = cls.GetMyContextFromRoot(sim.get_context())
    assert cls.GetOutputPort("detections").Eval(cctx).labels.size == 0
    assert cls.GetOutputPort("pedestrian_emotions").Eval(cctx).tolist() == [NEUTRAL] * 3
    # an unconnected image port: no faces either
    lone = EmotionClassifier(classifier=classifier)
    ctx = lone.CreateDefaultContext()
    lone.GetInputPort("robot_state").FixValue(ctx, ROBOT)
    lone.GetInputPort("crowd").FixValue(ctx, AbstractValue.Make(truth))
    assert lone.estimate(ctx).pedestrian_emotions.tolist() == [NEUTRAL] * 3


def test_a_pedestrian_out_of_range_or_out_of_view_gets_no_face(classifier):
    config = EmoNavConfig()
    frame, _, truth = _scene(classifier, config)
    far = dc.replace(truth, positions=truth.positions.copy())
    far.positions[0] = ROBOT[:2] + 20.0 * (far.positions[0] - ROBOT[:2])
    system = EmotionClassifier(classifier=classifier, max_range=6.0)
    ctx = system.CreateDefaultContext()
    system.GetInputPort("image").FixValue(ctx, AbstractValue.Make(image_from_bgr(frame)))
    system.GetInputPort("robot_state").FixValue(ctx, ROBOT)
    system.GetInputPort("crowd").FixValue(ctx, AbstractValue.Make(far))
    est = system.estimate(ctx)
    assert est.labels.tolist() == [HAPPY] and est.face_pedestrian.tolist() == [-1]
    assert est.pedestrian_emotions.tolist() == [NEUTRAL] * 3
    # turn the camera 90° left: the face now points at nobody
    side = EmotionClassifier(classifier=classifier, camera_yaw=np.pi / 2)
    ctx2 = side.CreateDefaultContext()
    side.GetInputPort("image").FixValue(ctx2, AbstractValue.Make(image_from_bgr(frame)))
    side.GetInputPort("robot_state").FixValue(ctx2, ROBOT)
    side.GetInputPort("crowd").FixValue(ctx2, AbstractValue.Make(truth))
    assert side.estimate(ctx2).pedestrian_emotions.tolist() == [NEUTRAL] * 3


def test_smoothing_averages_a_pedestrians_probabilities(classifier):
    config = EmoNavConfig()
    frame, _, truth = _scene(classifier, config)
    system = EmotionClassifier(classifier=classifier, smoothing=0.5)
    ctx = system.CreateDefaultContext()
    system.GetInputPort("image").FixValue(ctx, AbstractValue.Make(image_from_bgr(frame)))
    system.GetInputPort("robot_state").FixValue(ctx, ROBOT)
    system.GetInputPort("crowd").FixValue(ctx, AbstractValue.Make(truth))
    first = system.estimate(ctx)
    prior = dc.replace(first, pedestrian_probabilities=np.tile(np.eye(7)[6], (3, 1)))
    second = system.estimate(ctx, prior)
    p = second.pedestrian_probabilities[0]
    assert np.allclose(p, 0.5 * np.eye(7)[6] + 0.5 * first.pedestrian_probabilities[0])
    assert np.isnan(second.pedestrian_probabilities[1]).all()


def test_confusion_mode_is_seeded_and_redrawn_every_period():
    config = EmoNavConfig()
    truth = _crowd(np.zeros((40, 2)), np.repeat([0, 1, 2], [14, 13, 13]), config)
    params = EmotionEstimateParams(
        mode="confusion", confusion=[[0.6, 0.3, 0.1], [0.2, 0.6, 0.2], [0.1, 0.3, 0.6]], seed=5
    )

    def estimates(times, p=params):
        src = EmotionEstimateSource(config, p)
        ctx = src.CreateDefaultContext()
        src.GetInputPort("crowd").FixValue(ctx, AbstractValue.Make(truth))
        out = []
        for t in times:
            ctx.SetTime(t)
            out.append(src.GetOutputPort("crowd").Eval(ctx))
        return out

    a = estimates([0.0, 1.9, 2.0, 3.99, 4.0])
    assert np.array_equal(a[0].emotions, a[1].emotions)  # held within a period
    assert np.array_equal(a[2].emotions, a[3].emotions)
    assert not np.array_equal(a[0].emotions, a[2].emotions)  # redrawn at t = 2 s
    assert not np.array_equal(a[0].emotions, truth.emotions)
    d = np.asarray(config.reward.emotion_distances())
    assert all(np.allclose(s.discomfort, d[s.emotions]) for s in a)
    b = estimates([0.0, 1.9, 2.0, 3.99, 4.0])
    assert all(np.array_equal(x.emotions, y.emotions) for x, y in zip(a, b, strict=True))
    c = estimates([0.0], dc.replace(params, seed=6))
    assert not np.array_equal(a[0].emotions, c[0].emotions)
    g = estimates([3.0], EmotionEstimateParams())  # ground truth: passed through unchanged
    assert g[0] is not None and np.array_equal(g[0].emotions, truth.emotions)


def test_confusion_mode_follows_time_varying_true_emotions():
    config = EmoNavConfig()
    config.crowd.time_varying_emotions = True
    scenario = sample_scenario(2, config)
    b = DiagramBuilder()
    robot = b.AddSystem(ConstantVectorSource(np.array([-4.0, 0.0, 0.0, 0.0])))
    crowd = b.AddNamedSystem("crowd", CrowdSystem(scenario, config))
    b.Connect(robot.get_output_port(0), crowd.GetInputPort("robot_state"))
    identity = EmotionEstimateParams(mode="confusion", confusion=np.eye(3).tolist(), period=5.0)
    src = AddEmotionEstimateSource(b, crowd.GetOutputPort("crowd"), [], config, identity)
    sim = Simulator(b.Build())
    seen = set()
    for t in np.arange(0.1, 12.0, 0.5):
        sim.AdvanceTo(t)
        ctx = sim.get_context()
        truth = crowd.GetOutputPort("crowd").Eval(crowd.GetMyContextFromRoot(ctx))
        est = src.GetOutputPort("crowd").Eval(src.GetMyContextFromRoot(ctx))
        assert np.array_equal(est.emotions, truth.emotions)  # at once, within a draw period
        seen.add(tuple(truth.emotions))
    assert len(seen) > 1  # the true emotions did change


def test_classifier_mode_needs_its_input():
    config = EmoNavConfig()
    src = EmotionEstimateSource(config, EmotionEstimateParams(mode="classifier"))
    ctx = src.CreateDefaultContext()
    src.GetInputPort("crowd").FixValue(
        ctx, AbstractValue.Make(_crowd(np.zeros((1, 2)), [1], config))
    )
    with pytest.raises(RuntimeError, match="estimated_emotions"):
        src.GetOutputPort("crowd").Eval(ctx)
    src.GetInputPort("estimated_emotions").FixValue(ctx, AbstractValue.Make(np.array([0, 1])))
    with pytest.raises(ValueError, match="2 estimated emotions for 1 pedestrians"):
        src.GetOutputPort("crowd").Eval(ctx)
    b = DiagramBuilder()
    truth = b.AddSystem(
        ConstantValueSource(AbstractValue.Make(_crowd(np.zeros((1, 2)), [1], config)))
    )
    with pytest.raises(ValueError, match="needs the estimated_emotions"):
        AddEmotionEstimateSource(
            b, truth.get_output_port(0), [], config, EmotionEstimateParams(mode="classifier")
        )


def test_noisy_emotions_in_the_closed_navigation_loop():
    """The navigation diagram with the estimate between the crowd and the grid maps/planner."""
    config = EmoNavConfig()
    scenario = sample_scenario(4, config)
    params = EmotionEstimateParams(
        mode="confusion", confusion=[[0.2, 0.4, 0.4], [0.4, 0.2, 0.4], [0.4, 0.4, 0.2]], seed=1
    )
    b = DiagramBuilder()
    robot = b.AddNamedSystem("robot", LipRobotPlant(scenario, config))
    crowd = b.AddNamedSystem("crowd", CrowdSystem(scenario, config))
    maps = b.AddNamedSystem("grid_maps", LidarGridMapBuilder(config))
    plan = b.AddNamedSystem(
        "planner", NavigationPlanner(DwaPlanner(config), scenario.robot_goal, config)
    )
    monitor = b.AddNamedSystem("monitor", EpisodeMonitor(scenario, config))
    state = robot.GetOutputPort("robot_state")
    for sys in (crowd, maps, plan, monitor):
        b.Connect(state, sys.GetInputPort("robot_state"))
    source = AddEmotionEstimateSource(
        b,
        crowd.GetOutputPort("crowd"),
        [maps.GetInputPort("crowd"), plan.GetInputPort("crowd")],
        config,
        params,
    )
    b.Connect(crowd.GetOutputPort("crowd"), monitor.GetInputPort("crowd"))  # ground truth
    b.Connect(maps.GetOutputPort("lgm_stack"), plan.GetInputPort("lgm_stack"))
    b.Connect(plan.GetOutputPort("command"), robot.GetInputPort("command"))
    diagram = b.Build()
    sim = Simulator(diagram)
    ctx = sim.get_mutable_context()
    differs = 0
    for k in range(1, 16):
        sim.AdvanceTo(k * config.robot.step_time)
        truth = crowd.GetOutputPort("crowd").Eval(crowd.GetMyContextFromRoot(ctx))
        seen = plan.planner_input(plan.GetMyContextFromRoot(ctx)).crowd
        assert np.array_equal(seen.positions, truth.positions)
        differs += not np.array_equal(seen.emotions, truth.emotions)
    assert differs > 0  # the planner and grid maps saw misclassified emotions
    assert source.params.mode == "confusion"
