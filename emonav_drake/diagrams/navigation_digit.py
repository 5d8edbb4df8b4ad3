"""Navigation with the full-order Digit: the paper's deployment setting (LIP/Digit, Digit/Digit).

The navigation stack of `diagrams/navigation.py` — crowd, LiDAR grid maps, planner (DWA,
MPC or a learned policy) and episode monitor — around the Digit station
(`diagrams/digit_station.py`) instead of the LIP robot:

    NavigationPlanner (2.5 Hz, holds u_k) ─command─► DigitStation ──► robot_state, fall
       ▲  robot_state, crowd, lgm_stack               (ALIP 50 Hz, controller and
       └──────────────────────────────────────────────  plant 10 ms, fall check 100 Hz)

The robot state the navigation stack sees is Digit's CoM, torso yaw and sagittal CoM
speed, so the walking stack's tracking errors reach the crowd, the policy's observation
(LGM, scans, ...) and the rewards — the discrepancy the paper studies.

Timing. At t_k = kT the planner computes u_k from the robot, the crowd and the grid maps
at t_k and holds it; Digit walks u_k in step k, as the LIP does. Digit stands until
`walking.stand_time` = T (the LIP's step 0), so its walking step k runs from the foot
switch at (or up to 10 % of T before) t_k to the one at t_{k+1}: the footstep planner's
step clock is locked to the planner's instants, and an early touchdown lengthens the next
step rather than moving the later switches ahead. A switch reads the command held before
t_k (every update of one instant reads the pre-update state), so the step starts with the
previous speed and no turn and takes up u_k at the footstep planner's first update after
t_k (t_k + `walking.planner_period`, 20 ms by default): the heading target, the swing
foot's yaw and the foot placement's speed are re-targeted then
(`systems/alip_footstep_planner.py`, "Step clock", "In-step commands"). The ALIP places
the swing foot so that the speed reaches u_v at the end of the *next* step: the one-step
speed response of the ALIP itself, which the LIP model (reaching u_v at t_{k+1}) does not
have. The heading change of step k follows u_Δθ,k.

A fall (the station's `FallMonitor`) ends the episode with the outcome "fall": an
outcome, never an exception.

`run_digit_episode` simulates one episode with the loop both plants share
(`diagrams/episode.py`); on a simulator of your own (e.g. a context set up first),
`diagrams.episode.simulate_episode(sim, nd.systems(), config)`.
"""

from __future__ import annotations

import dataclasses as dc
from typing import Any

from pydrake.geometry import Meshcat, MeshcatVisualizer, MeshcatVisualizerParams, Role
from pydrake.systems.framework import Context, Diagram, DiagramBuilder

from emonav_drake.diagrams.digit_station import AddDigitStation, DigitStation
from emonav_drake.diagrams.episode import (
    EpisodeRequest,
    EpisodeSystems,
    FallCheck,
    run_navigation_episode,
    training_request,
)
from emonav_drake.diagrams.navigation import AddNavigationStack, AddNavigationVisualizer
from emonav_drake.navigation.episode_trace import EpisodeTrace
from emonav_drake.navigation.metrics import EpisodeRecord
from emonav_drake.params import EmoNavConfig
from emonav_drake.perception.noisy_emotions import CAMERA_MODES, EmotionEstimateParams
from emonav_drake.planners.protocol import Planner
from emonav_drake.scenarios.scenario import Scenario
from emonav_drake.systems.crowd_system import CrowdSystem
from emonav_drake.systems.episode_monitor import EpisodeMonitor
from emonav_drake.systems.head_camera import body_camera_mount
from emonav_drake.systems.navigation_planner import NavigationPlanner


@dc.dataclass
class DigitNavigationDiagram:
    """The built diagram and handles to its systems."""

    diagram: Diagram
    station: DigitStation
    crowd: CrowdSystem
    planner: NavigationPlanner
    monitor: EpisodeMonitor

    @property
    def model(self):
        return self.station.model

    def systems(self) -> EpisodeSystems:
        """What the episode loop reads (`diagrams.episode.simulate_episode`), with the
        station's fall check."""
        nav = (self.diagram, self.station, self.crowd, self.planner, self.monitor)
        return EpisodeSystems(*nav, "Digit", fall=_fall_check(self.station), footsteps=True)


