"""The Digit station: the full-order walking robot as one sub-diagram.

    command ──►┌──────────────────────────────────────────────────────────────┐
    (u_v, u_Δθ)│ AlipFootstepPlanner (50 Hz)  ─targets─► PassivityController  │
               │        ▲                       (every plant step) │ torques,  │
               │        │ state                                   ▼ v_r       │
               │ Digit MultibodyPlant (SAP) ──────► DigitComState ────────────┼──► robot_state
               │        └──────────────────────────► FallMonitor ─────────────┼──► fall
               └──────────────────────────────────────────────────────────────┘

Input port:
    command (2): (u_v [m/s], u_Δθ [rad]) for the walking step that starts at the next
        foot switch (read there by the footstep planner; hold it between switches).
Output ports:
    robot_state (4): CoM (x, y) [m] in the world W, torso yaw θ [rad], sagittal CoM speed
        v [m/s] (`DigitComState`).
    fall (abstract `FallStatus`): latched fall detection (`FallMonitor`).
    plant_state (nq + nv): the Digit plant's (q, v).
    targets (abstract `WalkingTargets`): the footstep planner's current targets.
    next_step (1): steps started so far; step_log (N_LOG): the last switch's record.
    actuation (nu): the joint torques [N·m] the plant applies in the step from now, in
        actuator order: the controller's, plus the contact solver's damping of the joints
        in `walking.implicit_damping` (the plant's net actuation; evaluating it solves
        that step's contact problem).
    query_object, contact_results: the scene graph's and the plant's, for visualisers.

The plant's default state is standing still at `pose`, so `Simulator(diagram)` with a
default context starts standing; the footstep planner reads its feet and heading at
initialization. Rates: plant `walking.time_step`, controller `walking.controller_period`,
footstep planner `walking.planner_period`, fall check `walking.fall_check_period`; T and
g from `robot`. `AddDigitStation(builder, config, pose)` adds one to a builder.
"""

from __future__ import annotations

import numpy as np
from pydrake.systems.framework import Diagram, DiagramBuilder

from emonav_drake.params import ConfigError, EmoNavConfig
from emonav_drake.systems.alip_footstep_planner import AlipFootstepPlanner
from emonav_drake.systems.digit_com_state import DigitComState
from emonav_drake.systems.digit_plant import AddDigitPlant, DigitModel, standing_state
from emonav_drake.systems.fall_monitor import FallMonitor
from emonav_drake.systems.passivity_controller import PassivityController


def standing_com_height(model: DigitModel) -> float:
    """CoM height of the standing pose [m] — the ALIP's H for this model."""
    ctx = model.plant.CreateDefaultContext()
    model.plant.SetPositionsAndVelocities(ctx, standing_state(model))
    return float(model.plant.CalcCenterOfMassPositionInWorld(ctx)[2])


def check_digit_config(config: EmoNavConfig) -> None:
    """The Digit gait needs 0.2 s ≤ T ≤ 1 s (the navigation model accepts more)."""
    config.validate()
    T = config.robot.step_time
    if not 0.2 <= T <= 1.0:
        raise ConfigError(
            f"robot.step_time = {T!r} is invalid for the Digit gait: must be in [0.2, 1.0] s"
        )


class DigitStation(Diagram):
    """The walking Digit (see the module docstring).

    Args:
        config: `robot` (T, g, command bounds) and `walking` (gait, gains, rates, model).
        pose: (x [m], y [m], yaw [rad]) of the torso at the start.
        record_timing: keep the controller's per-tick durations (benchmarks).

    Attributes:
        model: the plant and its index maps; planner, controller, com, fall_monitor:
        the systems inside; com_height: the ALIP height H [m].
    """

    def __init__(
        self,
        config: EmoNavConfig,
        pose: tuple[float, float, float] = (0.0, 0.0, 0.0),
        record_timing: bool = False,
    ) -> None:
        super().__init__()
        check_digit_config(config)
        wp = config.walking
        b = DiagramBuilder()
        model = AddDigitPlant(b, wp, gravity=config.robot.gravity, pose=pose)
        H = standing_com_height(model)
        planner = b.AddNamedSystem("alip", AlipFootstepPlanner(model, wp, config.robot, H))
        controller = b.AddNamedSystem(
            "controller", PassivityController(model, wp, record_timing=record_timing)
        )
        com = b.AddNamedSystem("com", DigitComState(model))
        fall = b.AddNamedSystem("fall_monitor", FallMonitor(model, wp))
        plant = model.plant
        for sys in (planner, controller, com, fall):
            b.Connect(plant.get_state_output_port(), sys.GetInputPort("state"))
        b.Connect(model.scene_graph.get_query_output_port(), fall.GetInputPort("geometry_query"))
        b.Connect(planner.GetOutputPort("targets"), controller.GetInputPort("targets"))
        b.Connect(controller.GetOutputPort("actuation"), plant.get_actuation_input_port())
        if model.implicit_legs.any():  # the solver's damping needs the reference velocity
            b.Connect(
                controller.GetOutputPort("desired_state"),
                plant.get_desired_state_input_port(model.instance),
            )
        b.ExportInput(planner.GetInputPort("command"), "command")
        b.ExportOutput(com.GetOutputPort("robot_state"), "robot_state")
        b.ExportOutput(fall.GetOutputPort("fall"), "fall")
        b.ExportOutput(plant.get_state_output_port(), "plant_state")
        b.ExportOutput(planner.GetOutputPort("targets"), "targets")
        b.ExportOutput(planner.GetOutputPort("next_step"), "next_step")
        b.ExportOutput(planner.GetOutputPort("step_log"), "step_log")
        b.ExportOutput(plant.get_net_actuation_output_port(), "actuation")
        b.ExportOutput(model.scene_graph.get_query_output_port(), "query_object")
        b.ExportOutput(plant.get_contact_results_output_port(), "contact_results")
        b.ExportOutput(plant.get_body_poses_output_port(), "body_poses")
        b.BuildInto(self)
        self.set_name("digit_station")
        self.model = model
        self.planner = planner
        self.controller = controller
        self.com = com
        self.fall_monitor = fall
        self.com_height = H

    @property
    def plant(self):
        """The Digit `MultibodyPlant`."""
        return self.model.plant

    def initial_state(self) -> np.ndarray:
        """The plant's default (q, v): standing still at the station's pose."""
        q = self.model.plant.GetDefaultPositions()
        return np.concatenate([q, np.zeros(self.model.plant.num_velocities())])


def AddDigitStation(
    builder: DiagramBuilder,
    config: EmoNavConfig,
    pose: tuple[float, float, float] = (0.0, 0.0, 0.0),
    record_timing: bool = False,
) -> DigitStation:
    """Add a `DigitStation` named "digit" to `builder` and return it."""
    station = builder.AddNamedSystem("digit", DigitStation(config, pose, record_timing))
    return station
