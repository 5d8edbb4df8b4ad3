"""The navigation diagram: crowd + LiDAR/LGM + planner + LIP robot (+ Meshcat).

    ┌───────────────┐ robot_state ┌──────────────┐ crowd ┌─────────────────────┐
    │ LipRobotPlant ├────────────►│ CrowdSystem  ├──────►│ LidarGridMapBuilder │
    │ (T = 0.4 s)   │             │ (dt = 0.1 s) │       │ (stack per step)    │
    └──▲─────┬──────┘             └──────┬───────┘       └─────────┬───────────┘
       │     │ robot_state               │ crowd                   │ lgm_stack
       │     │                    ┌──────▼───────────┐             │
       │     └───────────────────►│ NavigationPlanner│◄────────────┘
       │          command (held)  │ (DWA / MPC / SAC,│
       └──────────────────────────┤  T = 0.4 s)      │
                                  └──────────────────┘
    EpisodeMonitor (rewards, outcome, metrics) and the Meshcat visualiser listen.

Timing. Every navigation update is a periodic unrestricted event at offset 0 (the
planner, the plant and the grid maps every T, the crowd every dt, the monitor every T),
so at an instant t_k = kT every one reads the same pre-update state. At t_k the planner
reads the robot at its foot switch, the crowd and the grid-map stack at t_k, and its own
previous command u_{k−1} (from its state: there is no `last_command` port); it stores u_k,
which the robot executes during step k (t_k → t_{k+1}). The planner's `command` output is
its state (no direct feedthrough); the plant's `robot_state` is computed from the step's
start state, that command and the elapsed time (direct feedthrough from `command`). The
planner's memory (e.g. the MPC's warm start) lives in the Context: two simulations from
fresh default contexts, or a cloned context, need no `planner.reset()`.

Observation. The grid-map builder gives the planner the map observation of the
diagram's `grid_kind` on its `lgm_stack` port — LGM or OGM stack uint8 (N, M, M), raw
scan stack float32 (N, K) [m] ("scan": LiDAR-SAC, LNDNL), or the DRL-VO* image uint8
(1, 3, M, M) ("drlvo") — computed by the same `core.observations.observation_frame` as the
Gymnasium env's, so any policy checkpoint runs here with its training observation
(`planners.configure_for` reads the kind and sizes from the checkpoint). DWA and MPC
ignore it.

`build_navigation_diagram` wires it; `run_episode` simulates one episode walking step
by walking step and returns its `EpisodeRecord` and a per-step trajectory log.
With `progress=True` it shows `progress.SimulationProgress`, a bar over simulated time.
"""

from __future__ import annotations

import dataclasses as dc
import logging
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from pydrake.geometry import Meshcat
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import Context, Diagram, DiagramBuilder, OutputPort

from emonav_drake.core.metrics import EpisodeRecord
from emonav_drake.core.scenario import Scenario
from emonav_drake.diagrams.meshcat_viewing import ReplayCaption, make_meshcat, write_replay_html
from emonav_drake.params import EmoNavConfig
from emonav_drake.perception.noisy_emotions import EmotionEstimateParams
from emonav_drake.planners.protocol import Planner
from emonav_drake.progress import SimulationProgress
from emonav_drake.systems.crowd_system import CrowdSystem
from emonav_drake.systems.crowd_tracker_system import CrowdTrackerSystem
from emonav_drake.systems.emotion_estimate_source import AddEmotionEstimateSource
from emonav_drake.systems.episode_monitor import (
    EpisodeMonitor,
    EpisodeStatus,
    episode_monitor_callback,
)
from emonav_drake.systems.head_camera import CameraMount, lip_camera_mount
from emonav_drake.systems.lidar_grid_map_builder import LidarGridMapBuilder
from emonav_drake.systems.lip_robot_plant import LipRobotPlant
from emonav_drake.systems.navigation_meshcat import NavigationMeshcatVisualizer
from emonav_drake.systems.navigation_planner import NavigationPlanner

if TYPE_CHECKING:
    from emonav_drake.diagrams.camera_perception import CameraPerception
    from emonav_drake.diagrams.rates import RateMeasurement

log = logging.getLogger(__name__)


@dc.dataclass
class NavigationDiagram:
    """The built diagram and handles to its systems."""

    diagram: Diagram
    robot: LipRobotPlant
    crowd: CrowdSystem
    grid_maps: LidarGridMapBuilder
    planner: NavigationPlanner
    monitor: EpisodeMonitor
    visualizer: NavigationMeshcatVisualizer | None


