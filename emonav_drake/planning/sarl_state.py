"""SARL's joint state and one-step look-ahead on the LIP model (numpy only).

SARL (Chen et al., "Crowd-Robot Interaction", ICRA 2019; CrowdNav) values the joint state
of the robot and every other agent, seen from a frame at the robot whose x axis points to
the goal, and acts by a one-step look-ahead: for each command of a fixed set it predicts
the next joint state, the step's reward, and picks

    argmax_a  R(s, a) + γ^(T·v_pref) V(s'_a).

Our adaptation to the biped and to this task (`planners/sarl.py` holds the network):

* **the robot's step** is the LIP of Eq. 1 (`robot.lip.lip_step`): one walking step of
  T = 0.4 s under (u_v, u_Δθ), exact, from the CoM state at the foot switch;
* **the other agents** are the pedestrians, predicted at constant velocity for T, and the
  static discs (velocity 0, never moving): CrowdNav has no obstacles;
* **the reward** of a look-ahead step is the paper's (`navigation.reward.evaluate_step`, Eq. 6–9)
  at the predicted step end, with every pedestrian's emotion discomfort zone;
* **one row per agent** (`FEATURES` columns), CrowdNav's rotated self state followed by the
  agent's, plus two columns for this task: the agent's discomfort distance (emotion, or
  d_static) and whether it is a static disc.

Positions in metres, velocities in m/s, angles in radians; the robot's velocity is its
sagittal speed along its heading (the LIP's state at the switch).
"""

from __future__ import annotations

import dataclasses as dc

import numpy as np

from emonav_drake.crowd.crowd import CrowdSnapshot
from emonav_drake.navigation.reward import evaluate_step
from emonav_drake.params import EmoNavConfig
from emonav_drake.robot.lip import LipState, lip_step

# Columns of one row: the robot (rotated frame: x to the goal), then one agent.
FEATURES = (
    "dg",  # robot → goal distance [m]
    "v_pref",  # the robot's preferred (maximum) speed [m/s]
    "theta",  # robot heading relative to the goal direction [rad]
    "radius",  # robot radius [m]
    "vx",  # robot velocity, rotated frame [m/s]
    "vy",
    "px1",  # agent position relative to the robot, rotated frame [m]
    "py1",
    "vx1",  # agent velocity, rotated frame [m/s]
    "vy1",
    "radius1",  # agent radius [m]
    "da",  # robot → agent centre distance [m]
    "radius_sum",  # radius + radius1 [m]
    "zone1",  # the agent's discomfort distance: its emotion's, or d_static [m]
    "static1",  # 1 for a static disc, 0 for a pedestrian
)
NUM_FEATURES = len(FEATURES)
# The value networks over these rows (`planners/sarl.py`): CrowdNav's SARL and RGL.
VALUE_NETWORKS = ("sarl", "rgl")
SELF_FEATURES = 6  # the robot's columns (the first six)
# With no agent at all (possible in a hand-written scenario) the state holds one placeholder
# agent this far behind the robot, at rest, of radius 0.
_NOBODY_DISTANCE = 20.0


