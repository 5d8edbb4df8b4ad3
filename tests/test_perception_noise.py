"""Seeded misclassification through a 3 × 3 confusion matrix (numpy only)."""

import numpy as np
import pytest

from emonav_drake.crowd.crowd import Crowd
from emonav_drake.params import ConfigError, EmoNavConfig
from emonav_drake.perception.noisy_emotions import (
    ConfusionEmotionModel,
    EmotionEstimateParams,
    confusion_from_accuracy,
    empirical_confusion,
    replace_emotions,
    validate_confusion,
)
from emonav_drake.scenarios.scenario import sample_scenario

C = np.array([[0.7, 0.2, 0.1], [0.15, 0.6, 0.25], [0.05, 0.0, 0.95]])


def _draws(model, truth, n):
    return np.array([model.estimate(truth, k) for k in range(n)])


def test_draws_are_seeded_and_reproducible():
    truth = np.array([0, 1, 2, 2, 1, 0, 0, 2])
    a, b = ConfusionEmotionModel(C, seed=3), ConfusionEmotionModel(C, seed=3)
    assert np.array_equal(_draws(a, truth, 50), _draws(b, truth, 50))
    other = ConfusionEmotionModel(C, seed=4)
    assert not np.array_equal(_draws(a, truth, 50), _draws(other, truth, 50))
    assert len({tuple(a.estimate(truth, k)) for k in range(10)}) > 1  # draws vary with k
    # a pure function of (seed, draw, truth): order of calls does not matter
    assert np.array_equal(a.estimate(truth, 7), _draws(b, truth, 8)[7])


def test_empirical_confusion_converges_to_the_configured_matrix():
    model = ConfusionEmotionModel(C, seed=11)
    truth = np.repeat([0, 1, 2], 10)  # 10 pedestrians of each emotion
    errors = []
    for n in (100, 1_000, 10_000):
        est = _draws(model, truth, n)
        emp = empirical_confusion(np.tile(truth, n), est.ravel())
        errors.append(np.abs(emp - C).max())
        samples_per_row = 10 * n
        assert errors[-1] < 5 * np.sqrt(0.25 / samples_per_row)  # 5 σ of a proportion
    assert errors[2] < errors[0] and errors[2] < 0.005
    # an impossible confusion never happens
    est = _draws(model, np.full(20, 2), 500)
    assert not np.any(est == 1)


def test_identity_gives_the_truth_and_accuracy_helper():
    truth = np.array([2, 0, 1, 1])
    assert np.array_equal(ConfusionEmotionModel(np.eye(3), 5).estimate(truth, 9), truth)
    m = confusion_from_accuracy(0.8)
    assert np.allclose(np.diag(m), 0.8) and np.allclose(m.sum(axis=1), 1.0)
    assert np.allclose(m[0, 1:], 0.1)
    assert ConfusionEmotionModel(C).estimate(np.zeros(0, int), 0).shape == (0,)


@pytest.mark.parametrize(
    "bad, match",
    [
        (np.eye(2), "shape"),
        ([[0.5, 0.6, -0.1], [0, 1, 0], [0, 0, 1]], ">= 0"),
        ([[0.5, 0.4, 0.0], [0, 1, 0], [0, 0, 1]], "sum to 1"),
        ("abc", "numeric"),
    ],
)
def test_invalid_matrices_are_refused(bad, match):
    with pytest.raises(ConfigError, match=match):
        validate_confusion(bad)


def test_params_validate_and_bad_codes():
    EmotionEstimateParams(mode="confusion", confusion=C.tolist()).validate()
    with pytest.raises(ConfigError, match="mode"):
        EmotionEstimateParams(mode="oracle").validate()
    with pytest.raises(ConfigError, match="period"):
        EmotionEstimateParams(period=0.0).validate()
    with pytest.raises(ValueError, match="codes"):
        ConfusionEmotionModel(C).estimate(np.array([0, 3]), 0)


def test_params_load_from_yaml(tmp_path):
    from pydrake.common.yaml import yaml_load_typed

    f = tmp_path / "e.yaml"
    f.write_text(
        "mode: confusion\nseed: 7\nperiod: 1.0\n"
        "confusion: [[0.8, 0.1, 0.1], [0.1, 0.8, 0.1], [0.0, 0.2, 0.8]]\n"
    )
    p = yaml_load_typed(schema=EmotionEstimateParams, filename=str(f)).validate()
    assert p.mode == "confusion" and p.seed == 7 and p.confusion[2] == [0.0, 0.2, 0.8]


def test_replace_emotions_updates_the_discomfort_zones():
    cfg = EmoNavConfig()
    crowd = Crowd(sample_scenario(3, cfg), cfg)
    snap = crowd.snapshot(crowd.initial_state())
    p = len(snap.positions)
    est = np.zeros(p, np.int64)  # everybody happy
    new = replace_emotions(snap, est, np.asarray(cfg.reward.emotion_distances()))
    assert np.array_equal(new.emotions, est) and np.allclose(new.discomfort, 0.2)
    assert new.positions is snap.positions and snap.discomfort is not new.discomfort
    with pytest.raises(ValueError, match="pedestrians"):
        replace_emotions(snap, np.zeros(p + 1, np.int64), np.ones(3))
