"""The walking diagram: full-order Digit + ALIP footstep planner + passivity controller.

    ┌──────────────────────┐ command ┌──────────────────────┐ targets ┌─────────────────┐
    │ WalkingCommandSource ├────────►│ AlipFootstepPlanner  ├────────►│ Passivity-      │
    │ (per step)           │◄────────┤ (phase, ALIP, 200 Hz)│         │ Controller 1 kHz│
    └──────────────────────┘next_step└──────────▲───────────┘         └───────┬─────────┘
                                                │ state                       │ actuation
                                     ┌──────────┴───────────┐◄────────────────┘
                                     │ Digit MultibodyPlant │ (SAP, 1 ms) ──► Meshcat
                                     └──────────────────────┘

`build_walking_diagram` wires it; `run_walk` simulates it and returns the issue's JSON
fields. A fall — the torso origin below `fall_height` or any body but a foot touching the
ground — ends the run with `fell = True`; it is an outcome, never an exception.
"""

from __future__ import annotations

import dataclasses as dc
import logging
import math
import time
from pathlib import Path

import numpy as np
from pydrake.geometry import Meshcat, MeshcatVisualizer, MeshcatVisualizerParams, Role
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import Diagram, DiagramBuilder

from emonav_drake.core.lip import LipState, lip_step, wrap_angle
from emonav_drake.params import EmoNavConfig, load_config
from emonav_drake.systems.alip_footstep_planner import T_SWYAW0, T_SWYAW1, AlipFootstepPlanner
from emonav_drake.systems.digit_plant import AddDigitPlant, DigitModel, standing_state
from emonav_drake.systems.passivity_controller import PassivityController
from emonav_drake.systems.walking_command_source import WalkingCommandSource, command_sequence

log = logging.getLogger(__name__)


@dc.dataclass
class WalkingDiagram:
    """The built diagram and handles to its systems."""

    diagram: Diagram
    model: DigitModel
    planner: AlipFootstepPlanner
    controller: PassivityController
    commands: WalkingCommandSource
    com_height: float
    initial_state: np.ndarray


def standing_com_height(model: DigitModel) -> float:
    """CoM height of the standing pose [m] — the ALIP's H for this model."""
    ctx = model.plant.CreateDefaultContext()
    model.plant.SetPositionsAndVelocities(ctx, standing_state(model))
    return float(model.plant.CalcCenterOfMassPositionInWorld(ctx)[2])


def build_walking_diagram(
    config: EmoNavConfig,
    commands: np.ndarray,
    meshcat: Meshcat | None = None,
    record_timing: bool = False,
) -> WalkingDiagram:
    """Wire plant, planner, controller and command source (+ Meshcat).

    Args:
        config: the project configuration (`config.walking`, `config.robot`).
        commands: (N, 2) per-step commands (`command_sequence`).
        meshcat: draw the robot into this Meshcat when given.
        record_timing: keep the controller's per-tick durations.
    """
    config.validate()
    wp = config.walking
    b = DiagramBuilder()
    model = AddDigitPlant(b, wp)
    H = standing_com_height(model)
    planner = b.AddNamedSystem("planner", AlipFootstepPlanner(model, wp, config.robot, H))
    controller = b.AddNamedSystem(
        "controller", PassivityController(model, wp, record_timing=record_timing)
    )
    source = b.AddNamedSystem("commands", WalkingCommandSource(commands))
    plant = model.plant
    b.Connect(plant.get_state_output_port(), planner.GetInputPort("state"))
    b.Connect(plant.get_state_output_port(), controller.GetInputPort("state"))
    b.Connect(planner.GetOutputPort("targets"), controller.GetInputPort("targets"))
    b.Connect(planner.GetOutputPort("next_step"), source.GetInputPort("next_step"))
    b.Connect(source.GetOutputPort("command"), planner.GetInputPort("command"))
    b.Connect(controller.GetOutputPort("actuation"), plant.get_actuation_input_port())
    if meshcat is not None:
        MeshcatVisualizer.AddToBuilder(
            b, model.scene_graph, meshcat, MeshcatVisualizerParams(role=Role.kIllustration)
        )
    diagram = b.Build()
    return WalkingDiagram(diagram, model, planner, controller, source, H, standing_state(model))


@dc.dataclass
class StepRecord:
    """One foot switch: the measured state and the command of the step it starts."""

    time: float
    x: float  # CoM [m]
    y: float
    heading: float  # torso yaw [rad]
    speed: float  # sagittal CoM speed [m/s]
    u_speed: float
    u_heading: float
    heading_target: float
    predicted: list[float]  # ALIP mid-step prediction of the end (x_s, x_l, ℒ_s, ℒ_l)
    measured: list[float]  # the measured end state (x_s, x_l, ℒ_s, ℒ_l)
    swing_yaw: tuple[float, float]  # the new swing foot's yaw at lift-off and its target


