"""One navigation episode on either plant: what it is asked, and the loop both plants run.

`EpisodeRequest` is what `Plant.simulate` (`diagrams/plants.py`) is given: the scenario,
configuration, planner and its observation, the goal radius and emotion estimate, the
viewer options of `emonav sim` and whether to keep the per-step `EpisodeTrace`
(`navigation/episode_trace.py`). The LIP (`diagrams/navigation.py`) and Digit
(`diagrams/navigation_digit.py`) build their own diagrams — different physics — and hand
them here as `EpisodeSystems`:

* `run_navigation_episode(request, build)`: a Meshcat for the replay
  (`record_html`) if none is given, the plant's diagram (`build`), the simulator, the
  episode, the HTML replay; returns (record, trace or None). The plants' own
  `run_episode(scenario, config, planner, **options)` and `run_digit_episode(...)` call
  it with `training_request` (their goal radius defaults to the training one).
* `simulate_episode`: the loop on a simulator, one `AdvanceTo` per walking step:

      t_0: log, check ─ AdvanceTo(T) ─ t_1: log, check ─ … ─ done (or fallen)

  At every t_k, before the updates at t_k (what the planner sees): the trace row (when
  kept), the episode monitor's status and, on a plant that can fall, its fall check
  (`EpisodeSystems.fall`); the episode ends when the monitor says so, or with the
  outcome "fall" when the robot has fallen. On such a plant a `RuntimeError` of the
  simulator is a fall too (the contact solver gives up only on a robot in a heap). The
  progress bar follows the simulated time and is closed on any exception, Ctrl-C
  included. Reading the ports changes nothing: the record is the same with or without
  the trace, the bar or the profiler.
"""

from __future__ import annotations

import dataclasses as dc
import math
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

from emonav_drake.navigation.episode_trace import EpisodeTrace, perceived_emotions
from emonav_drake.navigation.metrics import EpisodeRecord
from emonav_drake.navigation.route_following import uses_route
from emonav_drake.params import EmoNavConfig
from emonav_drake.perception.noisy_emotions import EmotionEstimateParams
from emonav_drake.planners.protocol import Planner
from emonav_drake.scenarios.scenario import Scenario

if TYPE_CHECKING:
    from pydrake.geometry import Meshcat
    from pydrake.systems.analysis import Simulator
    from pydrake.systems.framework import Context, Diagram, System

    from emonav_drake.diagrams.rates import RateMeasurement

# the reason the robot has fallen at the context's time, or None (`EpisodeSystems.fall`)
FallCheck = Callable[["Context"], "str | None"]


@dc.dataclass
class EpisodeRequest:
    """One episode to simulate on a plant (`Plant.simulate`).

    Attributes:
        scenario: the episode to play.
        config: the project configuration (step time T, time limit, rewards, ...).
        planner: DWA, MPC or a learned policy (a `Planner`).
        grid_kind: the map observation the planner reads ("lgm", "ogm", "scan", "drlvo";
            a policy's: `planners.configure_for`).
        goal_radius: goal threshold [m]; default (None) `config.episode.eval_goal_radius`.
        emotion_estimate: where the perceived emotions come from (None: the ground truth).
        meshcat: draw into this Meshcat (`--meshcat`, `--record`), or None.
        record_html: write the episode as a self-contained HTML replay here (a record-only
            Meshcat is made when `meshcat` is None).
        show_rays: draw the LiDAR rays (`--rays`; the plants with `Plant.rays`).
        realtime_rate: the simulator's target real-time rate (0: as fast as it goes).
        rates: profile the run; the `RateReport` is left in `rates.report`.
        progress: a progress bar over simulated time on stderr.
        camera_frames: emotion estimate mode "camera": every classified head-camera image
            is appended as (time [s], BGR image) (`write_camera_gif`).
        trace: keep the `EpisodeTrace` (returned beside the record; None otherwise).
        scene: the scene in words for the replay's caption ("scenario closed_door",
            "family office, seed 3"); None: "seed N".
    """

    scenario: Scenario
    config: EmoNavConfig
    planner: Planner
    grid_kind: str = "lgm"
    goal_radius: float | None = None
    emotion_estimate: EmotionEstimateParams | None = None
    meshcat: Meshcat | None = None
    record_html: str | Path | None = None
    show_rays: bool = False
    realtime_rate: float = 0.0
    rates: RateMeasurement | None = None
    progress: bool = False
    camera_frames: list | None = None
    trace: bool = False
    scene: str | None = None

    def __post_init__(self) -> None:
        if self.goal_radius is None:
            self.goal_radius = self.config.episode.eval_goal_radius