def build_digit_navigation_diagram(
    scenario: Scenario,
    config: EmoNavConfig,
    planner: Planner | None,
    meshcat: Meshcat | None = None,
    grid_kind: str = "lgm",
    goal_radius: float | None = None,
    emotion_estimate: EmotionEstimateParams | None = None,
    camera_frames: list | None = None,
) -> DigitNavigationDiagram:
    """Wire the navigation stack around the Digit station for one scenario.

    Digit stands at the scenario's start, facing its heading, in a default context.
    `grid_kind` ("lgm", "ogm", "scan", "drlvo") selects the map observation the planner
    reads, seen from Digit's CoM and heading (as `diagrams.navigation`; for a policy,
    `planners.configure_for`). `planner` None builds the diagram for an external agent:
    an `action` input (the planner's, sampled at every t_k) and an `observation` output
    (the Gymnasium observation of `EmoNavDigit-v0`, `systems.navigation_observation`).
    `emotion_estimate` as in `build_navigation_diagram`; in mode "camera" the head camera
    rides on Digit's torso (`HeadCameraParams.digit_offset`) and sways with it.
    With `config.route.enabled`, the global route layer in a scene with walls
    (`AddNavigationStack`).
    """
    config.validate()
    scenario.validate()
    b = DiagramBuilder()
    pose = (*(float(v) for v in scenario.robot_start), float(scenario.robot_heading))
    station = AddDigitStation(b, config, pose=pose)
    robot_state = station.GetOutputPort("robot_state")
    mount = None
    if emotion_estimate is not None and emotion_estimate.mode in CAMERA_MODES:
        torso = station.model.torso_body.index()
        mount = body_camera_mount(
            b, station.GetOutputPort("body_poses"), int(torso), emotion_estimate.camera
        )
    stack = AddNavigationStack(
        b,
        scenario,
        config,
        planner,
        robot_state,
        grid_kind=grid_kind,
        goal_radius=goal_radius,
        emotion_estimate=emotion_estimate,
        camera_mount=mount,
        camera_frames=camera_frames,
    )
    crowd, nav, monitor = stack.crowd, stack.planner, stack.monitor
    b.Connect(nav.GetOutputPort("command"), station.GetInputPort("command"))
    if planner is None:  # an external agent: the Gymnasium env EmoNavDigit-v0
        from emonav_drake.systems.navigation_observation import NavigationObservation

        b.ExportInput(nav.GetInputPort("action"), "action")
        obs = b.AddNamedSystem(
            "observation", NavigationObservation(scenario.robot_goal, config, grid_kind)
        )
        b.Connect(robot_state, obs.GetInputPort("robot_state"))
        b.Connect(stack.grid_maps.GetOutputPort("lgm_stack"), obs.GetInputPort("lgm_stack"))
        b.Connect(nav.GetOutputPort("command"), obs.GetInputPort("last_action"))
        b.ExportOutput(obs.GetOutputPort("observation"), "observation")
    if meshcat is not None:
        MeshcatVisualizer.AddToBuilder(
            b,
            station.GetOutputPort("query_object"),
            meshcat,
            MeshcatVisualizerParams(role=Role.kIllustration),
        )
        vis = AddNavigationVisualizer(
            b, stack, robot_state, meshcat, "navigation_visualizer", draw_robot=False
        )
        b.Connect(station.GetOutputPort("targets"), vis.GetInputPort("footstep_targets"))
    diagram = b.Build()
    diagram.set_name("emonav_navigation_digit")
    return DigitNavigationDiagram(diagram, station, crowd, nav, monitor)


def run_digit_episode(
    scenario: Scenario, config: EmoNavConfig, planner: Planner, **options: Any
) -> tuple[EpisodeRecord, EpisodeTrace | None]:
    """Simulate one navigation episode with the full-order Digit; (its record, outcome
    success | collision | timeout | fall; its `EpisodeTrace` with `trace=True`, else None).

    As `diagrams.navigation.run_episode` (the same arguments, the same loop:
    `diagrams.episode.run_navigation_episode`): `options` are the other fields of
    `EpisodeRequest` — grid_kind, emotion_estimate, meshcat, record_html, realtime_rate,
    rates, progress, camera_frames (the camera rides on Digit's torso), trace; Digit draws
    no LiDAR rays (`show_rays`). `goal_radius` [m] defaults to `config.episode.goal_radius`.
    The trace's robot state is Digit's CoM [m], torso yaw [rad] and sagittal CoM speed
    [m/s] (world frame W); after a fall its last row is the instant the fall was seen.
    """
    request = training_request(scenario, config, planner, **options)
    return run_navigation_episode(request, build_episode)


def build_episode(r: EpisodeRequest) -> EpisodeSystems:
    """The Digit diagram of a request, as the episode loop reads it."""
    if r.show_rays:
        raise ValueError("the Digit diagram draws no LiDAR rays: show_rays must be False")
    nd = build_digit_navigation_diagram(
        r.scenario,
        r.config,
        r.planner,
        r.meshcat,
        r.grid_kind,
        r.goal_radius,
        r.emotion_estimate,
        r.camera_frames,
    )
    return nd.systems()


def _fall_check(station: DigitStation) -> FallCheck:
    """The station's fall port as the episode loop's fall check: the reason, or None."""
    port = station.GetOutputPort("fall")

    def fall_reason(ctx: Context) -> str | None:
        fall = port.Eval(station.GetMyContextFromRoot(ctx))
        return fall.reason if fall.fallen else None

    return fall_reason
