"""Rewards of the paper's Eq. 6–9, evaluated once per walking step.

    r_k = r_col + r_goal + r_emo

* r_col = −0.6 if d_min^all ≤ r_robot (collision: the robot centre within r_robot of
  any object's surface, or of a wall segment), else −0.1 if d_min^static < d_static +
  r_robot (static discs' surfaces and walls), else 0;
* r_goal = 0.5 if the goal distance ≤ d_goal, else 0.3 (d_{k−1} − d_k);
* r_emo = −0.1 if some pedestrian i has d_i < d_i^emo + r_robot (d_i: robot centre to
  the pedestrian's surface; d_i^emo its emotion's discomfort distance).

The discomfort penalty is counted once per step: when both the static branch of r_col
and r_emo apply, −0.1 is added once (paper §III-E).
"""

from __future__ import annotations

import dataclasses as dc
import math

import numpy as np

from emonav_drake.crowd.crowd import CrowdSnapshot
from emonav_drake.params import EMOTION_NAMES, RewardParams
from emonav_drake.scenarios.walls import point_segment_distances

# Indices of the IDT vector: [static; happy, neutral, negative].
IDT_STATIC = 0


@dc.dataclass(frozen=True)
class StepEvaluation:
    """What one walking step earned and what happened in it."""

    reward: float
    collision: bool
    reached_goal: bool
    in_discomfort: bool  # inside any discomfort zone (static or pedestrian): counts for DT
    idt: tuple[int, int, int, int]  # 1 where inside a zone of [static, happy, neutral, negative]
    min_ped_distance: float  # smallest robot–pedestrian centre distance [m] (inf if none)
    goal_distance: float  # [m]
    collided_with: str = ""  # with a collision: "static", "wall", or the pedestrian's emotion


def evaluate_step(
    robot_xy: np.ndarray,
    goal_xy: np.ndarray,
    prev_goal_distance: float,
    crowd: CrowdSnapshot,
    robot_radius: float,
    goal_radius: float,
    params: RewardParams,
) -> StepEvaluation:
    """Reward and events of the step that ended with the robot at `robot_xy` (world, m)."""
    goal_distance = float(math.hypot(goal_xy[0] - robot_xy[0], goal_xy[1] - robot_xy[1]))
    ped_centre = np.linalg.norm(crowd.positions - robot_xy, axis=1)
    ped_gap = ped_centre - crowd.radius  # robot centre to pedestrian surface
    static_gap = np.linalg.norm(crowd.static_centers - robot_xy, axis=1) - crowd.static_radii
    walls = crowd.wall_segments
    if len(walls):  # a wall is a static object of no thickness: its gap is the distance
        static_gap = np.concatenate([static_gap, point_segment_distances(robot_xy, walls)])
    all_gap = np.concatenate([ped_gap, static_gap])
    collision = bool(all_gap.size and all_gap.min() <= robot_radius)
    collided_with = ""
    if collision:
        nearest = int(np.argmin(all_gap))
        if nearest < len(ped_gap):
            collided_with = EMOTION_NAMES[int(crowd.emotions[nearest])]
        else:
            is_wall = nearest >= len(ped_gap) + len(crowd.static_radii)
            collided_with = "wall" if is_wall else "static"
    in_static = bool(static_gap.size and static_gap.min() < crowd.static_discomfort + robot_radius)
    in_ped = ped_gap < crowd.discomfort + robot_radius
    reached = goal_distance <= goal_radius

    r_col = params.collision if collision else (params.discomfort if in_static else 0.0)
    r_goal = params.goal if reached else params.progress_gain * (prev_goal_distance - goal_distance)
    r_emo = params.discomfort if in_ped.any() else 0.0
    if not collision and in_static and in_ped.any():
        r_emo = 0.0  # the discomfort penalty counts once per step
    idt = [int(in_static), 0, 0, 0]
    for emotion in crowd.emotions[in_ped]:
        idt[1 + int(emotion)] = 1
    return StepEvaluation(
        reward=float(r_col + r_goal + r_emo),
        collision=collision,
        reached_goal=bool(reached),
        in_discomfort=bool(in_static or in_ped.any()),
        idt=(idt[0], idt[1], idt[2], idt[3]),
        min_ped_distance=float(ped_centre.min()) if ped_centre.size else math.inf,
        goal_distance=goal_distance,
        collided_with=collided_with,
    )