@dc.dataclass
class EpisodeSystems:
    """The systems of a built navigation diagram that the episode loop reads.

    Attributes:
        diagram: the whole diagram.
        robot: the system with the `robot_state` output, (x [m], y [m], θ [rad], v [m/s])
            in the world frame: the LIP plant or the Digit station (CoM, torso yaw,
            sagittal CoM speed).
        crowd: the `CrowdSystem` (`crowd` output: positions [m], true emotion codes).
        planner: the `NavigationPlanner` (`command` output: the held (u_v [m/s], u_Δθ [rad])).
        monitor: the `EpisodeMonitor` (`status` output: the record, done, the last step).
        label: the robot's name in the progress bar and the replay's caption.
        footsteps: the replay draws the footsteps.
        stop_when_done: the simulator's monitor stops it at the step that ends the episode
            (`episode_monitor_callback`; the LIP's, cheap at its event rate).
        fall: a plant that can fall: the reason it has fallen at a context's time, or None
            (standing); None for a plant that cannot fall.
    """

    diagram: Diagram
    robot: System
    crowd: System
    planner: System
    monitor: System
    label: str
    footsteps: bool = False
    stop_when_done: bool = False
    fall: FallCheck | None = None


def training_request(
    scenario: Scenario, config: EmoNavConfig, planner: Planner, **options: Any
) -> EpisodeRequest:
    """The request of `run_episode` / `run_digit_episode`: `options` are the other fields
    of `EpisodeRequest`, but the goal radius defaults to `config.episode.goal_radius` (the
    training threshold, the episode monitor's own default)."""
    if options.get("goal_radius") is None:
        options["goal_radius"] = config.episode.goal_radius
    return EpisodeRequest(scenario, config, planner, **options)


def run_navigation_episode(
    request: EpisodeRequest,
    build: Callable[[EpisodeRequest], EpisodeSystems],
) -> tuple[EpisodeRecord, EpisodeTrace | None]:
    """Simulate `request` on the diagram `build(request)` returns; (record, trace or None).

    With `record_html` the run is recorded in Meshcat (a loopback-only one is made when
    the request has none) and written as a self-contained HTML replay; a browser already
    watching sees the episode while it is recorded."""
    from pydrake.systems.analysis import Simulator

    from emonav_drake.diagrams.meshcat_viewing import (
        ReplayCaption,
        make_meshcat,
        write_replay_html,
    )
    from emonav_drake.systems.episode_monitor import episode_monitor_callback

    req = request
    if req.record_html is not None and req.meshcat is None:
        req = dc.replace(req, meshcat=make_meshcat(live=False))  # loopback only
    systems = build(req)
    sim = Simulator(systems.diagram)
    sim.set_target_realtime_rate(req.realtime_rate)
    if systems.stop_when_done:
        sim.set_monitor(episode_monitor_callback(systems.diagram, systems.monitor))
    meshcat = req.meshcat
    if req.record_html is not None:
        live = meshcat.GetNumActiveConnections() > 0
        meshcat.StartRecording(set_visualizations_while_recording=live)
    record, trace = simulate_episode(
        sim, systems, req.config, trace=req.trace, progress=req.progress, rates=req.rates
    )
    if req.record_html is not None:
        meshcat.StopRecording()
        meshcat.PublishRecording()
        caption = ReplayCaption.for_episode(
            req.planner,
            systems.label,
            req.scenario,
            record,
            rays=req.show_rays,
            footsteps=systems.footsteps,
            tracks=req.config.perception.state_source == "lidar",
            route=uses_route(req.scenario, req.config),
            scene=req.scene,
        )
        write_replay_html(meshcat, req.record_html, caption)
    return record, trace


def simulate_episode(
    sim: Simulator,
    systems: EpisodeSystems,
    config: EmoNavConfig,
    *,
    trace: bool = False,
    progress: bool = False,
    rates: RateMeasurement | None = None,
) -> tuple[EpisodeRecord, EpisodeTrace | None]:
    """Initialize `sim` (built on `systems.diagram`, its context at the episode's start)
    and run it walking step by walking step until the episode monitor ends the episode or
    the robot falls (module docstring); (record, the `EpisodeTrace` if `trace` else None).

    With `progress`, a `SimulationProgress` bar on stderr (named after `systems.label`)
    is ended with the outcome. With `rates`, the run (initialization included) is
    profiled by `diagrams.rates` and the report left in `rates.report`."""
    from emonav_drake.progress import SimulationProgress

    ctx = sim.get_mutable_context()
    T = config.robot.step_time
    log = EpisodeTrace() if trace else None
    bar = SimulationProgress(config.episode.max_steps * T, f"{systems.label} episode", progress)

    def run() -> EpisodeRecord:
        sim.Initialize()
        return _walk(sim, systems, T, log, bar)

    try:
        record = run() if rates is None else rates.run(sim, systems.diagram, run)
    except BaseException:  # Ctrl-C included: end the bar's line
        bar.close(ctx.get_time())
        raise
    bar.close(ctx.get_time(), record.outcome)
    return record, log