@dc.dataclass
class WalkResult:
    """What `run_walk` measured; `to_json` gives the issue's JSON fields."""

    fell: bool
    fall_reason: str
    sim_seconds: float
    wall_seconds: float
    total_mass: float
    num_positions: int
    num_actuators: int
    mean_forward_speed: float
    tracking_rms: dict
    seed: int
    steps: list[StepRecord]
    com_height: float
    clipped_commands: int
    tick_seconds: list[float] = dc.field(default_factory=list)

    @property
    def real_time_factor(self) -> float:
        return self.sim_seconds / self.wall_seconds if self.wall_seconds > 0 else float("inf")

    def to_json(self) -> dict:
        return {
            "fell": self.fell,
            "fall_reason": self.fall_reason,
            "sim_seconds": round(self.sim_seconds, 4),
            "wall_seconds": round(self.wall_seconds, 3),
            "real_time_factor": round(self.real_time_factor, 3),
            "total_mass": round(self.total_mass, 3),
            "num_positions": self.num_positions,
            "num_actuators": self.num_actuators,
            "mean_forward_speed": round(self.mean_forward_speed, 4),
            "tracking_rms": {k: round(v, 5) for k, v in self.tracking_rms.items()},
            "seed": self.seed,
            "steps": len(self.steps),
            "com_height": round(self.com_height, 4),
            "clipped_commands": self.clipped_commands,
            # torso yaw at the last foot switch and the heading it was commanded to reach
            "final_heading": round(self.steps[-1].heading, 4) if self.steps else 0.0,
            "commanded_heading": (
                round(self.steps[-1].heading_target - self.steps[-1].u_heading, 4)
                if self.steps
                else 0.0
            ),
        }


def tracking_table(steps: list[StepRecord], omega: float, step_time: float) -> np.ndarray:
    """Per step k ≥ 1: desired vs actual state at switch k. Columns: t, x_d, y_d, θ_d, x, y, θ.

    Desired = the LIP step of paper Eq. 1 from the measured CoM position and sagittal speed
    at switch k−1, walked along the commanded heading with that step's command; θ_d is the
    accumulated commanded heading (so heading errors do not reset each step)."""
    rows = []
    for a, b in zip(steps[:-1], steps[1:], strict=False):
        # the step from a to b walks along the new heading a.heading_target
        start = LipState(a.x, a.y, a.heading_target - a.u_heading, a.speed)
        d = lip_step(start, a.u_speed, a.u_heading, omega, step_time)
        rows.append([b.time, d.x, d.y, d.heading, b.x, b.y, b.heading])
    return np.array(rows).reshape(-1, 7)


def tracking_rms(table: np.ndarray) -> dict:
    """RMS of actual − desired in x, y [m] and heading [rad] over the steps."""
    if len(table) == 0:
        return {"x": float("nan"), "y": float("nan"), "heading": float("nan")}
    dth = np.array([wrap_angle(a - b) for a, b in zip(table[:, 6], table[:, 3], strict=True)])
    return {
        "x": float(np.sqrt(np.mean((table[:, 4] - table[:, 1]) ** 2))),
        "y": float(np.sqrt(np.mean((table[:, 5] - table[:, 2]) ** 2))),
        "heading": float(np.sqrt(np.mean(dth**2))),
    }


