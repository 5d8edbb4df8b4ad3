"""Navigation with the full-order Digit: the paper's deployment setting (LIP/Digit, Digit/Digit).

The navigation stack of `diagrams/navigation.py` — crowd, LiDAR grid maps, planner (DWA,
MPC or a learned policy) and episode monitor — around the Digit station
(`diagrams/digit_station.py`) instead of the LIP robot:

    NavigationPlanner (2.5 Hz, holds u_k) ─command─► DigitStation ──► robot_state, fall
       ▲  robot_state, crowd, lgm_stack               (ALIP 50 Hz, controller 250 Hz,
       └──────────────────────────────────────────────  plant 4 ms, fall check 125 Hz)

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
"""

from __future__ import annotations

import dataclasses as dc
from pathlib import Path

from pydrake.geometry import Meshcat, MeshcatVisualizer, MeshcatVisualizerParams, Role
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import Diagram, DiagramBuilder

from emonav_drake.core.metrics import EpisodeRecord
from emonav_drake.core.scenario import Scenario
from emonav_drake.diagrams.digit_station import AddDigitStation, DigitStation
from emonav_drake.diagrams.meshcat_viewing import ReplayCaption, make_meshcat, write_replay_html
from emonav_drake.diagrams.navigation import AddNavigationStack
from emonav_drake.diagrams.rates import RateMeasurement
from emonav_drake.params import EmoNavConfig
from emonav_drake.perception.noisy_emotions import EmotionEstimateParams
from emonav_drake.planners.protocol import Planner
from emonav_drake.progress import SimulationProgress
from emonav_drake.systems.crowd_system import CrowdSystem
from emonav_drake.systems.episode_monitor import EpisodeMonitor
from emonav_drake.systems.fall_monitor import FALL
from emonav_drake.systems.head_camera import body_camera_mount
from emonav_drake.systems.navigation_meshcat import NavigationMeshcatVisualizer
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
    """
    config.validate()
    scenario.validate()
    b = DiagramBuilder()
    pose = (*(float(v) for v in scenario.robot_start), float(scenario.robot_heading))
    station = AddDigitStation(b, config, pose=pose)
    robot_state = station.GetOutputPort("robot_state")
    mount = None
    if emotion_estimate is not None and emotion_estimate.mode == "camera":
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
        from emonav_drake.diagrams.camera_perception import draw_in_meshcat

        MeshcatVisualizer.AddToBuilder(
            b,
            station.GetOutputPort("query_object"),
            meshcat,
            MeshcatVisualizerParams(role=Role.kIllustration),
        )
        vis = b.AddNamedSystem(
            "navigation_visualizer",
            NavigationMeshcatVisualizer(
                meshcat,
                scenario,
                config,
                draw_robot=False,
                goal_radius=goal_radius,
                **draw_in_meshcat(b, stack.perception, meshcat),
            ),
        )
        b.Connect(robot_state, vis.GetInputPort("robot_state"))
        b.Connect(crowd.GetOutputPort("crowd"), vis.GetInputPort("crowd"))
        b.Connect(station.GetOutputPort("targets"), vis.GetInputPort("footstep_targets"))
        if stack.tracker is not None:  # the crowd the planner reads, beside the true one
            b.Connect(stack.tracker.GetOutputPort("crowd"), vis.GetInputPort("tracks"))
    diagram = b.Build()
    diagram.set_name("emonav_navigation_digit")
    return DigitNavigationDiagram(diagram, station, crowd, nav, monitor)


def run_digit_episode(
    scenario: Scenario,
    config: EmoNavConfig,
    planner: Planner,
    meshcat: Meshcat | None = None,
    grid_kind: str = "lgm",
    goal_radius: float | None = None,
    realtime_rate: float = 0.0,
    record_html: str | Path | None = None,
    rates: RateMeasurement | None = None,
    trace: list[dict] | None = None,
    progress: bool = False,
    emotion_estimate: EmotionEstimateParams | None = None,
    camera_frames: list | None = None,
) -> EpisodeRecord:
    """Simulate one navigation episode with the full-order Digit; returns its record
    (outcome success | collision | timeout | fall). `emotion_estimate`: where the
    perceived emotions come from (default the ground truth; `build_navigation_diagram`);
    `camera_frames` collects the camera's classified images (`AddNavigationStack`).

    With `rates`, the simulation runs under the profiler of `diagrams.rates` and the
    per-system rates and wall-time shares are left in `rates.report`. With `trace`, the
    robot state and held command at every planner instant are appended to it
    (`simulate_digit_episode`). With `progress`, a progress bar on stderr follows the
    simulated time (`SimulationProgress`; the record does not change)."""
    if record_html is not None and meshcat is None:
        meshcat = make_meshcat(live=False)  # loopback only
    nd = build_digit_navigation_diagram(
        scenario, config, planner, meshcat, grid_kind, goal_radius, emotion_estimate, camera_frames
    )
    sim = Simulator(nd.diagram)
    sim.set_target_realtime_rate(realtime_rate)
    if record_html is not None:
        # a browser already watching sees the episode while it is recorded
        live = meshcat.GetNumActiveConnections() > 0
        meshcat.StartRecording(set_visualizations_while_recording=live)
    if rates is not None:
        record = rates.run(
            sim, nd.diagram, lambda: simulate_digit_episode(sim, nd, config, trace, progress)
        )
    else:
        record = simulate_digit_episode(sim, nd, config, trace, progress)
    if record_html is not None:
        meshcat.StopRecording()
        meshcat.PublishRecording()
        tracks = config.perception.state_source == "lidar"
        caption = ReplayCaption.for_episode(
            planner, "Digit", scenario, record, footsteps=True, tracks=tracks
        )
        write_replay_html(meshcat, record_html, caption)
    return record


def simulate_digit_episode(
    sim: Simulator,
    nd: DigitNavigationDiagram,
    config: EmoNavConfig,
    trace: list[dict] | None = None,
    progress: bool = False,
) -> EpisodeRecord:
    """Run `sim` (built on `nd`, its context at the episode's start) walking step by
    walking step until the episode monitor ends the episode or the robot falls.

    With `trace`, one entry per planner instant t_k = kT is appended, taken before the
    updates at t_k (what the planner sees): {"k", "t" [s], "robot": [x, y, θ, v] (CoM
    [m], torso yaw [rad], sagittal CoM speed [m/s], world frame W), "held": the command
    held since t_{k−1}, u_{k−1} = [u_v, u_Δθ], "pedestrians": [[x, y], ...] (world [m]),
    "emotions": [code, ...] (true emotion codes in force)}; the last entry is the
    episode's end. With `progress`, a `SimulationProgress` bar on stderr is updated after
    every walking step and ended with the outcome (it only reads the time: the record is
    the same)."""
    ctx = sim.get_mutable_context()
    T = config.robot.step_time
    sim.Initialize()
    bar = SimulationProgress(config.episode.max_steps * T, "Digit episode", progress)
    try:
        record = _walk_episode(sim, nd, T, trace, bar)
    except BaseException:  # Ctrl-C included: end the bar's line
        bar.close(ctx.get_time())
        raise
    bar.close(ctx.get_time(), record.outcome)
    return record


def _walk_episode(
    sim: Simulator,
    nd: DigitNavigationDiagram,
    T: float,
    trace: list[dict] | None,
    bar: SimulationProgress,
) -> EpisodeRecord:
    """The loop of `simulate_digit_episode`: one `AdvanceTo` per walking step."""
    ctx = sim.get_mutable_context()
    status_port = nd.monitor.GetOutputPort("status")
    fall_port = nd.station.GetOutputPort("fall")
    robot_port = nd.station.GetOutputPort("robot_state")
    command_port = nd.planner.GetOutputPort("command")
    crowd_port = nd.crowd.GetOutputPort("crowd")
    k = round(ctx.get_time() / T)
    while True:
        if trace is not None:
            crowd = crowd_port.Eval(nd.crowd.GetMyContextFromRoot(ctx))
            trace.append(
                {
                    "k": k,
                    "t": ctx.get_time(),
                    "robot": robot_port.Eval(nd.station.GetMyContextFromRoot(ctx)).tolist(),
                    "held": command_port.Eval(nd.planner.GetMyContextFromRoot(ctx)).tolist(),
                    "pedestrians": crowd.positions.tolist(),
                    "emotions": [int(e) for e in crowd.emotions],
                }
            )
        status = status_port.Eval(nd.monitor.GetMyContextFromRoot(ctx))
        fall = fall_port.Eval(nd.station.GetMyContextFromRoot(ctx))
        if fall.fallen:
            record = status.record
            record.outcome, record.fall_reason = FALL, fall.reason
            return record
        if status.done:
            return status.record
        k += 1
        try:
            sim.AdvanceTo(k * T)
        except RuntimeError as e:  # the contact solver gives up only on a robot in a heap
            record = status_port.Eval(nd.monitor.GetMyContextFromRoot(ctx)).record
            record.outcome, record.fall_reason = FALL, f"simulation stopped: {e}"
            return record
        bar.update(ctx.get_time())
