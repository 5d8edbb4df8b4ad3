"""What a learned policy reads as its goal: the goal itself, or a sub-goal on a guide path.

A policy's vector state starts with (distance [m], bearing [rad, CCW from the heading]) of
its goal in the robot frame. Two goal inputs exist (a checkpoint's
`observation["goal_input"]`; checkpoints without the key read "goal"):

    "goal"   the paper's: distance and bearing of the goal itself.
    "guide"  the distance of the goal, and the bearing of a sub-goal: the farthest point,
             at most `GUIDE_LOOKAHEAD` metres along the shortest path to the goal around
             the static discs (`GuidePath`, the MPC's guide path), that the robot sees
             with its clearance (the straight segment to it keeps `r_disc + r_robot +
             d_static + margin` from every disc centre it is not already closer to).

Where no disc blocks the straight line to the goal the two inputs are equal. The "guide"
input is not the paper's observation: it gives the policy the map knowledge the MPC plans
with (the static discs are known obstacles), as DRL-VO's sub-goal from a global path does.
It does not see pedestrians.

The guide grid is a function of the goal and the discs alone (a square of
`GUIDE_REACH` metres around the goal, the discs' zones and a padding), so the result does
not depend on which episodes a process saw before; grids are cached per (goal, discs).
Outside the grid the goal's own bearing is used.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from emonav_drake.crowd.crowd import CrowdSnapshot
from emonav_drake.params import MpcParams
from emonav_drake.planning.mpc_guide import GuidePath
from emonav_drake.robot.lip import LipState, wrap_angle

GOAL_INPUTS = ("goal", "guide")
GUIDE_LOOKAHEAD = 3.0  # farthest sub-goal along the guide path [m]
GUIDE_REACH = 8.0  # half-size of the guide grid's square around the goal [m]
_MPC = MpcParams()


def check_goal_input(goal_input: str) -> str:
    """`goal_input` if it is one of `GOAL_INPUTS`, else `ValueError`."""
    if goal_input not in GOAL_INPUTS:
        raise ValueError(f"goal_input = {goal_input!r}: must be one of {list(GOAL_INPUTS)}")
    return goal_input


def goal_state(robot: LipState, goal_xy: np.ndarray) -> np.ndarray:
    """(distance [m], bearing [rad, CCW from the heading]) of the goal."""
    dx, dy = goal_xy[0] - robot.x, goal_xy[1] - robot.y
    return np.array([math.hypot(dx, dy), wrap_angle(math.atan2(dy, dx) - robot.heading)])


def policy_goal_state(
    robot: LipState,
    goal_xy: np.ndarray,
    crowd: CrowdSnapshot,
    goal_input: str,
    robot_radius: float,
) -> np.ndarray:
    """The (distance [m], bearing [rad]) a policy of `goal_input` reads (module docstring).

    Args:
        robot: CoM position [m] and heading [rad], world frame.
        goal_xy: (2,) the goal, world frame [m].
        crowd: the static discs (centres, radii, d_static) of the snapshot; pedestrians
            are not used.
        goal_input: "goal" or "guide".
        robot_radius: r_robot [m] (the clearance of the guide path).
    """
    state = goal_state(robot, np.asarray(goal_xy, float))
    if check_goal_input(goal_input) == "goal":
        return state
    sub = guide_subgoal(robot, goal_xy, crowd, robot_radius)
    if sub is None:
        return state
    bearing = math.atan2(sub[1] - robot.y, sub[0] - robot.x) - robot.heading
    return np.array([state[0], wrap_angle(bearing)])


def guide_subgoal(
    robot: LipState, goal_xy: np.ndarray, crowd: CrowdSnapshot, robot_radius: float
) -> np.ndarray | None:
    """The sub-goal (2,) [m] of the "guide" input, None where the goal itself is the
    sub-goal (no discs, the goal in sight, the robot off the grid or no path)."""
    centers = np.asarray(crowd.static_centers, float).reshape(-1, 2)
    radii = np.asarray(crowd.static_radii, float).reshape(-1)
    if not len(radii):
        return None
    p = np.array([robot.x, robot.y])
    goal = np.asarray(goal_xy, float)
    r_zone = radii + robot_radius + crowd.static_discomfort + _MPC.discomfort_margin
    if _in_sight(p, goal, centers, r_zone):
        return None
    guide = _guide(
        goal.tobytes(),
        centers.tobytes(),
        radii.tobytes(),
        float(crowd.static_discomfort),
        float(robot_radius),
    )
    if not guide.covers(p):
        return None
    path = guide.path(p)
    if path is None:
        return None
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(path, axis=0), axis=1))])
    best = None
    for q in path[1:][arc[1:] <= GUIDE_LOOKAHEAD]:
        if _in_sight(p, q, centers, r_zone):
            best = q
    if best is None:  # not even the next waypoint in sight: head along the path
        best = path[min(1, len(path) - 1)]
    return best.copy()


def _in_sight(p: np.ndarray, q: np.ndarray, centers: np.ndarray, r_zone: np.ndarray) -> bool:
    """Whether the segment p → q keeps r_zone from every centre, or at least the distance
    p already has (a robot inside a zone may move along or out of it)."""
    d = q - p
    length2 = float(d @ d)
    rel = centers - p
    t = np.clip(rel @ d / length2, 0.0, 1.0) if length2 > 0 else np.zeros(len(centers))
    closest = np.linalg.norm(rel - t[:, None] * d, axis=1)
    start = np.linalg.norm(rel, axis=1)
    return bool(np.all(closest >= np.minimum(r_zone, start) - 1e-9))


@functools.lru_cache(maxsize=16)
def _guide(
    goal: bytes, centers: bytes, radii: bytes, static_discomfort: float, robot_radius: float
) -> GuidePath:
    """The guide grid of one (goal, discs): a pure function of them (module docstring)."""
    g = np.frombuffer(goal, float)
    c = np.frombuffer(centers, float).reshape(-1, 2)
    r = np.frombuffer(radii, float)
    r_col = r + robot_radius + _MPC.collision_margin
    r_zone = r + robot_radius + static_discomfort + _MPC.discomfort_margin
    return GuidePath(
        g, c, r_col, r_zone, g, _MPC.guide_resolution, GUIDE_REACH, _MPC.guide_zone_cost
    )
