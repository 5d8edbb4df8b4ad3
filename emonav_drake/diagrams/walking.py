"""The walking diagram: the Digit station driven by a per-step command source.

    ┌──────────────────────┐ command  ┌──────────────────────────────────────────┐
    │ WalkingCommandSource ├─────────►│ DigitStation: ALIP footstep planner,     │
    │ (per step)           │◄─────────┤ passivity controller, Digit plant, CoM   │──► Meshcat
    └──────────────────────┘ next_step│ state, fall monitor                      │
                                      └──────────────────────────────────────────┘

`build_walking_diagram` wires it; `run_walk` simulates it and returns the issue's JSON
fields (with `progress=True`, under a progress bar over simulated time). A fall — detected
by the station's `FallMonitor` (non-finite state, torso below `walking.fall_height`, or
any body but a foot touching the ground, checked every `walking.fall_check_period`) —
ends the run with the outcome "fall"; it is an outcome, never an exception.
"""

from __future__ import annotations

import dataclasses as dc
import logging
import math
import time
from pathlib import Path

import numpy as np
from pydrake.geometry import Meshcat, MeshcatVisualizer, MeshcatVisualizerParams, Role
from pydrake.systems.analysis import Simulator, SimulatorStatus
from pydrake.systems.framework import Context, Diagram, DiagramBuilder
from pydrake.systems.primitives import LogVectorOutput, VectorLogSink

from emonav_drake.diagrams.digit_station import AddDigitStation, DigitStation
from emonav_drake.diagrams.meshcat_viewing import make_meshcat
from emonav_drake.params import EmoNavConfig, load_config, pendulum_frequency
from emonav_drake.progress import SimulationProgress
from emonav_drake.robot.lip import wrap_angle
from emonav_drake.robot.tracking import COLUMNS as TRACKING_COLUMNS
from emonav_drake.robot.tracking import column as tracking_column
from emonav_drake.robot.tracking import step_tracking
from emonav_drake.systems.alip_footstep_planner import (
    LOG_COM,
    LOG_COMMAND,
    LOG_HEADING_TARGET,
    LOG_MEASURED,
    LOG_PREDICTED,
    LOG_SPEED,
    LOG_SWING_YAW,
    LOG_TIME,
    LOG_YAW,
)
from emonav_drake.systems.fall_monitor import FALL
from emonav_drake.systems.walking_command_source import WalkingCommandSource, command_sequence

log = logging.getLogger(__name__)

# The longest walk `run_walk` simulates [s]: one simulated hour. The walk runs at about real
# time on one core and its step logs keep ~2 MB per simulated minute (~120 MB at this
# bound); the per-step command sequence is allocated up front (16 B per 0.4 s step).
MAX_WALK_SECONDS = 3600.0

# With a progress bar, `run_walk` advances the simulator in chunks of this much simulated
# time [s] and updates the bar after each (the trajectory is the same: tests/test_walking.py).
PROGRESS_CHUNK = 0.5


@dc.dataclass
class WalkingDiagram:
    """The built diagram and handles to its systems."""

    diagram: Diagram
    station: DigitStation
    commands: WalkingCommandSource
    step_logger: VectorLogSink
    count_logger: VectorLogSink

    @property
    def com_height(self) -> float:
        return self.station.com_height


