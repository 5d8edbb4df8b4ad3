"""Navigation scenarios: what the paper's environment randomises, as plain data.

A `Scenario` fixes everything random about one episode: pedestrians (start, goal,
emotion, behaviour), static discs, walls and the robot's start and goal. The data and its
validation live in `scenarios/scenario_spec.py`, the paper's sampler in
`scenarios/paper_scenario.py`, the other scenario families in `scenarios/scenario_families.py`;
this module gathers them: `sample_scenario(seed, config)` draws the scenario of `seed` in
the configuration's family (`crowd.family`, "paper" by default), `load_scenario` reads
one from YAML, `dump_scenario` writes it.

World frame: x towards the robot's goal, y left, metres.
"""

from emonav_drake.params import EmoNavConfig
from emonav_drake.scenarios.paper_scenario import (
    PLACEMENT_TRIES,
    add_time_varying_emotion,
    sample_paper_scenario,
)
from emonav_drake.scenarios.scenario_families import sample_family
from emonav_drake.scenarios.scenario_spec import (
    AT_GOAL,
    MAX_OBSTACLES,
    MAX_PEDESTRIANS,
    MAX_SCHEDULE,
    MAX_SEED,
    MAX_WALLS,
    MAX_WAYPOINTS,
    PedestrianSpec,
    Scenario,
    ScenarioSamplingError,
    StaticDiscSpec,
    WallSpec,
    dump_scenario,
    load_scenario,
    point_segment_distance,
)

__all__ = [
    "AT_GOAL",
    "MAX_OBSTACLES",
    "MAX_PEDESTRIANS",
    "MAX_SCHEDULE",
    "MAX_SEED",
    "MAX_WALLS",
    "MAX_WAYPOINTS",
    "PLACEMENT_TRIES",
    "PedestrianSpec",
    "Scenario",
    "ScenarioSamplingError",
    "StaticDiscSpec",
    "WallSpec",
    "add_time_varying_emotion",
    "dump_scenario",
    "load_scenario",
    "point_segment_distance",
    "sample_paper_scenario",
    "sample_scenario",
]


def sample_scenario(seed: int, config: EmoNavConfig | None = None) -> Scenario:
    """The scenario of `seed` in the configuration's family (`crowd.family`).

    The default family, "paper", is `sample_paper_scenario` (the paper's seeds); the others
    are the samplers of `scenarios/scenario_families.py`.
    """
    cfg = config or EmoNavConfig()
    if cfg.crowd.family == "paper":
        return sample_paper_scenario(seed, cfg)
    return sample_family(cfg.crowd.family, seed, cfg)
