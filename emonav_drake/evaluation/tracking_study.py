"""How well the LiDAR tracker follows the crowd: CLEAR-MOT on LIP episodes.

`config.perception.state_source = "lidar"` gives the state-based planners the crowd as
`systems/crowd_tracker_system.py` estimates it: every scan (10 Hz) is segmented into
discs (`sensing/lidar_objects.py::detect_objects`) and folded into a multi-target tracker
(`sensing/crowd_tracker.py::CrowdTracker`). This module measures that estimate against the
simulator's truth.

**Episodes** (`run_episode`): the fast LIP world (`navigation/lip_world.py::NavigationWorld`,
no map), the robot driven by a planner on the TRUE crowd (by default the MPC), so it
moves as in a real episode whatever the tracker makes of the crowd. The world is stepped
as usual; before each walking step the crowd periods of that step are replayed on a copy
of the crowd state with the robot where `robot_at_substep` has it, exactly as
`NavigationWorld.step` does, and one scan is taken at each period's start — the
`CrowdTrackerSystem`'s timing (a scan at t = j·dt of the robot pose at t and the crowd at
t, before the crowd's update at t). After the walking step the replayed crowd is checked
to be the world's, bit for bit.

Each scan is scored by `evaluation/tracking_evaluator.py` (`EpisodeEvaluator`: the truth,
the tracker's pedestrians, CLEAR-MOT by py-motmetrics, visibility, the causes of misses
and of false pedestrians, the static discs).

`evaluation/tracking_summary.py` pools the episodes: the CLEAR-MOT numbers, the errors,
the causes, the rates by distance and visibility and by the time occluded;
`evaluation/tracking_report.py` draws their figure and writes their tables.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

import numpy as np

from emonav_drake.evaluation.tracking_evaluator import EpisodeEvaluator, EpisodeResult, ScanTruth
from emonav_drake.navigation.lip_world import (
    NavigationWorld,
    check_command,
    robot_at_substep,
    substeps_per_step,
)
from emonav_drake.params import EmoNavConfig
from emonav_drake.robot.lip import lip_velocity
from emonav_drake.scenarios.scenario import Scenario
from emonav_drake.sensing.crowd_tracker import TrackerParams
from emonav_drake.sensing.lidar_objects import DetectionParams


def run_episode(
    scenario: Scenario,
    config: EmoNavConfig,
    planner: Any,
    detection: DetectionParams | None = None,
    tracking: TrackerParams | None = None,
) -> EpisodeResult:
    """One LIP episode of `planner` on the true crowd, with a scan at every crowd period
    (module docstring); returns its `EpisodeResult`."""
    world = NavigationWorld(scenario, config, grid_kind=None)
    ev = EpisodeEvaluator(config, detection, tracking)
    memory = planner.initial_memory()
    crowd_model, dt = world.crowd, config.crowd.dt
    outcome = None
    while outcome is None:
        command, memory = planner.plan_with_memory(world.planner_input(), memory)
        u, _ = check_command(command, config.robot)
        start, crowd = world.robot, world.crowd_state
        for j in range(substeps_per_step(config)):
            seen = robot_at_substep(start, u, j, config)
            xy = np.array([seen.x, seen.y])
            snap = crowd_model.snapshot(crowd)
            ev.observe(
                ScanTruth(
                    time=crowd.substep * dt,
                    robot_xy=xy,
                    heading=seen.heading,
                    ped_positions=crowd.positions,
                    ped_velocities=crowd.velocities,
                    static_centers=crowd_model.static_centers,
                    static_radii=crowd_model.static_radii,
                    wall_segments=crowd_model.wall_segments,
                    gait_phase=snap.gait_phase,
                    facing=snap.facing,
                    seed=snap.seed,
                )
            )
            crowd = crowd_model.step(crowd, xy, lip_velocity(seen))
        _, outcome = world.step(u)
        if not np.array_equal(crowd.positions, world.crowd_state.positions):
            raise RuntimeError(f"seed {scenario.seed}: the replayed crowd left the world's")
    return ev.result(scenario.seed, outcome, world.step_count)


def study(
    seeds: Iterable[int],
    config: EmoNavConfig | None = None,
    detection: DetectionParams | None = None,
    tracking: TrackerParams | None = None,
    planner_name: str = "mpc",
    progress: bool = False,
) -> list[EpisodeResult]:
    """`run_episode` on the scenario `sample_scenario(seed, config)` of each seed."""
    from emonav_drake.planners import make_planner
    from emonav_drake.scenarios.scenario import sample_scenario

    cfg = config or EmoNavConfig()
    planner = make_planner(planner_name, cfg)
    seeds = list(seeds)
    if progress:
        from emonav_drake.progress import progress_bar

        seeds = progress_bar(seeds, desc="tracking episodes", unit="episode")
    return [run_episode(sample_scenario(s, cfg), cfg, planner, detection, tracking) for s in seeds]
