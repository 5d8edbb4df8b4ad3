"""The robots a navigation episode can run on, as objects chosen once by name.

* `lip`: the paper's reduced robot, the linear inverted pendulum of Eq. 1 stepping once
  per T (`systems.LipRobotPlant`, `diagrams/navigation.py`).
* `digit`: the full-order Digit in Drake — the ALIP footstep planner, the passivity
  controller and the multibody plant — under the same navigation stack
  (`diagrams/navigation_digit.py`). It can fall; perceived-emotion estimates
  (`--emotion-estimate`) are not wired into its diagram.

Everything that depends on the robot asks its `Plant` (`plant_named("digit")`) instead of
comparing strings: which episode runner, whether falls are an outcome, whether the replay
draws footsteps, whether an emotion estimate can be given.
"""

from __future__ import annotations

import dataclasses as dc
from collections.abc import Callable

from emonav_drake.core.metrics import EpisodeRecord
from emonav_drake.core.scenario import Scenario
from emonav_drake.params import ConfigError, EmoNavConfig
from emonav_drake.perception.noisy_emotions import EmotionEstimateParams
from emonav_drake.planners.protocol import Planner
from emonav_drake.registry import Registry

# run(scenario, config, planner, grid_kind, goal_radius, emotion_estimate) -> record
EpisodeRunner = Callable[
    [Scenario, EmoNavConfig, Planner, str, float, "EmotionEstimateParams | None"],
    EpisodeRecord,
]


@dc.dataclass(frozen=True)
class Plant:
    """One robot of the navigation diagram.

    Attributes:
        name: "lip" or "digit" (`--plant`).
        label: for tables and captions.
        run: simulates one episode and returns its record (`EpisodeRunner`).
        can_fall: "fall" is one of its outcomes (the tables then show a fall rate).
        emotion_estimates: accepts a perceived-emotion model (`--emotion-estimate`).
        footsteps: its replay draws the footsteps.
    """

    name: str
    label: str
    run: EpisodeRunner
    can_fall: bool
    emotion_estimates: bool
    footsteps: bool


def _run_lip(scenario, config, planner, grid_kind, goal_radius, emotion_estimate):
    from emonav_drake.diagrams.navigation import run_episode

    record, _ = run_episode(
        scenario,
        config,
        planner,
        goal_radius=goal_radius,
        grid_kind=grid_kind,
        emotion_estimate=emotion_estimate,
    )
    return record


def _run_digit(scenario, config, planner, grid_kind, goal_radius, emotion_estimate):
    from emonav_drake.diagrams.navigation_digit import run_digit_episode

    if emotion_estimate is not None:
        raise ConfigError("--emotion-estimate is available with --plant lip only")
    return run_digit_episode(
        scenario, config, planner, grid_kind=grid_kind, goal_radius=goal_radius
    )


PLANTS: Registry[Plant] = Registry("plant")
PLANTS.add(
    "lip", Plant("lip", "LIP", _run_lip, can_fall=False, emotion_estimates=True, footsteps=False)
)
PLANTS.add(
    "digit",
    Plant(
        "digit",
        "Digit (full order)",
        _run_digit,
        can_fall=True,
        emotion_estimates=False,
        footsteps=True,
    ),
)


def register_plant(plant: Plant, replace: bool = False) -> Plant:
    """Add a plant (`ValueError` if its name is taken and not `replace`): `emonav eval`,
    `emonav benchmark` and `emonav sim` (its record; the replay, trajectory and step
    outputs are those of the LIP and Digit diagrams) then run it by name."""
    return PLANTS.add(plant.name, plant, replace)


def unregister_plant(name: str) -> None:
    """Remove a plant (tests that register a throw-away one); the built-in ones stay."""
    if name not in ("lip", "digit"):
        PLANTS.remove(name)


def plant_named(name: str, flag: str = "--plant") -> Plant:
    """The plant called `name`; `ConfigError` naming `flag` and the choices otherwise."""
    if name not in PLANTS:
        raise ConfigError(f"{flag} {name!r}: choose {' or '.join(PLANTS)}")
    return PLANTS[name]
