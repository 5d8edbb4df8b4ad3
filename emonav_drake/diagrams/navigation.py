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
(1, 3, M, M) ("drlvo") — computed by the same `navigation.observations.observation_frame` as the
Gymnasium env's, so any policy checkpoint runs here with its training observation
(`planners.configure_for` reads the kind and sizes from the checkpoint). DWA and MPC
ignore it.

`build_navigation_diagram` wires it; `run_episode` simulates one episode walking step
by walking step (the loop both plants share, `diagrams/episode.py`) and returns its
`EpisodeRecord` and, with `trace=True`, its `EpisodeTrace` (`navigation/episode_trace.py`).
With `progress=True` it shows `progress.SimulationProgress`, a bar over simulated time.
"""

from __future__ import annotations

import dataclasses as dc
import logging
from typing import TYPE_CHECKING, Any

from pydrake.geometry import Meshcat
from pydrake.systems.framework import Diagram, DiagramBuilder, OutputPort

from emonav_drake.diagrams.episode import (
    EpisodeRequest,
    EpisodeSystems,
    run_navigation_episode,
    training_request,
)
from emonav_drake.navigation.episode_trace import EpisodeTrace
from emonav_drake.navigation.metrics import EpisodeRecord
from emonav_drake.navigation.route_following import route_follower, uses_route
from emonav_drake.params import ConfigError, EmoNavConfig
from emonav_drake.perception.noisy_emotions import CAMERA_MODES, EmotionEstimateParams
from emonav_drake.planners.protocol import Planner
from emonav_drake.scenarios.scenario import Scenario
from emonav_drake.systems.crowd_system import CrowdSystem
from emonav_drake.systems.crowd_tracker_system import CrowdTrackerSystem
from emonav_drake.systems.emotion_estimate_source import AddEmotionEstimateSource
from emonav_drake.systems.episode_monitor import EpisodeMonitor
from emonav_drake.systems.global_route_planner import GlobalRoutePlanner
from emonav_drake.systems.head_camera import CameraMount, lip_camera_mount
from emonav_drake.systems.lidar_grid_map_builder import LidarGridMapBuilder
from emonav_drake.systems.lip_robot_plant import LipRobotPlant
from emonav_drake.systems.navigation_meshcat import NavigationMeshcatVisualizer
from emonav_drake.systems.navigation_planner import NavigationPlanner

if TYPE_CHECKING:
    from emonav_drake.diagrams.camera_perception import CameraPerception

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

    def systems(self) -> EpisodeSystems:
        """What the episode loop reads (`diagrams.episode.simulate_episode`)."""
        nav = (self.diagram, self.robot, self.crowd, self.planner, self.monitor)
        return EpisodeSystems(*nav, "LIP", stop_when_done=True)


@dc.dataclass
class NavigationStack:
    """The robot-independent part of a navigation diagram, and what it was built for."""

    crowd: CrowdSystem
    grid_maps: LidarGridMapBuilder
    planner: NavigationPlanner
    monitor: EpisodeMonitor
    scenario: Scenario
    config: EmoNavConfig
    goal_radius: float | None  # the monitor's [m]; None: config.episode.goal_radius
    perception: CameraPerception | None = None  # mode "camera": the camera chain
    tracker: CrowdTrackerSystem | None = None  # perception.state_source "lidar"
    route: GlobalRoutePlanner | None = None  # global_route in a scene with walls


def make_route_planner(scenario: Scenario, config: EmoNavConfig) -> GlobalRoutePlanner:
    """The `GlobalRoutePlanner` of a scene (`navigation.route_following.route_follower`:
    its map, goal, clearances, look-ahead, line of sight and stray distance), checked
    every walking step. `ConfigError` naming what blocks it when no route with the robot's
    radius joins the start to the goal on the map at t = 0."""
    return GlobalRoutePlanner.of_follower(
        route_follower(scenario, config), period=config.robot.step_time
    )


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
    global_route: bool | None = None,
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
        global_route: in a scene with walls, a `GlobalRoutePlanner` (`make_route_planner`)
            gives the planner its goal, a sub-goal along the route around the walls, and
            the monitor its `has_route` (docs/global_route.md); None: as
            `config.route.enabled` (on by default).
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
    route = None
    if uses_route(scenario, config, global_route):  # the planner steers to a sub-goal
        route = b.AddNamedSystem("global_route", make_route_planner(scenario, config))
        b.Connect(robot_state, route.GetInputPort("robot_state"))
        b.Connect(route.GetOutputPort("subgoal"), plan.GetInputPort("goal"))
        b.Connect(route.GetOutputPort("has_route"), monitor.GetInputPort("has_route"))
    planner_crowd = plan.GetInputPort("crowd")
    tracker = None
    if config.perception.state_source == "lidar":  # the planner reads the tracked crowd
        tracker = b.AddNamedSystem(
            "crowd_tracker", CrowdTrackerSystem(config, known_walls=scenario.wall_segments())
        )
        b.Connect(robot_state, tracker.GetInputPort("robot_state"))
        b.Connect(maps.GetOutputPort("scan"), tracker.GetInputPort("scan"))
        b.Connect(tracker.GetOutputPort("crowd"), planner_crowd)
        planner_crowd = tracker.GetInputPort("crowd")  # its emotion reports
    perceivers = [maps.GetInputPort("crowd"), planner_crowd]
    ring_tracks = ""  # why the maps ring the tracked people ("": they ring the crowd's)
    if tracker is not None and config.perception.map_rings == "tracks":
        ring_tracks = "perception.map_rings = tracks"
    perception = None
    if emotion_estimate is not None and emotion_estimate.mode in CAMERA_MODES:
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
            tracker,
        )
        if tracker is not None and emotion_estimate.mode == "camera_tracks":
            ring_tracks = "emotion source camera_tracks"
    elif emotion_estimate is not None and emotion_estimate.mode != "ground_truth":
        AddEmotionEstimateSource(
            b, crowd.GetOutputPort("crowd"), perceivers, config, emotion_estimate
        )
    else:
        for port in perceivers:
            b.Connect(crowd.GetOutputPort("crowd"), port)
    if ring_tracks:  # the maps' discomfort rings: round the tracked people, their emotions
        if grid_kind == "drlvo":
            raise ConfigError(
                f"{ring_tracks} rings the tracked pedestrians in the grid maps; the drlvo "
                "observation cannot take them"
            )
        b.Connect(tracker.GetOutputPort("crowd"), maps.GetInputPort("perceived_crowd"))
    b.Connect(crowd.GetOutputPort("crowd"), monitor.GetInputPort("crowd"))
    b.Connect(plan.GetOutputPort("command"), monitor.GetInputPort("command"))  # for the jerk
    b.Connect(maps.GetOutputPort("lgm_stack"), plan.GetInputPort("lgm_stack"))
    return NavigationStack(
        crowd, maps, plan, monitor, scenario, config, goal_radius, perception, tracker, route
    )


def AddNavigationVisualizer(
    builder: DiagramBuilder,
    stack: NavigationStack,
    robot_state: OutputPort,
    meshcat: Meshcat,
    name: str = "visualizer",
    **options: Any,
) -> NavigationMeshcatVisualizer:
    """Add the drawing of a navigation stack (`NavigationMeshcatVisualizer`, named `name`,
    its goal pad the stack's goal radius [m]) wired to the robot's `robot_state` (x [m],
    y [m], θ [rad], v [m/s], world frame), the true crowd and, with LiDAR tracking, the
    tracked crowd the planner reads beside it; with the global route layer, the route and
    its sub-goal; with the camera, its rendered heads and faces (`draw_in_meshcat`).
    `options` go to the visualizer (`show_rays`, `draw_robot`); the caller connects the
    plant's own inputs (`scan`, `footstep_targets`)."""
    from emonav_drake.diagrams.camera_perception import draw_in_meshcat

    b = builder
    vis = b.AddNamedSystem(
        name,
        NavigationMeshcatVisualizer(
            meshcat,
            stack.scenario,
            stack.config,
            goal_radius=stack.goal_radius,
            **options,
            **draw_in_meshcat(b, stack.perception, meshcat),
        ),
    )
    b.Connect(robot_state, vis.GetInputPort("robot_state"))
    b.Connect(stack.crowd.GetOutputPort("crowd"), vis.GetInputPort("crowd"))
    if stack.tracker is not None:  # the crowd the planner reads, beside the true one
        b.Connect(stack.tracker.GetOutputPort("crowd"), vis.GetInputPort("tracks"))
    if stack.route is not None:  # the global route and its sub-goal
        b.Connect(stack.route.GetOutputPort("route"), vis.GetInputPort("route"))
        b.Connect(stack.route.GetOutputPort("subgoal"), vis.GetInputPort("subgoal"))
    return vis


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
    if emotion_estimate is not None and emotion_estimate.mode in CAMERA_MODES:
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
        vis = AddNavigationVisualizer(b, stack, state, meshcat, show_rays=show_rays)
        b.Connect(maps.GetOutputPort("scan"), vis.GetInputPort("scan"))
    diagram = b.Build()
    diagram.set_name("emonav_navigation")
    return NavigationDiagram(diagram, robot, crowd, maps, plan, monitor, vis)


def run_episode(
    scenario: Scenario, config: EmoNavConfig, planner: Planner, **options: Any
) -> tuple[EpisodeRecord, EpisodeTrace | None]:
    """Simulate one episode of the LIP navigation diagram; (its record, its
    `EpisodeTrace` with `trace=True`, else None).

    `options` are the other fields of `EpisodeRequest` (`diagrams/episode.py`): grid_kind,
    emotion_estimate, meshcat, record_html, show_rays, realtime_rate, rates, progress,
    camera_frames, trace. `goal_radius` [m] defaults to `config.episode.goal_radius` (the
    training threshold; `Plant.simulate`'s request defaults to the evaluation one). The
    loop, replay, profiler and progress bar are `diagrams.episode.run_navigation_episode`'s:
    the results do not depend on them. The planner's memory starts from
    `planner.initial_memory()` in the new diagram's Context (no `reset()` needed).
    """
    request = training_request(scenario, config, planner, **options)
    return run_navigation_episode(request, build_episode)


def build_episode(r: EpisodeRequest) -> EpisodeSystems:
    """The LIP diagram of a request, as the episode loop reads it."""
    nav = build_navigation_diagram(
        r.scenario,
        r.config,
        r.planner,
        r.meshcat,
        r.show_rays,
        r.grid_kind,
        r.goal_radius,
        r.emotion_estimate,
        r.camera_frames,
    )
    return nav.systems()
