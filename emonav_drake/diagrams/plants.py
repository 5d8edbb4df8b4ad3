"""The robots a navigation episode can run on, as objects chosen once by name.

* `lip`: the paper's reduced robot, the linear inverted pendulum of Eq. 1 stepping once
  per T (`systems.LipRobotPlant`, `diagrams/navigation.py`).
* `digit`: the full-order Digit in Drake — the ALIP footstep planner, the passivity
  controller and the multibody plant — under the same navigation stack
  (`diagrams/navigation_digit.py`). It can fall.

Everything that depends on the robot asks its `Plant` (`plant_named("digit")`) instead of
comparing strings: which episode runner, whether falls are an outcome, whether the replay
draws footsteps, whether an emotion estimate can be given, whether an episode can give a
per-step trace (the tracking comparison of `emonav diagnose`) or the LIP step log (the
replays of `TrialRunner.replay`), and how `emonav sim` runs it with its viewers and
per-step outputs (`simulate`).
"""

from __future__ import annotations

import dataclasses as dc
from collections.abc import Callable
from typing import Any

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
# run(scenario, config, planner, grid_kind, goal_radius, trace) -> record, appending the
# robot state and held command at every planner instant to `trace`
TracedRunner = Callable[[Scenario, EmoNavConfig, Planner, str, float, list], EpisodeRecord]
# run(scenario, config, planner, grid_kind, goal_radius, emotion_estimate)
#   -> (record, the LIP step log `diagrams.navigation.StepLog`)
LoggedRunner = Callable[
    [Scenario, EmoNavConfig, Planner, str, float, "EmotionEstimateParams | None"],
    tuple[EpisodeRecord, Any],
]

# the --plant a command runs when none is given
DEFAULT_PLANT = "lip"


@dc.dataclass
class SimRequest:
    """One `emonav sim` episode: what it runs and with which viewer and outputs."""

    scenario: Scenario
    config: EmoNavConfig
    planner: Planner
    grid_kind: str
    emotion_estimate: EmotionEstimateParams | None
    meshcat: Any = None  # the viewer of --meshcat / --record, or None
    record_html: Any = None  # --record: where the HTML replay goes
    show_rays: bool = False  # --rays
    realtime_rate: float = 0.0  # 1.0 with --meshcat
    rates: Any = None  # --rates: a `diagrams.rates.RateMeasurement`
    per_step: bool = False  # --json / --steps-out: keep the per-step log or trace
    progress: bool = False  # the progress bar on stderr
    camera_frames: list | None = None  # --camera-gif: the classified camera images


@dc.dataclass
class SimResult:
    """What a plant's `simulate` gives back: the record and, when asked for, the LIP step
    log (`step_log`) or the per-step trace (`trace`) — the --json trajectory and
    --steps-out are drawn from whichever is there."""

    record: EpisodeRecord
    step_log: Any = None
    trace: list[dict] | None = None


Simulator = Callable[[SimRequest], SimResult]


@dc.dataclass(frozen=True)
class Plant:
    """One robot of the navigation diagram.

    Attributes:
        name: "lip" or "digit" (`--plant`).
        label: for tables and captions.
        run: simulates one episode and returns its record (`EpisodeRunner`).
        can_fall: "fall" is one of its outcomes (the tables then show a fall rate).
        footsteps: its replay draws the footsteps.
        caption: its name in the Meshcat caption (`label` when None).
        rays: `emonav sim --rays` can draw its LiDAR rays.
        run_traced: runs one episode filling a per-step trace (`TracedRunner`), or None.
        run_logged: runs one episode giving the LIP step log (`LoggedRunner`), or None.
        response: the step-response model its traces are compared with
            (`planners.model_aware.load_response`), or None.
        simulate: runs `emonav sim`'s episode with the viewers and per-step outputs
            (`Simulator`), or None (then `sim` gives its record only).
    """

    name: str
    label: str
    run: EpisodeRunner
    can_fall: bool
    footsteps: bool
    caption: str | None = None
    rays: bool = False
    run_traced: TracedRunner | None = None
    run_logged: LoggedRunner | None = None
    response: str | None = None
    simulate: Simulator | None = None

    @property
    def traces(self) -> bool:
        """An episode can give its per-step trace (the tracking comparison)."""
        return self.run_traced is not None

    @property
    def step_log(self) -> bool:
        """An episode can give the LIP step log (replays, trajectories)."""
        return self.run_logged is not None

    @property
    def caption_name(self) -> str:
        """Its name in the Meshcat caption."""
        return self.label if self.caption is None else self.caption


