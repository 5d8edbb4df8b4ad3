"""Emotions kept per tracked person (`perception/track_emotions.py`).

A face is assigned to a LiDAR track by bearing (and range, when the face's size gives
one), its emotion is fused into the track's running average and remembered until the
decay time; a track never seen is neutral. Real code, hand-made inputs with known answers.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from emonav_drake.params import HAPPY, NEGATIVE, NEUTRAL
from emonav_drake.perception.track_emotions import TrackEmotionMemory, TrackEmotionParams

HAPPY_FACE = np.array([0.8, 0.15, 0.05])
NEGATIVE_FACE = np.array([0.05, 0.25, 0.7])
NEUTRAL_FACE = np.array([0.1, 0.8, 0.1])


def test_a_face_seen_once_keeps_its_tracks_emotion_until_the_decay_time():
    mem = TrackEmotionMemory(TrackEmotionParams(decay_time=10.0))
    ids = np.array([4, 9])
    owner = mem.update(1.0, ids, [0.2, -0.4], [3.0, 4.0], [0.21], [NEGATIVE_FACE])
    assert owner.tolist() == [0]
    for t in (1.0, 5.0, 11.0):
        codes, conf = mem.emotions(t, ids)
        assert codes.tolist() == [NEGATIVE, NEUTRAL]
        assert conf[0] == pytest.approx(0.7) and conf[1] == 0.0
    codes, _ = mem.emotions(11.01, ids)
    assert codes.tolist() == [NEUTRAL, NEUTRAL]  # decayed


def test_two_people_crossing_keep_their_own_emotions():
    """Association by track id, not by order: after the crossing (no face seen) the
    track on the left is still the negative person's."""
    mem = TrackEmotionMemory()
    ids = np.array([3, 7])
    mem.update(0.0, ids, [0.3, -0.3], [3.0, 3.0], [0.3, -0.29], [HAPPY_FACE, NEGATIVE_FACE])
    # 2 s later they have crossed: track 3 is now on the right, track 7 on the left; both
    # turned away (no face); the tracker lists them in another order
    mem.update(2.0, ids[::-1], [0.3, -0.3], [3.0, 3.0], [], np.zeros((0, 3)))
    codes, _ = mem.emotions(2.0, np.array([7, 3]))
    assert codes.tolist() == [NEGATIVE, HAPPY]


def test_a_face_outside_every_tracks_gate_is_not_assigned():
    mem = TrackEmotionMemory()
    ids = np.array([1, 2])
    # track 1 at 2 m: angular radius atan(0.3/2) = 8.5° + 3° tolerance; the face 15° off
    owner = mem.update(0.0, ids, [0.0, np.nan], [2.0, 3.0], [math.radians(15)], [HAPPY_FACE])
    assert owner.tolist() == [-1]
    assert mem.memory(1) is None and mem.memory(2) is None
    assert mem.emotions(0.0, ids)[0].tolist() == [NEUTRAL, NEUTRAL]
    # a track the camera cannot see (NaN bearing) never takes a face
    owner = mem.update(1.0, ids, [np.nan, np.nan], [2.0, 3.0], [0.0], [HAPPY_FACE])
    assert owner.tolist() == [-1]


def test_the_range_gate_picks_the_track_at_the_faces_distance():
    mem = TrackEmotionMemory(TrackEmotionParams(range_tolerance=0.35))
    ids = np.array([10, 11])
    # same bearing; the face's size says ≈ 4.8 m: the 5 m track, not the 2 m one whose
    # bearing is closer
    owner = mem.update(
        0.0, ids, [0.01, 0.03], [2.0, 5.0], [0.0], [NEGATIVE_FACE], face_distances=[4.8]
    )
    assert owner.tolist() == [1]
    # without a range (NaN) the bearing decides
    owner = mem.update(1.0, ids, [0.01, 0.03], [2.0, 5.0], [0.0], [HAPPY_FACE], [np.nan])
    assert owner.tolist() == [0]


def test_fusion_is_a_running_average_over_the_window_and_deterministic():
    params = TrackEmotionParams(window=3)
    mem = TrackEmotionMemory(params)
    ids = np.array([5])
    faces = [HAPPY_FACE, NEGATIVE_FACE, NEGATIVE_FACE, NEGATIVE_FACE, NEUTRAL_FACE]
    for k, face in enumerate(faces):
        mem.update(2.0 * k, ids, [0.0], [3.0], [0.0], [face])
    # mean of the first 3, then each new face weighs 1/3
    expected = (HAPPY_FACE + 2 * NEGATIVE_FACE) / 3
    expected = expected + (NEGATIVE_FACE - expected) / 3
    expected = expected + (NEUTRAL_FACE - expected) / 3
    m = mem.memory(5)
    assert m.sightings == 5 and m.last_seen == 8.0
    assert np.allclose(m.probabilities, expected, atol=1e-15)
    assert mem.emotions(8.0, ids)[0].tolist() == [int(np.argmax(expected))]
    # the same calls again, and a memory restored half-way, give the same bits
    again, resumed = TrackEmotionMemory(params), TrackEmotionMemory(params)
    for k, face in enumerate(faces):
        again.update(2.0 * k, ids, [0.0], [3.0], [0.0], [face])
        if k == 2:
            resumed.load_state_dict(again.state_dict())
        elif k > 2:
            resumed.update(2.0 * k, ids, [0.0], [3.0], [0.0], [face])
    assert again.state_dict() == mem.state_dict() == resumed.state_dict()