def agents(
    crowd: CrowdSnapshot,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Every other agent: positions (H, 2), velocities (H, 2), radii (H,), discomfort
    distances (H,), static flags (H,); pedestrians first, then static discs."""
    p = len(crowd.positions)
    s = len(crowd.static_radii)
    pos = np.vstack([crowd.positions.reshape(-1, 2), crowd.static_centers.reshape(-1, 2)])
    vel = np.vstack([crowd.velocities.reshape(-1, 2), np.zeros((s, 2))])
    radius = np.concatenate([np.full(p, crowd.radius), np.asarray(crowd.static_radii, float)])
    zone = np.concatenate(
        [np.asarray(crowd.discomfort, float), np.full(s, crowd.static_discomfort)]
    )
    static = np.concatenate([np.zeros(p), np.ones(s)])
    return pos, vel, radius, zone, static


def joint_rows(
    robots: np.ndarray,
    goal_xy: np.ndarray,
    pos: np.ndarray,
    vel: np.ndarray,
    radius: np.ndarray,
    zone: np.ndarray,
    static: np.ndarray,
    robot_radius: float,
    v_pref: float,
) -> np.ndarray:
    """The joint states (B, H, NUM_FEATURES) float32 of B robot states (B, 4) = (x, y, θ, v)
    against the same H agents (module docstring; H = 1 placeholder row without agents)."""
    robots = np.asarray(robots, float).reshape(-1, 4)
    if len(pos) == 0:
        pos = robots[:1, :2] - [_NOBODY_DISTANCE, 0.0]
        vel, radius = np.zeros((1, 2)), np.zeros(1)
        zone, static = np.zeros(1), np.zeros(1)
    b, h = len(robots), len(pos)
    x, y, th, v = robots.T
    dx, dy = goal_xy[0] - x, goal_xy[1] - y
    rot = np.arctan2(dy, dx)
    c, s = np.cos(rot)[:, None], np.sin(rot)[:, None]
    out = np.empty((b, h, NUM_FEATURES), np.float32)
    vx, vy = v * np.cos(th), v * np.sin(th)
    out[:, :, 0] = np.hypot(dx, dy)[:, None]
    out[:, :, 1] = v_pref
    out[:, :, 2] = np.angle(np.exp(1j * (th - rot)))[:, None]
    out[:, :, 3] = robot_radius
    out[:, :, 4] = vx[:, None] * c + vy[:, None] * s
    out[:, :, 5] = vy[:, None] * c - vx[:, None] * s
    rx, ry = pos[None, :, 0] - x[:, None], pos[None, :, 1] - y[:, None]
    out[:, :, 6] = rx * c + ry * s
    out[:, :, 7] = ry * c - rx * s
    out[:, :, 8] = vel[None, :, 0] * c + vel[None, :, 1] * s
    out[:, :, 9] = vel[None, :, 1] * c - vel[None, :, 0] * s
    out[:, :, 10] = radius[None]
    out[:, :, 11] = np.hypot(rx, ry)
    out[:, :, 12] = radius[None] + robot_radius
    out[:, :, 13] = zone[None]
    out[:, :, 14] = static[None]
    return out


def current_rows(
    robot: LipState, goal_xy: np.ndarray, crowd: CrowdSnapshot, config: EmoNavConfig
) -> np.ndarray:
    """The joint state (H, NUM_FEATURES) now (what the value network is trained on)."""
    r = config.robot
    a = agents(crowd)
    return joint_rows(np.array([tuple(robot)]), goal_xy, *a, r.radius, r.max_speed)[0]


def lookahead(
    robot: LipState,
    goal_xy: np.ndarray,
    prev_goal_distance: float,
    crowd: CrowdSnapshot,
    commands: np.ndarray,
    config: EmoNavConfig,
    goal_radius: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One-step look-ahead of every command (A, 2) = (u_v [m/s], u_Δθ [rad]): the
    predicted joint states (A, H, NUM_FEATURES), the step rewards (A,) (Eq. 6–9 at the
    predicted step end) and whether each step ends the episode (A,) (collision or goal).

    The robot walks one LIP step; pedestrians move at constant velocity for T; discs stay.
    """
    r = config.robot
    goal = np.asarray(goal_xy, float)
    nxt = np.array(
        [tuple(lip_step(robot, float(u[0]), float(u[1]), r.omega, r.step_time)) for u in commands]
    )
    moved = dc.replace(crowd, positions=crowd.positions + r.step_time * crowd.velocities)
    rewards = np.empty(len(nxt))
    done = np.zeros(len(nxt), bool)
    for i, q in enumerate(nxt):
        ev = evaluate_step(
            q[:2], goal, prev_goal_distance, moved, r.radius, goal_radius, config.reward
        )
        rewards[i] = ev.reward
        done[i] = ev.collision or ev.reached_goal
    rows = joint_rows(nxt, goal, *agents(moved), r.radius, r.max_speed)
    return rows, rewards, done


def step_discount(gamma: float, config: EmoNavConfig) -> float:
    """CrowdNav's discount of one step, γ^(T·v_pref)."""
    return float(gamma ** (config.robot.step_time * config.robot.max_speed))