def build_walking_diagram(
    config: EmoNavConfig,
    commands: np.ndarray,
    meshcat: Meshcat | None = None,
    record_timing: bool = False,
) -> WalkingDiagram:
    """Wire the Digit station, the command source, step loggers (+ Meshcat).

    Args:
        config: the project configuration (`config.walking`, `config.robot`).
        commands: (N, 2) per-step commands (`command_sequence`).
        meshcat: draw the robot into this Meshcat when given.
        record_timing: keep the controller's per-tick durations.
    """
    b = DiagramBuilder()
    station = AddDigitStation(b, config, record_timing=record_timing)
    source = b.AddNamedSystem("commands", WalkingCommandSource(commands))
    b.Connect(station.GetOutputPort("next_step"), source.GetInputPort("next_step"))
    b.Connect(source.GetOutputPort("command"), station.GetInputPort("command"))
    # A switch happens at a footstep-planner update and lasts at least half a step, so
    # logging at the planner's rate sees every one.
    period = config.walking.planner_period
    steps = LogVectorOutput(station.GetOutputPort("step_log"), b, period)
    counts = LogVectorOutput(station.GetOutputPort("next_step"), b, period)
    if meshcat is not None:
        MeshcatVisualizer.AddToBuilder(
            b,
            station.GetOutputPort("query_object"),
            meshcat,
            MeshcatVisualizerParams(role=Role.kIllustration),
        )
    diagram = b.Build()
    diagram.set_name("emonav_walking")
    return WalkingDiagram(diagram, station, source, steps, counts)


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

    @property
    def outcome(self) -> str:
        """ "fall" or "walked"."""
        return FALL if self.fell else "walked"

    def tracking(self, config: EmoNavConfig) -> np.ndarray:
        """The per-step tracking table of this walk (`walk_tracking`, `robot.tracking.COLUMNS`)
        with this robot's ω = √(g/H) [1/s] and T [s] of `config.robot`."""
        omega = pendulum_frequency(self.com_height, config.robot.gravity)
        return walk_tracking(self.steps, omega, config.robot.step_time)

    def to_json(self) -> dict:
        return {
            "outcome": self.outcome,
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


def walk_tracking(steps: list[StepRecord], omega: float, step_time: float) -> np.ndarray:
    """The per-step tracking table of a walk (`robot.tracking.COLUMNS`), one row per step
    between consecutive foot switches k → k + 1.

    Desired = the LIP step of paper Eq. 1 from the measured CoM position and sagittal speed
    at switch k, walked along the accumulated commanded heading with step k's command
    (so heading errors do not reset each step); achieved = the measured CoM and the
    (unwrapped) torso yaw at switch k + 1. ω [1/s] is the walking robot's √(g/H)."""
    if len(steps) < 2:
        return np.empty((0, len(TRACKING_COLUMNS)))
    a, b = steps[:-1], steps[1:]
    commands = np.array([[s.u_speed, s.u_heading] for s in a])
    return step_tracking(
        [[s.x, s.y, s.heading_target - s.u_heading, s.speed] for s in a],
        commands,
        [[s.x, s.y, s.heading] for s in b],
        omega,
        step_time,
        t_start=[s.time for s in a],
        t=[s.time for s in b],
        previous=np.vstack([np.zeros((1, 2)), commands[:-1]]),
    )


def tracking_table(steps: list[StepRecord], omega: float, step_time: float) -> np.ndarray:
    """Per step k ≥ 1: desired vs actual state at switch k. Columns: t, x_d, y_d, θ_d, x, y, θ.

    Desired = the LIP step of paper Eq. 1 from the measured CoM position and sagittal speed
    at switch k−1, walked along the commanded heading with that step's command; θ_d is the
    accumulated commanded heading (so heading errors do not reset each step; not
    wrapped). The full per-step table is `walk_tracking`."""
    names = ("t", "x_des", "y_des", "heading_des", "x", "y", "heading")
    table = walk_tracking(steps, omega, step_time)
    return np.column_stack([tracking_column(table, n) for n in names]).reshape(-1, 7)


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
    progress: bool = False,
) -> WalkResult:
    """Simulate Digit walking for `seconds` [s] under a command mode; never raises on a fall.

    Args:
        seconds: simulated time after t = 0 (the first `stand_time` is standing), in
            (0, `MAX_WALK_SECONDS`].
        seed: the random command sequence's seed.
        command: "random", "straight", "turn", "stand" or "scripted".
        config: project configuration; default `load_config()`.
        meshcat: draw into this Meshcat; `record_html` writes a self-contained replay.
        realtime_rate: 1.0 to watch live; 0 runs as fast as possible.
        record_timing: keep the controller tick durations in the result.
        speed, heading_change, script: see `command_sequence`.
        push: an initial torso velocity v_WT [m/s] (world), e.g. to provoke a fall.
        progress: show a progress bar over simulated time on stderr (`SimulationProgress`):
            the simulator then advances in chunks of `PROGRESS_CHUNK`, which changes no
            result.
    """
    cfg, seq = _walk_commands(seconds, seed, command, config, speed, heading_change, script)
    if record_html is not None and meshcat is None:
        meshcat = make_meshcat(live=False)  # loopback only
    wd = build_walking_diagram(cfg, seq, meshcat=meshcat, record_timing=record_timing)
    station = wd.station
    sim = Simulator(wd.diagram)  # the default context stands still
    ctx = sim.get_mutable_context()
    if push is not None:
        _push_torso(station, ctx, push)
    sim.set_target_realtime_rate(realtime_rate)
    if meshcat is not None and record_html is not None:
        # a browser already watching sees the walk while it is recorded
        live = meshcat.GetNumActiveConnections() > 0
        meshcat.StartRecording(set_visualizations_while_recording=live)
    t0 = time.perf_counter()
    bar = SimulationProgress(seconds, "walk", progress)
    reason = _simulate_walk(sim, seconds, bar)
    wall = time.perf_counter() - t0
    t_end = ctx.get_time()
    fall = station.GetOutputPort("fall").Eval(station.GetMyContextFromRoot(ctx))
    reason = fall.reason if fall.fallen else reason
    bar.close(t_end, f"{FALL} ({reason})" if reason else "walked")
    if meshcat is not None and record_html is not None:
        meshcat.StopRecording()
        meshcat.PublishRecording()
        Path(record_html).write_text(meshcat.StaticHtml())
    return _walk_result(wd, ctx, cfg, seed, reason, t_end, wall)