def run_walk(
    seconds: float,
    seed: int = 0,
    command: str = "random",
    config: EmoNavConfig | None = None,
    meshcat: Meshcat | None = None,
    record_html: str | Path | None = None,
    realtime_rate: float = 0.0,
    record_timing: bool = False,
    speed: float | None = None,
    heading_change: float | None = None,
    script: list[tuple[float, float]] | None = None,
    push: tuple[float, float, float] | None = None,
) -> WalkResult:
    """Simulate Digit walking for `seconds` [s] under a command mode; never raises on a fall.

    Args:
        seconds: simulated time after t = 0 (the first `stand_time` is standing).
        seed: the random command sequence's seed.
        command: "random", "straight", "turn", "stand" or "scripted".
        config: project configuration; default `load_config()`.
        meshcat: draw into this Meshcat; `record_html` writes a self-contained replay.
        realtime_rate: 1.0 to watch live; 0 runs as fast as possible.
        record_timing: keep the controller tick durations in the result.
        speed, heading_change, script: see `command_sequence`.
        push: an initial torso velocity v_WT [m/s] (world), e.g. to provoke a fall.
    """
    cfg = config if config is not None else load_config()
    if command == "stand":
        cfg = dc.replace(cfg, walking=dc.replace(cfg.walking, stand_time=seconds + 1.0))
    wp = cfg.walking
    n_steps = int(seconds / wp.step_time) + 10
    seq = command_sequence(
        command,
        n_steps,
        cfg.robot,
        seed,
        speed=speed,
        heading_change=heading_change,
        script=script,
    )
    if record_html is not None and meshcat is None:
        meshcat = Meshcat()
    wd = build_walking_diagram(cfg, seq, meshcat=meshcat, record_timing=record_timing)
    plant = wd.model.plant
    sim = Simulator(wd.diagram)
    ctx = sim.get_mutable_context()
    plant_ctx = plant.GetMyMutableContextFromRoot(ctx)
    x0 = wd.initial_state.copy()
    if push is not None:
        x0[plant.num_positions() + wd.model.base_v[3:]] = push
    plant.SetPositionsAndVelocities(plant_ctx, x0)
    planner_ctx = wd.planner.GetMyContextFromRoot(ctx)
    log_port = wd.planner.GetOutputPort("step_log")
    torso_q = wd.model.base_q[6]
    non_foot = wd.model.non_foot_bodies
    fall = {"reason": ""}
    steps: list[StepRecord] = []
    last = {"count": 0.0}
    count_port = wd.planner.GetOutputPort("next_step")
    targets_port = wd.planner.GetOutputPort("targets")

    def check() -> str:
        """Fall reason ('' if none); also records a new step from the planner's log."""
        q = plant.GetPositions(plant_ctx)
        if not np.all(np.isfinite(q)):
            return "non-finite state"
        if q[torso_q] < wp.fall_height:
            return f"torso at {q[torso_q]:.3f} m"
        contacts = plant.get_contact_results_output_port().Eval(plant_ctx)
        for i in range(contacts.num_point_pair_contacts()):
            info = contacts.point_pair_contact_info(i)
            for bi in (info.bodyA_index(), info.bodyB_index()):
                if int(bi) in non_foot:
                    return f"{plant.get_body(bi).name()} touched the ground"
        c = count_port.Eval(planner_ctx)[0]
        if c != last["count"]:
            last["count"] = c
            r = log_port.Eval(planner_ctx)
            tg = targets_port.Eval(planner_ctx)
            steps.append(
                StepRecord(
                    *[float(v) for v in r[:8]],
                    [float(v) for v in r[8:12]],
                    [float(v) for v in r[12:16]],
                    (float(tg[T_SWYAW0]), float(tg[T_SWYAW1])),
                )
            )
        return ""

    sim.set_target_realtime_rate(realtime_rate)
    if meshcat is not None and record_html is not None:
        meshcat.StartRecording(set_visualizations_while_recording=False)
    sim.Initialize()
    # Advance in chunks of the planner period (5 ms) and check for a fall in between:
    # cheaper than a per-tick monitor, and a fall is caught within one chunk.
    chunk = wp.planner_period
    n_chunks = int(math.ceil(seconds / chunk - 1e-9))
    t0 = time.perf_counter()
    for k in range(1, n_chunks + 1):
        try:
            sim.AdvanceTo(min(k * chunk, seconds))
        except RuntimeError as e:  # a solver failure after a fall is still a fall
            fall["reason"] = f"simulation stopped: {e}"
            break
        fall["reason"] = check()
        if fall["reason"]:
            break
    wall = time.perf_counter() - t0
    t_end = ctx.get_time()
    if meshcat is not None and record_html is not None:
        meshcat.StopRecording()
        meshcat.PublishRecording()
        Path(record_html).write_text(meshcat.StaticHtml())
    omega = math.sqrt(cfg.robot.gravity / wd.com_height)
    table = tracking_table(steps, omega, wp.step_time)
    return WalkResult(
        fell=bool(fall["reason"]),
        fall_reason=fall["reason"],
        sim_seconds=t_end,
        wall_seconds=wall,
        total_mass=wd.model.total_mass,
        num_positions=plant.num_positions(),
        num_actuators=plant.num_actuators(),
        mean_forward_speed=mean_forward_speed(steps),
        tracking_rms=tracking_rms(table),
        seed=seed,
        steps=steps,
        com_height=wd.com_height,
        clipped_commands=wd.planner.clipped_commands(planner_ctx),
        tick_seconds=list(wd.controller.tick_seconds),
    )


def mean_forward_speed(steps: list[StepRecord]) -> float:
    """Mean CoM speed along the walking heading from the first to the last switch [m/s]."""
    if len(steps) < 3:
        return 0.0
    dist = 0.0
    for a, b in zip(steps[1:-1], steps[2:], strict=False):
        th = a.heading_target
        dist += (b.x - a.x) * math.cos(th) + (b.y - a.y) * math.sin(th)
    return dist / (steps[-1].time - steps[1].time)
