"""A planner of your own, outside the package: walk to the goal, slow down near people.

Register it by naming this file on the command line (no edit of emonav_drake):

    emonav sim --planner-module examples/cautious_planner.py --planner cautious --seed 3
    emonav benchmark --planner-module examples/cautious_planner.py --planners cautious,dwa \
        --trials 20 --out runs/cautious
    emonav train --algo dagger --planner-module examples/cautious_planner.py \
        --config my_route.yaml --out runs/student
        # my_route.yaml: `expert: !PlannerSpec {name: cautious}`

or install it as a plug-in: a package whose pyproject.toml has
`[project.entry-points."emonav_drake.planners"]` with `cautious = "my_package.cautious"`.
See docs/howto/planner.md.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from emonav_drake.navigation.lip_world import PlannerInput
from emonav_drake.params import EmoNavConfig
from emonav_drake.planners import PlannerKind, register

SLOW_RADIUS = 1.5  # [m] centre to centre: closer to a pedestrian than this, half speed


class Cautious:
    """Heads for the goal at full speed, half speed within `slow_radius` of a pedestrian.

    It reads the crowd state (`PlannerInput.crowd`: the simulator's, or with
    `--state-source lidar` the LiDAR tracker's) and keeps no memory between steps."""

    name = "cautious"

    def __init__(self, config: EmoNavConfig, slow_radius: float = SLOW_RADIUS) -> None:
        self.slow_radius = slow_radius
        self.max_speed = config.robot.max_speed
        self.max_turn = config.robot.max_heading_change

    def initial_memory(self) -> None:
        return None

    def plan_with_memory(self, obs: PlannerInput, memory: None) -> tuple[np.ndarray, None]:
        _, bearing = obs.goal_state()  # goal distance [m] and bearing [rad], robot frame
        robot = np.array([obs.robot.x, obs.robot.y])
        peds = np.asarray(obs.crowd.positions).reshape(-1, 2)  # world frame [m]
        nearest = float(np.linalg.norm(peds - robot, axis=1).min()) if len(peds) else np.inf
        near = nearest < self.slow_radius
        speed = self.max_speed * (0.5 if near else 1.0)
        turn = float(np.clip(bearing, -self.max_turn, self.max_turn))
        return np.array([speed, turn]), memory

    def reset(self) -> None:
        pass

    def plan(self, obs: PlannerInput) -> np.ndarray:
        return self.plan_with_memory(obs, None)[0]


@dataclass
class CautiousSpec:
    """The registry's spec: `build(config, device)` makes the planner. A spec with a
    `checkpoint` field would run a learned checkpoint (`--checkpoint`); this one has none."""

    slow_radius: float = SLOW_RADIUS  # [m]

    def build(self, config: EmoNavConfig, device: str = "cpu") -> Cautious:
        return Cautious(config, self.slow_radius)


register(PlannerKind("cautious", CautiousSpec(), "goal-seeking, half speed near pedestrians"))