def _walk_commands(
    seconds: float,
    seed: int,
    command: str,
    config: EmoNavConfig | None,
    speed: float | None,
    heading_change: float | None,
    script: list[tuple[float, float]] | None,
) -> tuple[EmoNavConfig, np.ndarray]:
    """`seconds` checked; the walk's configuration (standing throughout for "stand") and
    its per-step command sequence (`command_sequence`, ten steps beyond the end)."""
    if not (math.isfinite(seconds) and 0 < seconds <= MAX_WALK_SECONDS):
        raise ValueError(f"seconds must be in (0, {MAX_WALK_SECONDS:g}], got {seconds}")
    cfg = config if config is not None else load_config()
    if command == "stand":
        cfg = dc.replace(cfg, walking=dc.replace(cfg.walking, stand_time=seconds + 1.0))
    n_steps = int(seconds / cfg.robot.step_time) + 10
    seq = command_sequence(
        command,
        n_steps,
        cfg.robot,
        seed,
        speed=speed,
        heading_change=heading_change,
        script=script,
    )
    return cfg, seq


def _push_torso(
    station: DigitStation, root_context: Context, push: tuple[float, float, float]
) -> None:
    """Set the torso's initial translational velocity v_WT [m/s] (world) to `push`."""
    plant = station.plant
    plant_ctx = plant.GetMyMutableContextFromRoot(root_context)
    v = plant.GetVelocities(plant_ctx).copy()
    v[station.model.base_v[3:]] = push
    plant.SetVelocities(plant_ctx, v)


def _simulate_walk(sim: Simulator, seconds: float, bar: SimulationProgress) -> str:
    """Initialize and advance `sim` to `seconds` (in chunks with an enabled `bar`); "" or,
    when the solver stopped the simulation, why (a failure after a fall is still a fall)."""
    try:
        sim.Initialize()
        if bar.enabled:
            _advance_in_chunks(sim, seconds, bar)
        else:
            sim.AdvanceTo(seconds)
    except RuntimeError as e:  # a solver failure after a fall is still a fall
        return f"simulation stopped: {e}"
    except BaseException:  # Ctrl-C included: end the bar's line
        bar.close(sim.get_context().get_time())
        raise
    return ""


