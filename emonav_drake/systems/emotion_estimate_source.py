"""`EmotionEstimateSource`: the crowd as the robot perceives it — estimated emotions.

It sits between the crowd and the systems that should see *estimated* emotions (the
LGM builder, whose discomfort zones depend on them, and the planner), while the
episode monitor keeps the ground truth for the metrics:

    CrowdSystem ── crowd ──► EmotionEstimateSource ── crowd ──► LidarGridMapBuilder, planner
        │                          ▲ estimated_emotions (classifier mode)
        └── crowd (ground truth) ──┼──► EpisodeMonitor
                           EmotionClassifier.pedestrian_emotions

Input ports:
    crowd (abstract `CrowdSnapshot`): the simulated crowd with ground-truth emotions.
    estimated_emotions (abstract int64 array (P,)): per-pedestrian codes, read only in
        "classifier" mode (e.g. `EmotionClassifier`'s `pedestrian_emotions`).
Output port:
    crowd (abstract `CrowdSnapshot`): the same crowd with `emotions` replaced by the
        estimate and `discomfort` by the matching distances (happy 0.2, neutral 0.35,
        negative 0.5 m by default).

Modes (`EmotionEstimateParams.mode`):
    ground_truth: pass the crowd through unchanged.
    confusion: every pedestrian's estimate is drawn from the row of its true emotion
        in the configured 3 × 3 confusion matrix, redrawn every `period` (draw
        k = ⌊t / period⌋, seeded, see `perception/noisy_emotions.py`). The output is a
        pure function of time and input, so the system has no state.
    classifier, camera: the `estimated_emotions` input (held by the classifier at 0.5 Hz;
        "camera" when that classifier reads the diagram's own head camera,
        `diagrams/camera_perception.py`).
"""

from __future__ import annotations

import math

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import Context, DiagramBuilder, InputPort, LeafSystem, OutputPort

from emonav_drake.params import EmoNavConfig
from emonav_drake.perception.noisy_emotions import (
    CAMERA_MODES,
    ConfusionEmotionModel,
    EmotionEstimateParams,
    replace_emotions,
)


class EmotionEstimateSource(LeafSystem):
    """Replaces the crowd's ground-truth emotions by estimated ones.

    Args:
        config: for the discomfort distance of each emotion.
        params: mode, confusion matrix, seed and draw period.
    """

    def __init__(self, config: EmoNavConfig, params: EmotionEstimateParams | None = None) -> None:
        super().__init__()
        self.params = (params or EmotionEstimateParams()).validate()
        self._distances = np.asarray(config.reward.emotion_distances(), dtype=float)
        self._model = ConfusionEmotionModel(self.params.confusion, self.params.seed)
        self._crowd_in = self.DeclareAbstractInputPort("crowd", AbstractValue.Make(object()))
        self._estimates_in = self.DeclareAbstractInputPort(
            "estimated_emotions", AbstractValue.Make(np.zeros(0, np.int64))
        )
        self.DeclareAbstractOutputPort(
            "crowd",
            lambda: AbstractValue.Make(object()),
            self._calc_crowd,
            {self.all_input_ports_ticket(), self.time_ticket()},
        )

    def draw_index(self, time: float) -> int:
        """Confusion draw in force at `time` [s] (a tiny tolerance absorbs round-off)."""
        return max(0, math.floor(time / self.params.period + 1e-9))

    def estimated_emotions(self, context: Context) -> np.ndarray:
        """The (P,) codes this system puts into the crowd in `context`."""
        crowd = self._crowd_in.Eval(context)
        mode = self.params.mode
        if mode == "ground_truth":
            return np.asarray(crowd.emotions, dtype=np.int64)
        if mode == "confusion":
            return self._model.estimate(crowd.emotions, self.draw_index(context.get_time()))
        if not self._estimates_in.HasValue(context):
            raise RuntimeError(
                f"EmotionEstimateSource in {mode!r} mode needs its estimated_emotions "
                "input connected (e.g. EmotionClassifier.pedestrian_emotions)"
            )
        return np.asarray(self._estimates_in.Eval(context), dtype=np.int64)

    def _calc_crowd(self, context: Context, output: AbstractValue) -> None:
        crowd = self._crowd_in.Eval(context)
        if self.params.mode == "ground_truth":
            output.set_value(crowd)
            return
        output.set_value(replace_emotions(crowd, self.estimated_emotions(context), self._distances))


def AddEmotionEstimateSource(
    builder: DiagramBuilder,
    crowd_output: OutputPort,
    consumers: list[InputPort],
    config: EmoNavConfig,
    params: EmotionEstimateParams | None = None,
    estimated_emotions: OutputPort | None = None,
    name: str = "emotion_estimate",
) -> EmotionEstimateSource:
    """Add an `EmotionEstimateSource` fed by `crowd_output` and connect it to `consumers`.

    Connect only the inputs that should see estimated emotions (grid maps, planner);
    leave the episode monitor on the ground truth. `estimated_emotions` (required in
    "classifier" and "camera" modes) is connected to the source's input of that name.
    """
    system = EmotionEstimateSource(config, params)
    if system.params.mode in ("classifier", *CAMERA_MODES) and estimated_emotions is None:
        raise ValueError(f"mode {system.params.mode!r} needs the estimated_emotions output port")
    source = builder.AddNamedSystem(name, system)
    builder.Connect(crowd_output, source.GetInputPort("crowd"))
    if estimated_emotions is not None:
        builder.Connect(estimated_emotions, source.GetInputPort("estimated_emotions"))
    for port in consumers:
        builder.Connect(source.GetOutputPort("crowd"), port)
    return source