def test_a_small_faces_reading_weighs_little_and_a_tiny_ones_nothing():
    """A negative face read up close (60 px) is kept when the same person, farther away,
    is read neutral on small faces: the 22-px readings add nothing (not even a sighting),
    the 40-px one half a reading."""
    params = TrackEmotionParams(window=5)
    assert params.reading_weight(np.array([20.0, 32.0, 40.0, 48.0, 90.0, np.nan])).tolist() == [
        0.0,
        0.0,
        0.5,
        1.0,
        1.0,
        1.0,
    ]
    mem = TrackEmotionMemory(params)
    ids = np.array([3])
    mem.update(0.0, ids, [0.0], [1.5], [0.0], [NEGATIVE_FACE], face_heights=[60.0])
    for k in range(1, 4):
        mem.update(2.0 * k, ids, [0.0], [5.0], [0.0], [NEUTRAL_FACE], face_heights=[22.0])
    m = mem.memory(3)
    assert m.sightings == 1 and m.last_seen == 0.0
    assert np.array_equal(m.probabilities, NEGATIVE_FACE)
    mem.update(8.0, ids, [0.0], [3.0], [0.0], [NEUTRAL_FACE], face_heights=[40.0])
    m = mem.memory(3)
    expected = NEGATIVE_FACE + (0.5 / 1.5) * (NEUTRAL_FACE - NEGATIVE_FACE)
    assert m.sightings == 2 and m.last_seen == 8.0 and m.weight == 1.5
    assert np.allclose(m.probabilities, expected, atol=1e-15)
    assert mem.emotions(8.0, ids)[0].tolist() == [NEGATIVE]
    # unweighted, the same readings would have made the person neutral
    plain = TrackEmotionMemory(params)
    plain.update(0.0, ids, [0.0], [1.5], [0.0], [NEGATIVE_FACE])
    for k in range(1, 5):
        plain.update(2.0 * k, ids, [0.0], [5.0], [0.0], [NEUTRAL_FACE])
    assert plain.emotions(8.0, ids)[0].tolist() == [NEUTRAL]


def test_a_deleted_track_is_forgotten_and_a_new_track_is_neutral():
    mem = TrackEmotionMemory()
    mem.update(0.0, np.array([1]), [0.0], [2.0], [0.0], [NEGATIVE_FACE])
    assert mem.memory(1) is not None
    mem.update(2.0, np.array([2]), [0.0], [2.0], [], np.zeros((0, 3)))  # 1 deleted, 2 born
    assert mem.memory(1) is None
    assert mem.emotions(2.0, np.array([2]))[0].tolist() == [NEUTRAL]


@pytest.mark.parametrize(
    "field,value",
    [
        ("decay_time", 0.0),
        ("window", 0),
        ("range_tolerance", -0.1),
        ("bearing_tolerance", math.nan),
        ("zero_weight_face_px", -1.0),
        ("full_weight_face_px", 10.0),
    ],
)
def test_bad_parameters_name_the_field(field, value):
    with pytest.raises(ValueError, match=f"TrackEmotionParams.{field}"):
        TrackEmotionParams(**{field: value}).validate()


def test_mismatched_inputs_are_refused():
    mem = TrackEmotionMemory()
    with pytest.raises(ValueError, match="track ids"):
        mem.update(0.0, np.array([1, 2]), [0.0], [2.0], [], np.zeros((0, 3)))
    with pytest.raises(ValueError, match="face probabilities"):
        mem.update(0.0, np.array([1]), [0.0], [2.0], [0.0, 0.1], [HAPPY_FACE])


def test_the_fusion_system_gates_a_face_by_the_range_its_box_gives():
    """`TrackEmotionFusion`: two people on one bearing, 1.2 m and 2.3 m away; a face box
    40 px tall says ≈ 2.3 m (focal 514 px × 0.18 m / 40 px): the far track takes it. Without the
    focal length the bearing decides (the near one is dead ahead)."""
    from pydrake.systems.analysis import Simulator

    from emonav_drake.systems.crowd_tracker_system import TrackedPeople
    from emonav_drake.systems.emotion_classifier import EmotionEstimate
    from emonav_drake.systems.track_emotion_fusion import FACE_BOX_HEIGHT, TrackEmotionFusion

    probs7 = np.zeros((1, 7))
    probs7[0, 0] = 1.0  # angry: negative
    estimate = EmotionEstimate(
        time=0.5,
        boxes=np.array([[600, 300, 40, 40]]),
        probabilities=probs7,
        labels=np.array([2]),
        bearings=np.array([0.0]),
        face_pedestrian=np.array([-1]),
        pedestrian_emotions=np.zeros(0, np.int64),
        pedestrian_probabilities=np.zeros((0, 7)),
    )
    tracks = TrackedPeople(
        np.array([7, 8]), np.array([[1.2, 0.0], [2.3, 0.05]]), np.zeros(2, bool), 0.5
    )
    assert 514 * FACE_BOX_HEIGHT / 40 == pytest.approx(2.3, abs=0.02)
    for focal, owner in ((514.0, 8), (None, 7)):
        fusion = TrackEmotionFusion(0.1, math.radians(51), 6.0, focal_y=focal)
        ctx = fusion.CreateDefaultContext()
        fusion.GetInputPort("detections").FixValue(ctx, estimate)
        fusion.GetInputPort("robot_state").FixValue(ctx, np.zeros(4))
        fusion.GetInputPort("tracks").FixValue(ctx, tracks)
        sim = Simulator(fusion, ctx)
        sim.AdvanceTo(0.15)  # the periodic updates at 0 and 0.1 s fold the estimate in
        codes = fusion.GetOutputPort("track_emotions").Eval(sim.get_context()).codes
        assert codes == {owner: NEGATIVE}, (focal, codes)