@dc.dataclass
class NavigationStack:
    """The robot-independent part of a navigation diagram."""

    crowd: CrowdSystem
    grid_maps: LidarGridMapBuilder
    planner: NavigationPlanner
    monitor: EpisodeMonitor
    perception: CameraPerception | None = None  # mode "camera": the camera chain
    tracker: CrowdTrackerSystem | None = None  # perception.state_source "lidar"


def AddNavigationStack(
    builder: DiagramBuilder,
    scenario: Scenario,
    config: EmoNavConfig,
    planner: Planner,
    robot_state: OutputPort,
    grid_kind: str = "lgm",
    goal_radius: float | None = None,
    emotion_estimate: EmotionEstimateParams | None = None,
    camera_mount: CameraMount | None = None,
    camera_frames: list | None = None,
) -> NavigationStack:
    """Add crowd, grid maps, planner and episode monitor, wired to a robot.

    Args:
        builder: the diagram builder.
        robot_state: the robot's (x [m], y [m], θ [rad], v [m/s]) output, world frame (LIP
            plant or Digit's CoM state); at t_k it must show the robot at its foot switch.
        camera_mount: where the robot carries its head camera (required by the emotion
            estimate's mode "camera": `diagrams/camera_perception.py`).
        camera_frames: mode "camera" only: every classified image, annotated, is
            appended to this list as (time [s], BGR image) (`write_camera_gif`).
        Others: as `build_navigation_diagram`.
    The caller connects the planner's `command` output to its robot: (u_v [m/s], u_Δθ
    [rad]), held for the whole walking step (u_k during step k, planned at t_k).
    """
    b = builder
    crowd = b.AddNamedSystem("crowd", CrowdSystem(scenario, config))
    maps = b.AddNamedSystem("grid_maps", LidarGridMapBuilder(config, grid_kind))
    plan = b.AddNamedSystem("planner", NavigationPlanner(planner, scenario.robot_goal, config))
    monitor = b.AddNamedSystem("monitor", EpisodeMonitor(scenario, config, goal_radius))
    for sys in (crowd, maps, plan, monitor):
        b.Connect(robot_state, sys.GetInputPort("robot_state"))
    planner_crowd = plan.GetInputPort("crowd")
    tracker = None
    if config.perception.state_source == "lidar":  # the planner reads the tracked crowd
        tracker = b.AddNamedSystem("crowd_tracker", CrowdTrackerSystem(config))
        b.Connect(robot_state, tracker.GetInputPort("robot_state"))
        b.Connect(maps.GetOutputPort("scan"), tracker.GetInputPort("scan"))
        b.Connect(tracker.GetOutputPort("crowd"), planner_crowd)
        planner_crowd = tracker.GetInputPort("crowd")  # its emotion reports
    perceivers = [maps.GetInputPort("crowd"), planner_crowd]
    perception = None
    if emotion_estimate is not None and emotion_estimate.mode == "camera":
        from emonav_drake.diagrams.camera_perception import AddCameraPerception

        if camera_mount is None:
            raise ValueError("emotion estimate mode 'camera' needs the robot's camera_mount")
        perception = AddCameraPerception(
            b,
            scenario,
            config,
            crowd.GetOutputPort("crowd"),
            robot_state,
            camera_mount,
            perceivers,
            emotion_estimate,
            camera_frames,
        )
    elif emotion_estimate is not None and emotion_estimate.mode != "ground_truth":
        AddEmotionEstimateSource(
            b, crowd.GetOutputPort("crowd"), perceivers, config, emotion_estimate
        )
    else:
        for port in perceivers:
            b.Connect(crowd.GetOutputPort("crowd"), port)
    b.Connect(crowd.GetOutputPort("crowd"), monitor.GetInputPort("crowd"))
    b.Connect(plan.GetOutputPort("command"), monitor.GetInputPort("command"))  # for the jerk
    b.Connect(maps.GetOutputPort("lgm_stack"), plan.GetInputPort("lgm_stack"))
    return NavigationStack(crowd, maps, plan, monitor, perception, tracker)