class EpisodeStepper:
    """Walks a built navigation diagram one walking step at a time: the one loop of every
    navigation episode (`simulate_episode`, the `EmoNavDigit-v0` environment, the camera
    study's episodes).

    Walking step k ends at t_k = k·T exactly (`AdvanceTo(k·T)`: summing T would drift off
    the planner's instants in the last bits). `outcome` says, at t_k, whether the episode
    has ended — a fall first (the plant's check, `EpisodeSystems.fall`), then the episode
    monitor — and with which record; `advance` walks to t_{k+1} and, on a plant that can
    fall, turns a `RuntimeError` of the simulator into the record of a fall (the contact
    solver gives up only on a robot in a heap).

    Args:
        sim: the simulator of `systems.diagram`, initialized.
        systems: what the loop reads of the diagram.
        step_time: T [s], the planner's period (`robot.step_time`).
    """

    def __init__(self, sim: Simulator, systems: EpisodeSystems, step_time: float) -> None:
        self.sim, self.systems, self.step_time = sim, systems, step_time
        self.context = sim.get_mutable_context()
        self._status = systems.monitor.GetOutputPort("status")
        self._monitor_context = systems.monitor.GetMyContextFromRoot(self.context)
        self.k = round(self.context.get_time() / step_time)
        self._stopped: EpisodeRecord | None = None  # the fall of a simulator that gave up

    def status(self) -> Any:
        """The episode monitor's status now (record, done, the last step's evaluation)."""
        return self._status.Eval(self._monitor_context)

    def outcome(self, status: Any = None) -> EpisodeRecord | None:
        """The episode's record if it has ended at the current instant (the simulator
        gave up, a fall, or the monitor's verdict), else None; `status`: `status()` if
        already read."""
        from emonav_drake.systems.fall_monitor import FALL

        if self._stopped is not None:
            return self._stopped
        status = self.status() if status is None else status
        reason = None if self.systems.fall is None else self.systems.fall(self.context)
        if reason is not None:  # a copy: the status is the monitor's cached value
            return dc.replace(status.record, outcome=FALL, fall_reason=reason)
        return status.record if status.done else None

    def advance(self) -> EpisodeRecord | None:
        """Walk to the next instant t_{k+1}; None, or the record of a fall if the simulator
        gave up on a plant that can fall (a `RuntimeError` elsewhere is raised)."""
        from emonav_drake.systems.fall_monitor import FALL

        self.k += 1
        try:
            self.sim.AdvanceTo(self.k * self.step_time)
        except RuntimeError as e:
            if self.systems.fall is None:
                raise
            reason = f"simulation stopped: {e}"
            self._stopped = dc.replace(self.status().record, outcome=FALL, fall_reason=reason)
            return self._stopped
        return None


def _walk(
    sim: Simulator,
    systems: EpisodeSystems,
    T: float,
    log: EpisodeTrace | None,
    bar: Any,
) -> EpisodeRecord:
    """The loop of `simulate_episode`: one `AdvanceTo` per walking step."""
    stepper = EpisodeStepper(sim, systems, T)
    while True:
        status = stepper.status()
        if log is not None:
            _log_instant(systems, stepper.context, stepper.k, status, log)
        record = stepper.outcome(status)
        if record is None:
            record = stepper.advance()
        if record is not None:
            return record
        bar.update(stepper.context.get_time())


def _log_instant(
    systems: EpisodeSystems, ctx: Context, k: int, status: Any, log: EpisodeTrace
) -> None:
    """Append the row of t_k: the world before the updates at t_k (the planner still holds
    u_{k−1}, the command of the step that just ended)."""
    robot = systems.robot.GetOutputPort("robot_state")
    crowd_sys, planner = systems.crowd, systems.planner
    crowd = crowd_sys.GetOutputPort("crowd").Eval(crowd_sys.GetMyContextFromRoot(ctx))
    seen = planner.GetInputPort("crowd").Eval(planner.GetMyContextFromRoot(ctx))
    last = status.last_step
    log.append(
        k,
        ctx.get_time(),
        robot.Eval(systems.robot.GetMyContextFromRoot(ctx)),
        planner.GetOutputPort("command").Eval(planner.GetMyContextFromRoot(ctx)),
        crowd.positions,
        crowd.emotions,
        math.nan if last is None else last.reward,
        perceived_emotions(crowd.positions, seen.positions, seen.emotions),
    )
