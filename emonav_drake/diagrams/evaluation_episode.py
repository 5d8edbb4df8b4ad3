"""One evaluation episode on either robot: what `emonav eval` and `emonav benchmark` run.

`run_evaluation_episode` simulates a request (`diagrams.episode.EpisodeRequest`: the
scenario, configuration, planner, observation and emotion estimate; its goal radius is the
evaluation one, `episode.eval_goal_radius`, 0.2 m, unless it says otherwise) on the LIP
plant (`diagrams/navigation.py`), the full-order Digit (`diagrams/navigation_digit.py`) or
a registered plant, and returns the episode's record.
"""

from __future__ import annotations

from emonav_drake.diagrams.episode import EpisodeRequest
from emonav_drake.navigation.metrics import EpisodeRecord


def run_evaluation_episode(plant: str, request: EpisodeRequest) -> EpisodeRecord:
    """The record of one evaluation episode: `request` on the plant named `plant`
    ("lip", "digit" or a registered one; `ConfigError` naming `plant =` otherwise)."""
    from emonav_drake.diagrams.plants import plant_named

    record, _ = plant_named(plant, "plant =").simulate(request)
    return record
