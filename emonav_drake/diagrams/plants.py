"""The robots a navigation episode can run on, as objects chosen once by name.

* `lip`: the paper's reduced robot, the linear inverted pendulum of Eq. 1 stepping once
  per T (`systems.LipRobotPlant`, `diagrams/navigation.py`).
* `digit`: the full-order Digit in Drake — the ALIP footstep planner, the passivity
  controller and the multibody plant — under the same navigation stack
  (`diagrams/navigation_digit.py`). It can fall.

Everything that depends on the robot asks its `Plant` (`plant_named("digit")`) instead of
comparing strings: how an episode runs (`simulate`, one `EpisodeRequest` → the record
and, when asked, the `EpisodeTrace`), whether falls are an outcome, whether the replay
draws footsteps and the LiDAR rays, whether `emonav sim`'s viewers apply (`viewers`) and
which step-response model its traces are compared with (`response`: `emonav diagnose`).
"""

from __future__ import annotations

import dataclasses as dc
import importlib
from collections.abc import Callable

from emonav_drake.diagrams.episode import EpisodeRequest
from emonav_drake.navigation.episode_trace import EpisodeTrace
from emonav_drake.navigation.metrics import EpisodeRecord
from emonav_drake.params import ConfigError
from emonav_drake.registry import Registry

# simulate(request) -> (record, the trace if request.trace and the plant keeps one, else None)
EpisodeSimulator = Callable[[EpisodeRequest], tuple[EpisodeRecord, EpisodeTrace | None]]

# the --plant a command runs when none is given
DEFAULT_PLANT = "lip"


@dc.dataclass(frozen=True)
class Plant:
    """One robot of the navigation diagram.

    Attributes:
        name: "lip" or "digit" (`--plant`).
        label: for tables and captions.
        simulate: runs one episode (`EpisodeSimulator`): `EpisodeRequest` → (its
            `EpisodeRecord`, its `EpisodeTrace` when `request.trace`, else None). A plant
            that cannot trace returns None there (then `emonav sim --json` has no
            trajectory, and `emonav diagnose` no tracking comparison).
        can_fall: "fall" is one of its outcomes (the tables then show a fall rate).
        footsteps: its replay draws the footsteps.
        caption: its name in the Meshcat caption (`label` when None).
        rays: `emonav sim --rays` can draw its LiDAR rays.
        viewers: its `simulate` honours the request's viewer options (meshcat,
            record_html, rates, camera_frames) and `trace`: `emonav sim --meshcat`,
            `--record`, `--rates`, `--camera-gif` and `--steps-out` need it (without it,
            `sim` gives the record only).
        response: the step-response model its traces are compared with
            (`planners.model_aware.load_response`; `emonav diagnose`), or None.
    """

    name: str
    label: str
    simulate: EpisodeSimulator
    can_fall: bool
    footsteps: bool
    caption: str | None = None
    rays: bool = False
    viewers: bool = False
    response: str | None = None

    @property
    def caption_name(self) -> str:
        """Its name in the Meshcat caption."""
        return self.label if self.caption is None else self.caption


def _runner(module: str) -> EpisodeSimulator:
    """`simulate` of a built-in plant: the request run by the one episode loop
    (`diagrams.episode.run_navigation_episode`) on the diagram `module.build_episode`
    builds (`diagrams.navigation`, `diagrams.navigation_digit`), looked up when called (the
    diagrams load on first use)."""

    def simulate(request: EpisodeRequest) -> tuple[EpisodeRecord, EpisodeTrace | None]:
        from emonav_drake.diagrams.episode import run_navigation_episode

        build = importlib.import_module(module).build_episode
        return run_navigation_episode(request, build)

    return simulate


PLANTS: Registry[Plant] = Registry("plant")
PLANTS.add(
    "lip",
    Plant(
        "lip",
        "LIP",
        _runner("emonav_drake.diagrams.navigation"),
        can_fall=False,
        footsteps=False,
        rays=True,
        viewers=True,
    ),
)
PLANTS.add(
    "digit",
    Plant(
        "digit",
        "Digit (full order)",
        _runner("emonav_drake.diagrams.navigation_digit"),
        can_fall=True,
        footsteps=True,
        caption="Digit",
        viewers=True,
        response="digit",
    ),
)

BUILT_IN = tuple(PLANTS)


def register_plant(plant: Plant, replace: bool = False) -> Plant:
    """Add a plant (`ValueError` if its name is taken and not `replace`): `emonav eval`,
    `emonav benchmark`, `emonav sim` and `TrialRunner.replay` then run it by name through
    its `simulate` — `sim` its record only, or with the viewers and per-step outputs if it
    has `viewers`; `emonav diagnose` compares its traces' tracking if it has a `response`
    model."""
    return PLANTS.add(plant.name, plant, replace)


def unregister_plant(name: str) -> None:
    """Remove a plant (tests that register a throw-away one); the built-in ones stay."""
    if name not in BUILT_IN:
        PLANTS.remove(name)


def plant_named(name: str, flag: str = "--plant") -> Plant:
    """The plant called `name`; `ConfigError` naming `flag` and the choices otherwise."""
    if name not in PLANTS:
        raise ConfigError(f"{flag} {name!r}: choose {' or '.join(PLANTS)}")
    return PLANTS[name]
