"""Navigation with the full-order Digit: the paper's deployment setting (LIP/Digit, Digit/Digit).

The navigation stack of `diagrams/navigation.py` — crowd, LiDAR grid maps, planner (DWA,
MPC or a learned policy) and episode monitor — around the walking stack of
`diagrams/walking.py` instead of the LIP robot:

    planner ─command─► CommandHold (2.5 Hz) ─► AlipFootstepPlanner ─► PassivityController
       ▲                                           ▲                        │ torques
       │ robot_state, crowd, lgm_stack             │ state                  ▼
    DigitComState ◄──────────── state ──────── Digit MultibodyPlant (SAP, 1 ms)

The robot state the navigation stack sees is Digit's CoM, torso yaw and sagittal CoM
speed (`DigitComState`), so the LIP model's tracking errors reach the crowd, the LGM and
the rewards — the discrepancy the paper studies. A fall (torso below
`walking.fall_height`, or a non-foot body on the ground) ends the episode with outcome
"fall": an outcome, never an exception.
"""

from __future__ import annotations

import dataclasses as dc
import math
from pathlib import Path

import numpy as np
from pydrake.geometry import Meshcat, MeshcatVisualizer, MeshcatVisualizerParams, Role
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import Diagram, DiagramBuilder

from emonav_drake.core.metrics import EpisodeRecord
from emonav_drake.core.scenario import Scenario
from emonav_drake.diagrams.navigation import AddNavigationStack
from emonav_drake.diagrams.walking import standing_com_height
from emonav_drake.params import EmoNavConfig
from emonav_drake.systems.alip_footstep_planner import AlipFootstepPlanner
from emonav_drake.systems.crowd_system import CrowdSystem
from emonav_drake.systems.digit_navigation_bridge import CommandHold, DigitComState
from emonav_drake.systems.digit_plant import AddDigitPlant, DigitModel, standing_state
from emonav_drake.systems.episode_monitor import EpisodeMonitor
from emonav_drake.systems.navigation_meshcat import NavigationMeshcatVisualizer
from emonav_drake.systems.navigation_planner import NavigationPlanner, Planner
from emonav_drake.systems.passivity_controller import PassivityController

FALL = "fall"


@dc.dataclass
class DigitNavigationDiagram:
    diagram: Diagram
    model: DigitModel
    com: DigitComState
    crowd: CrowdSystem
    planner: NavigationPlanner
    monitor: EpisodeMonitor
    initial_state: np.ndarray


def build_digit_navigation_diagram(
    scenario: Scenario,
    config: EmoNavConfig,
    planner: Planner,
    meshcat: Meshcat | None = None,
    grid_kind: str = "lgm",
    goal_radius: float | None = None,
) -> DigitNavigationDiagram:
    """Wire the navigation stack around the full-order Digit for one scenario."""
    config.validate()
    scenario.validate()
    wp = config.walking
    b = DiagramBuilder()
    model = AddDigitPlant(b, wp)
    height = standing_com_height(model)
    alip = b.AddNamedSystem("alip", AlipFootstepPlanner(model, wp, config.robot, height))
    controller = b.AddNamedSystem("controller", PassivityController(model, wp))
    com = b.AddNamedSystem("com", DigitComState(model))
    hold = b.AddNamedSystem("command_hold", CommandHold(config.robot.step_time))
    plant = model.plant
    for sys in (alip, controller, com):
        b.Connect(plant.get_state_output_port(), sys.GetInputPort("state"))
    b.Connect(alip.GetOutputPort("targets"), controller.GetInputPort("targets"))
    b.Connect(controller.GetOutputPort("actuation"), plant.get_actuation_input_port())
    stack = AddNavigationStack(
        b,
        scenario,
        config,
        planner,
        com.GetOutputPort("robot_state"),
        hold.GetOutputPort("command"),
        grid_kind,
        goal_radius,
    )
    crowd, nav, monitor = stack.crowd, stack.planner, stack.monitor
    b.Connect(nav.GetOutputPort("command"), hold.GetInputPort("command"))
    b.Connect(hold.GetOutputPort("command"), alip.GetInputPort("command"))
    if meshcat is not None:
        MeshcatVisualizer.AddToBuilder(
            b, model.scene_graph, meshcat, MeshcatVisualizerParams(role=Role.kIllustration)
        )
        vis = b.AddNamedSystem(
            "navigation_visualizer",
            NavigationMeshcatVisualizer(meshcat, scenario, config, draw_robot=False),
        )
        b.Connect(com.GetOutputPort("robot_state"), vis.GetInputPort("robot_state"))
        b.Connect(crowd.GetOutputPort("crowd"), vis.GetInputPort("crowd"))
    diagram = b.Build()
    x0 = standing_state(model)
    heading = float(scenario.robot_heading)
    x0[model.base_q[:4]] = [math.cos(heading / 2), 0.0, 0.0, math.sin(heading / 2)]
    x0[model.base_q[4:6]] = scenario.robot_start
    return DigitNavigationDiagram(diagram, model, com, crowd, nav, monitor, x0)


def run_digit_episode(
    scenario: Scenario,
    config: EmoNavConfig,
    planner: Planner,
    meshcat: Meshcat | None = None,
    grid_kind: str = "lgm",
    goal_radius: float | None = None,
    realtime_rate: float = 0.0,
    record_html: str | Path | None = None,
) -> EpisodeRecord:
    """Simulate one navigation episode with the full-order Digit; returns its record
    (outcome success | collision | timeout | fall)."""
    if record_html is not None and meshcat is None:
        meshcat = Meshcat()
    planner.reset()
    nd = build_digit_navigation_diagram(scenario, config, planner, meshcat, grid_kind, goal_radius)
    sim = Simulator(nd.diagram)
    sim.set_target_realtime_rate(realtime_rate)
    ctx = sim.get_mutable_context()
    plant = nd.model.plant
    plant_ctx = plant.GetMyMutableContextFromRoot(ctx)
    plant.SetPositionsAndVelocities(plant_ctx, nd.initial_state)
    if record_html is not None:
        meshcat.StartRecording(set_visualizations_while_recording=False)
    sim.Initialize()
    record = _simulate_until_done(sim, nd, config)
    if record_html is not None:
        meshcat.StopRecording()
        meshcat.PublishRecording()
        Path(record_html).write_text(meshcat.StaticHtml())
    return record


def _simulate_until_done(
    sim: Simulator, nd: DigitNavigationDiagram, config: EmoNavConfig
) -> EpisodeRecord:
    """Advance walking step by walking step until the monitor or a fall ends the episode."""
    ctx = sim.get_mutable_context()
    plant = nd.model.plant
    plant_ctx = plant.GetMyMutableContextFromRoot(ctx)
    status_port = nd.monitor.GetOutputPort("status")
    monitor_ctx = nd.monitor.GetMyContextFromRoot(ctx)
    torso_z = nd.model.base_q[6]
    T = config.robot.step_time
    k = 0
    while True:
        status = status_port.Eval(monitor_ctx)
        if status.done:
            return status.record
        q = plant.GetPositions(plant_ctx)
        if not np.all(np.isfinite(q)) or q[torso_z] < config.walking.fall_height:
            record = status.record
            record.outcome = FALL
            return record
        k += 1
        sim.AdvanceTo(k * T)