def build_navigation_diagram(
    scenario: Scenario,
    config: EmoNavConfig,
    planner: Planner,
    meshcat: Meshcat | None = None,
    show_rays: bool = False,
    grid_kind: str = "lgm",
    goal_radius: float | None = None,
    emotion_estimate: EmotionEstimateParams | None = None,
    camera_frames: list | None = None,
) -> NavigationDiagram:
    """Wire the navigation diagram for one scenario.

    Args:
        scenario: the episode to play.
        config: the project configuration.
        planner: DWA, MPC or a learned policy (a `Planner`); its memory lives in the
            diagram's Context, so one planner object may serve several contexts.
        meshcat: draw into this Meshcat when given.
        show_rays: draw LiDAR rays in Meshcat.
        grid_kind: the map observation on the planner's `lgm_stack` input: "lgm" (the
            paper's LGM stack), "ogm", "scan" (raw scan stack) or "drlvo" (DRL-VO*
            image); see `LidarGridMapBuilder`. A policy's: `planners.configure_for`.
        goal_radius: goal threshold [m]; default `config.episode.goal_radius`.
        emotion_estimate: where the perceived emotions come from (default: ground truth).
            In "confusion" mode an `EmotionEstimateSource` between the crowd and the grid
            maps / planner feeds them misclassified emotions; the episode monitor keeps
            the ground truth, so the metrics measure real discomfort. In "camera" mode
            the robot's head camera and the face pipeline (`diagrams/camera_perception.py`).
        camera_frames: with "camera": collects the classified images (AddNavigationStack).
    """
    config.validate()
    scenario.validate()
    b = DiagramBuilder()
    robot = b.AddNamedSystem("robot", LipRobotPlant(scenario, config))
    state = robot.GetOutputPort("robot_state")
    mount = None
    if emotion_estimate is not None and emotion_estimate.mode == "camera":
        mount = lip_camera_mount(b, state, emotion_estimate.camera)
    stack = AddNavigationStack(
        b,
        scenario,
        config,
        planner,
        state,
        grid_kind,
        goal_radius,
        emotion_estimate,
        mount,
        camera_frames,
    )
    crowd, maps, plan, monitor = stack.crowd, stack.grid_maps, stack.planner, stack.monitor
    b.Connect(plan.GetOutputPort("command"), robot.GetInputPort("command"))
    vis = None
    if meshcat is not None:
        from emonav_drake.diagrams.camera_perception import draw_in_meshcat

        vis = b.AddNamedSystem(
            "visualizer",
            NavigationMeshcatVisualizer(
                meshcat,
                scenario,
                config,
                show_rays=show_rays,
                goal_radius=goal_radius,
                **draw_in_meshcat(b, stack.perception, meshcat),
            ),
        )
        b.Connect(state, vis.GetInputPort("robot_state"))
        b.Connect(crowd.GetOutputPort("crowd"), vis.GetInputPort("crowd"))
        b.Connect(maps.GetOutputPort("scan"), vis.GetInputPort("scan"))
        if stack.tracker is not None:  # the crowd the planner reads, beside the true one
            b.Connect(stack.tracker.GetOutputPort("crowd"), vis.GetInputPort("tracks"))
    diagram = b.Build()
    diagram.set_name("emonav_navigation")
    return NavigationDiagram(diagram, robot, crowd, maps, plan, monitor, vis)


@dc.dataclass
class StepLog:
    """The world at every walking step t_k (k = 0 … steps)."""

    robot: list[np.ndarray] = dc.field(default_factory=list)  # (x, y, θ, v)
    pedestrians: list[np.ndarray] = dc.field(default_factory=list)  # (P, 2)
    emotions: list[np.ndarray] = dc.field(default_factory=list)  # (P,) true codes in force
    commands: list[np.ndarray] = dc.field(default_factory=list)  # u_k, k = 0 … steps − 1
    rewards: list[float] = dc.field(default_factory=list)  # reward of the step ending at t_k


