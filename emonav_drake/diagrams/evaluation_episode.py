"""One evaluation episode on either robot: what `emonav eval` and `emonav benchmark` run.

`run_evaluation_episode` simulates a scenario with the LIP plant (`diagrams/navigation.py`)
or the full-order Digit (`diagrams/navigation_digit.py`) at the evaluation goal radius
(`episode.eval_goal_radius`, 0.2 m) and returns the episode's record.
"""

from __future__ import annotations

from emonav_drake.core.metrics import EpisodeRecord
from emonav_drake.core.scenario import Scenario
from emonav_drake.params import EmoNavConfig
from emonav_drake.perception.noisy_emotions import EmotionEstimateParams
from emonav_drake.planners.protocol import Planner


def run_evaluation_episode(
    plant: str,
    scenario: Scenario,
    config: EmoNavConfig,
    planner: Planner,
    grid_kind: str = "lgm",
    emotion_estimate: EmotionEstimateParams | None = None,
) -> EpisodeRecord:
    """The record of one evaluation episode.

    Args:
        plant: "lip" or "digit".
        scenario, config, planner, grid_kind: as `run_episode`.
        emotion_estimate: perceived emotions (None: the ground truth).
    """
    from emonav_drake.diagrams.plants import plant_named

    robot = plant_named(plant, "plant =")
    goal_radius = config.episode.eval_goal_radius
    return robot.run(scenario, config, planner, grid_kind, goal_radius, emotion_estimate)