def _walk_result(
    wd: WalkingDiagram,
    root_context: Context,
    cfg: EmoNavConfig,
    seed: int,
    reason: str,
    t_end: float,
    wall: float,
) -> WalkResult:
    """The `WalkResult` of a simulated walk: its foot switches, tracking and counters
    (`reason`: why it fell, "" if it did not)."""
    station = wd.station
    plant = station.plant
    steps = step_records(wd, root_context)
    omega = pendulum_frequency(station.com_height, cfg.robot.gravity)
    table = tracking_table(steps, omega, cfg.robot.step_time)
    planner_ctx = station.planner.GetMyContextFromRoot(root_context)
    return WalkResult(
        fell=bool(reason),
        fall_reason=reason,
        sim_seconds=t_end,
        wall_seconds=wall,
        total_mass=station.model.total_mass,
        num_positions=plant.num_positions(),
        num_actuators=plant.num_actuators(),
        mean_forward_speed=mean_forward_speed(steps),
        tracking_rms=tracking_rms(table),
        seed=seed,
        steps=steps,
        com_height=station.com_height,
        clipped_commands=station.planner.clipped_commands(planner_ctx),
        tick_seconds=list(station.controller.tick_seconds),
    )


def _advance_in_chunks(sim: Simulator, seconds: float, bar: SimulationProgress) -> None:
    """`sim.AdvanceTo(seconds)` in chunks of `PROGRESS_CHUNK` simulated seconds, updating
    `bar` after each; stops where the simulation stops (a fall's termination event)."""
    k = 0
    while True:
        k += 1
        boundary = min(k * PROGRESS_CHUNK, seconds)
        status = sim.AdvanceTo(boundary)
        bar.update(sim.get_context().get_time())
        reached = status.reason() == SimulatorStatus.ReturnReason.kReachedBoundaryTime
        if not reached or boundary >= seconds:
            return


def step_records(wd: WalkingDiagram, root_context) -> list[StepRecord]:
    """Every foot switch of a simulated walk, from the step loggers in `root_context`."""
    logs = wd.step_logger.FindLog(root_context).data()
    counts = wd.count_logger.FindLog(root_context).data()[0]
    # one record per switch: the step's last sample, which holds the command the step
    # took up just after it started (the switch's sample still shows the previous one)
    last_of_step = [
        k for k in range(len(counts)) if k + 1 == len(counts) or counts[k + 1] != counts[k]
    ]
    steps: list[StepRecord] = []
    for k in last_of_step:
        if counts[k] == 0:
            continue
        r = logs[:, k].tolist()
        steps.append(
            StepRecord(
                time=r[LOG_TIME],
                x=r[LOG_COM][0],
                y=r[LOG_COM][1],
                heading=r[LOG_YAW],
                speed=r[LOG_SPEED],
                u_speed=r[LOG_COMMAND][0],
                u_heading=r[LOG_COMMAND][1],
                heading_target=r[LOG_HEADING_TARGET],
                predicted=r[LOG_PREDICTED],
                measured=r[LOG_MEASURED],
                swing_yaw=tuple(r[LOG_SWING_YAW]),
            )
        )
    return steps


def mean_forward_speed(steps: list[StepRecord]) -> float:
    """Mean CoM speed along the walking heading from the first to the last switch [m/s]."""
    if len(steps) < 3:
        return 0.0
    dist = 0.0
    for a, b in zip(steps[1:-1], steps[2:], strict=False):
        th = a.heading_target
        dist += (b.x - a.x) * math.cos(th) + (b.y - a.y) * math.sin(th)
    return dist / (steps[-1].time - steps[1].time)