def _run_lip(scenario, config, planner, grid_kind, goal_radius, emotion_estimate):
    record, _ = _run_lip_logged(scenario, config, planner, grid_kind, goal_radius, emotion_estimate)
    return record


def _run_digit(scenario, config, planner, grid_kind, goal_radius, emotion_estimate):
    from emonav_drake.diagrams.navigation_digit import run_digit_episode

    return run_digit_episode(
        scenario,
        config,
        planner,
        grid_kind=grid_kind,
        goal_radius=goal_radius,
        emotion_estimate=emotion_estimate,
    )


def _run_lip_logged(scenario, config, planner, grid_kind, goal_radius, emotion_estimate):
    from emonav_drake.diagrams.navigation import run_episode

    return run_episode(
        scenario,
        config,
        planner,
        goal_radius=goal_radius,
        grid_kind=grid_kind,
        emotion_estimate=emotion_estimate,
    )


def _run_digit_traced(scenario, config, planner, grid_kind, goal_radius, trace):
    from emonav_drake.diagrams.navigation_digit import run_digit_episode

    return run_digit_episode(
        scenario, config, planner, grid_kind=grid_kind, goal_radius=goal_radius, trace=trace
    )


def _simulate_lip(req: SimRequest) -> SimResult:
    from emonav_drake.diagrams.navigation import run_episode

    cfg = req.config
    record, step_log = run_episode(
        req.scenario,
        cfg,
        req.planner,
        meshcat=req.meshcat,
        record_html=req.record_html,
        show_rays=req.show_rays,
        goal_radius=cfg.episode.eval_goal_radius,
        realtime_rate=req.realtime_rate,
        grid_kind=req.grid_kind,
        emotion_estimate=req.emotion_estimate,
        rates=req.rates,
        progress=req.progress,
        camera_frames=req.camera_frames,
    )
    return SimResult(record, step_log=step_log)


def _simulate_digit(req: SimRequest) -> SimResult:
    from emonav_drake.diagrams.navigation_digit import run_digit_episode

    cfg = req.config
    trace: list[dict] | None = [] if req.per_step else None
    record = run_digit_episode(
        req.scenario,
        cfg,
        req.planner,
        meshcat=req.meshcat,
        grid_kind=req.grid_kind,
        goal_radius=cfg.episode.eval_goal_radius,
        realtime_rate=req.realtime_rate,
        record_html=req.record_html,
        rates=req.rates,
        trace=trace,
        progress=req.progress,
        emotion_estimate=req.emotion_estimate,
        camera_frames=req.camera_frames,
    )
    return SimResult(record, trace=trace)


PLANTS: Registry[Plant] = Registry("plant")
PLANTS.add(
    "lip",
    Plant(
        "lip",
        "LIP",
        _run_lip,
        can_fall=False,
        footsteps=False,
        rays=True,
        run_logged=_run_lip_logged,
        simulate=_simulate_lip,
    ),
)
PLANTS.add(
    "digit",
    Plant(
        "digit",
        "Digit (full order)",
        _run_digit,
        can_fall=True,
        footsteps=True,
        caption="Digit",
        run_traced=_run_digit_traced,
        response="digit",
        simulate=_simulate_digit,
    ),
)

BUILT_IN = tuple(PLANTS)


def register_plant(plant: Plant, replace: bool = False) -> Plant:
    """Add a plant (`ValueError` if its name is taken and not `replace`): `emonav eval`,
    `emonav benchmark` and `emonav sim` then run it by name — `sim` its record only, or
    with the viewers and per-step outputs if it has `simulate`; `emonav diagnose` compares
    its tracking if it has `run_traced`, `TrialRunner.replay` needs `run_logged`."""
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