def run_episode(
    scenario: Scenario,
    config: EmoNavConfig,
    planner: Planner,
    meshcat: Meshcat | None = None,
    record_html: str | Path | None = None,
    show_rays: bool = False,
    grid_kind: str = "lgm",
    goal_radius: float | None = None,
    realtime_rate: float = 0.0,
    emotion_estimate: EmotionEstimateParams | None = None,
    rates: RateMeasurement | None = None,
    progress: bool = False,
    camera_frames: list | None = None,
) -> tuple[EpisodeRecord, StepLog]:
    """Simulate one episode of the navigation diagram.

    Returns the episode's record (outcome, metrics) and the per-step log. With
    `record_html` the run is recorded in Meshcat and written as a self-contained HTML
    replay (a Meshcat is created if none is given). With `rates`, the simulation runs
    under the profiler of `diagrams.rates` and the per-system rates and wall-time shares
    are left in `rates.report`. With `progress`, a `SimulationProgress` bar on stderr
    follows the simulated time step by step (the same steps either way: the results do
    not change). The planner's memory starts from `planner.initial_memory()` in the new
    diagram's Context (no `reset()` needed). `camera_frames`: see `AddNavigationStack`.
    """
    if record_html is not None and meshcat is None:
        meshcat = make_meshcat(live=False)  # loopback only
    nav = build_navigation_diagram(
        scenario,
        config,
        planner,
        meshcat,
        show_rays,
        grid_kind,
        goal_radius,
        emotion_estimate,
        camera_frames,
    )
    sim = start_episode_simulator(nav, realtime_rate, meshcat if record_html is not None else None)
    ctx = sim.get_mutable_context()
    T = config.robot.step_time
    log_ = StepLog()
    snapshot = _Snapshots(nav, ctx, log_)
    bar = SimulationProgress(config.episode.max_steps * T, "LIP episode", progress)

    def walk() -> None:
        done = snapshot(0)
        k = 0
        while not done:
            k += 1
            sim.AdvanceTo(k * T)
            bar.update(ctx.get_time())
            done = snapshot(k)

    try:
        if rates is not None:
            rates.run(sim, nav.diagram, walk)
        else:
            walk()
    except BaseException:  # Ctrl-C included: end the bar's line
        bar.close(ctx.get_time())
        raise
    record = snapshot.status().record
    bar.close(ctx.get_time(), record.outcome)
    if record_html is not None:
        meshcat.StopRecording()
        meshcat.PublishRecording()
        tracks = config.perception.state_source == "lidar"
        caption = ReplayCaption.for_episode(
            planner, "LIP", scenario, record, show_rays, tracks=tracks
        )
        write_replay_html(meshcat, record_html, caption)
    return record, log_


def start_episode_simulator(
    nav: NavigationDiagram, realtime_rate: float, recording: Meshcat | None
) -> Simulator:
    """The episode's simulator, initialized, with the episode monitor's termination; with a
    `recording` Meshcat, its recording started first."""
    sim = Simulator(nav.diagram)
    sim.set_target_realtime_rate(realtime_rate)
    sim.set_monitor(episode_monitor_callback(nav.diagram, nav.monitor))
    if recording is not None:
        # a browser already watching sees the episode while it is recorded
        live = recording.GetNumActiveConnections() > 0
        recording.StartRecording(set_visualizations_while_recording=live)
    sim.Initialize()
    return sim


class _Snapshots:
    """Logs the world at each t_k into a `StepLog` (`__call__`); reads the episode status."""

    def __init__(self, nav: NavigationDiagram, ctx: Context, log_: StepLog) -> None:
        self._nav, self._ctx, self._log = nav, ctx, log_
        self._robot_port = nav.robot.GetOutputPort("robot_state")
        self._crowd_port = nav.crowd.GetOutputPort("crowd")
        self._cmd_port = nav.planner.GetOutputPort("command")
        self._status_port = nav.monitor.GetOutputPort("status")

    def status(self) -> EpisodeStatus:
        """The episode monitor's status now (`status.record` is the episode's record)."""
        return self._status_port.Eval(self._nav.monitor.GetMyContextFromRoot(self._ctx))

    def __call__(self, k: int) -> bool:
        """Log the world at t_k, before the updates at t_k (the planner still holds
        u_{k−1}: the command of the step that just ended); whether the episode is done."""
        nav, ctx, log_ = self._nav, self._ctx, self._log
        rc = nav.robot.GetMyContextFromRoot(ctx)
        log_.robot.append(self._robot_port.Eval(rc).copy())
        crowd = self._crowd_port.Eval(nav.crowd.GetMyContextFromRoot(ctx))
        log_.pedestrians.append(crowd.positions.copy())
        log_.emotions.append(crowd.emotions.copy())
        status = self.status()
        if k > 0:
            log_.commands.append(self._cmd_port.Eval(nav.planner.GetMyContextFromRoot(ctx)).copy())
            if status.last_step is not None:
                log_.rewards.append(status.last_step.reward)
        return status.done
