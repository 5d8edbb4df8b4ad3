"""Straightforward reference implementation of ORCA, used to cross-check the fast one.

Same semantics and signature as :func:`emonav_drake.crowd.orca.orca_velocities` (see that
module's docstring): world frame, metres, m/s, seconds; RVO2's ORCA lines and linear
programs. This version follows RVO2's structure literally — one agent at a time, one
neighbour at a time, numpy 2-vectors, no vectorisation — and is therefore slow. It does not
validate its input.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from emonav_drake.crowd.orca import OrcaParams

EPSILON = 1e-5


@dataclass
class Line:
    """Directed line; the permitted half-plane lies to the left of ``direction``."""

    point: np.ndarray
    direction: np.ndarray


def det(a: np.ndarray, b: np.ndarray) -> float:
    """2-D cross product ``a x b``."""
    return float(a[0] * b[1] - a[1] * b[0])


def dot(a: np.ndarray, b: np.ndarray) -> float:
    """2-D dot product."""
    return float(a[0] * b[0] + a[1] * b[1])


def orca_velocities_reference(
    positions: np.ndarray,
    velocities: np.ndarray,
    radii: np.ndarray,
    pref_velocities: np.ndarray,
    max_speeds: np.ndarray,
    dt: float,
    params: OrcaParams = OrcaParams(),  # noqa: B008 - frozen, immutable default
    obstacle_centers: np.ndarray | None = None,
    obstacle_radii: np.ndarray | None = None,
    visible: np.ndarray | None = None,
    active: np.ndarray | None = None,
) -> np.ndarray:
    """Reference ORCA step; see :func:`emonav_drake.crowd.orca.orca_velocities`."""
    positions = np.asarray(positions, dtype=float)
    velocities = np.asarray(velocities, dtype=float)
    radii = np.asarray(radii, dtype=float)
    pref_velocities = np.asarray(pref_velocities, dtype=float)
    max_speeds = np.asarray(max_speeds, dtype=float)
    n = len(positions)
    if obstacle_centers is None:
        obstacle_centers = np.zeros((0, 2))
        obstacle_radii = np.zeros(0)
    obstacle_centers = np.asarray(obstacle_centers, dtype=float)
    obstacle_radii = np.asarray(obstacle_radii, dtype=float)
    if visible is None:
        visible = np.ones((n, n), dtype=bool)
    if active is None:
        active = np.ones(n, dtype=bool)

    new_velocities = velocities.copy()
    for i in range(n):
        if not active[i]:
            continue
        lines = []
        obstacles = obstacle_neighbours(
            i, positions, radii, max_speeds, obstacle_centers, obstacle_radii, params
        )
        for k in obstacles:
            lines.append(
                orca_line(
                    i,
                    positions[i],
                    velocities[i],
                    radii[i],
                    obstacle_centers[k],
                    np.zeros(2),
                    obstacle_radii[k],
                    n + k,
                    1.0 / params.time_horizon_obst,
                    dt,
                    1.0,
                )
            )
        n_obstacle_lines = len(lines)
        for j in agent_neighbours(i, positions, visible, params):
            lines.append(
                orca_line(
                    i,
                    positions[i],
                    velocities[i],
                    radii[i],
                    positions[j],
                    velocities[j],
                    radii[j],
                    j,
                    1.0 / params.time_horizon,
                    dt,
                    0.5,
                )
            )
        fail, result = linear_program2(lines, max_speeds[i], pref_velocities[i], False)
        if fail < len(lines):
            result = linear_program3(lines, n_obstacle_lines, fail, max_speeds[i], result)
        speed = math.sqrt(dot(result, result))
        if speed * speed > max_speeds[i] * max_speeds[i]:
            result = result * (max_speeds[i] / speed)
        new_velocities[i] = result
    return new_velocities


def agent_neighbours(
    i: int, positions: np.ndarray, visible: np.ndarray, params: OrcaParams
) -> list[int]:
    """Visible agents within neighbor_dist, nearest first, at most max_neighbors."""
    candidates = []
    for j in range(len(positions)):
        if j == i or not visible[i, j]:
            continue
        rel = positions[j] - positions[i]
        dist_sq = dot(rel, rel)
        if dist_sq < params.neighbor_dist**2:
            candidates.append((dist_sq, j))
    candidates.sort()
    return [j for _, j in candidates[: params.max_neighbors]]


def obstacle_neighbours(
    i: int,
    positions: np.ndarray,
    radii: np.ndarray,
    max_speeds: np.ndarray,
    centers: np.ndarray,
    obstacle_radii: np.ndarray,
    params: OrcaParams,
) -> list[int]:
    """Static discs whose surface is within RVO2's obstacle range, nearest first."""
    reach = params.time_horizon_obst * max_speeds[i] + radii[i]
    candidates = []
    for k in range(len(centers)):
        rel = centers[k] - positions[i]
        surface = max(math.sqrt(dot(rel, rel)) - obstacle_radii[k], 0.0)
        if surface < reach:
            candidates.append((surface, k))
    candidates.sort()
    return [k for _, k in candidates]


def orca_line(
    i: int,
    position: np.ndarray,
    velocity: np.ndarray,
    radius: float,
    other_position: np.ndarray,
    other_velocity: np.ndarray,
    other_radius: float,
    other_index: int,
    inv_time_horizon: float,
    dt: float,
    responsibility: float,
) -> Line:
    """RVO2's ORCA line of ``i`` with respect to one other (agent or static disc)."""
    relative_position = other_position - position
    relative_velocity = velocity - other_velocity
    dist_sq = dot(relative_position, relative_position)
    combined_radius = radius + other_radius
    combined_radius_sq = combined_radius * combined_radius

    if dist_sq > combined_radius_sq:
        w = relative_velocity - inv_time_horizon * relative_position
        w_length_sq = dot(w, w)
        dot_product1 = dot(w, relative_position)
        if dot_product1 < 0.0 and dot_product1 * dot_product1 > combined_radius_sq * w_length_sq:
            w_length = math.sqrt(w_length_sq)
            unit_w = w / w_length
            direction = np.array([unit_w[1], -unit_w[0]])
            u = (combined_radius * inv_time_horizon - w_length) * unit_w
        else:
            leg = math.sqrt(dist_sq - combined_radius_sq)
            rx, ry = relative_position
            if det(relative_position, w) > 0.0:
                direction = (
                    np.array([rx * leg - ry * combined_radius, rx * combined_radius + ry * leg])
                    / dist_sq
                )
            else:
                direction = -(
                    np.array([rx * leg + ry * combined_radius, -rx * combined_radius + ry * leg])
                    / dist_sq
                )
            u = dot(relative_velocity, direction) * direction - relative_velocity
    else:
        inv_time_step = 1.0 / dt
        w = relative_velocity - inv_time_step * relative_position
        w_length = math.sqrt(dot(w, w))
        if w_length == 0.0:
            unit_w = degenerate_unit(relative_position, i < other_index)
        else:
            unit_w = w / w_length
        direction = np.array([unit_w[1], -unit_w[0]])
        u = (combined_radius * inv_time_step - w_length) * unit_w
    return Line(point=velocity + responsibility * u, direction=direction)


def degenerate_unit(relative_position: np.ndarray, self_first: bool) -> np.ndarray:
    """Push direction when ``w == 0``: away from the other, or +-x if the centres coincide."""
    dist = math.sqrt(dot(relative_position, relative_position))
    if dist > 0.0:
        return -relative_position / dist
    return np.array([1.0, 0.0]) if self_first else np.array([-1.0, 0.0])


def linear_program1(
    lines: list[Line],
    line_no: int,
    radius: float,
    opt_velocity: np.ndarray,
    direction_opt: bool,
) -> np.ndarray | None:
    """Best point on line ``line_no`` under the previous lines and the speed circle."""
    line = lines[line_no]
    dot_product = dot(line.point, line.direction)
    discriminant = dot_product**2 + radius**2 - dot(line.point, line.point)
    if discriminant < 0.0:
        return None
    sqrt_discriminant = math.sqrt(discriminant)
    t_left = -dot_product - sqrt_discriminant
    t_right = -dot_product + sqrt_discriminant
    for i in range(line_no):
        denominator = det(line.direction, lines[i].direction)
        numerator = det(lines[i].direction, line.point - lines[i].point)
        if abs(denominator) <= EPSILON:
            if numerator < 0.0:
                return None
            continue
        t = numerator / denominator
        if denominator >= 0.0:
            t_right = min(t_right, t)
        else:
            t_left = max(t_left, t)
        if t_left > t_right:
            return None
    if direction_opt:
        if dot(opt_velocity, line.direction) > 0.0:
            return line.point + t_right * line.direction
        return line.point + t_left * line.direction
    t = dot(line.direction, opt_velocity - line.point)
    if t < t_left:
        return line.point + t_left * line.direction
    if t > t_right:
        return line.point + t_right * line.direction
    return line.point + t * line.direction


def linear_program2(
    lines: list[Line], radius: float, opt_velocity: np.ndarray, direction_opt: bool
) -> tuple[int, np.ndarray]:
    """Incremental LP; returns (index of the failing line or len(lines), result)."""
    if direction_opt:
        result = opt_velocity * radius
    elif dot(opt_velocity, opt_velocity) > radius**2:
        result = opt_velocity / math.sqrt(dot(opt_velocity, opt_velocity)) * radius
    else:
        result = opt_velocity.copy()
    for i, line in enumerate(lines):
        if det(line.direction, line.point - result) > 0.0:
            new_result = linear_program1(lines, i, radius, opt_velocity, direction_opt)
            if new_result is None:
                return i, result
            result = new_result
    return len(lines), result


def linear_program3(
    lines: list[Line],
    n_obstacle_lines: int,
    begin_line: int,
    radius: float,
    result: np.ndarray,
) -> np.ndarray:
    """Minimise the largest violation of the agent lines, obstacle lines kept hard."""
    distance = 0.0
    for i in range(begin_line, len(lines)):
        line_i = lines[i]
        if det(line_i.direction, line_i.point - result) > distance:
            projected = list(lines[:n_obstacle_lines])
            for j in range(n_obstacle_lines, i):
                line_j = lines[j]
                determinant = det(line_i.direction, line_j.direction)
                if abs(determinant) <= EPSILON:
                    if dot(line_i.direction, line_j.direction) > 0.0:
                        continue
                    point = 0.5 * (line_i.point + line_j.point)
                else:
                    point = (
                        line_i.point
                        + (det(line_j.direction, line_i.point - line_j.point) / determinant)
                        * line_i.direction
                    )
                difference = line_j.direction - line_i.direction
                direction = difference / math.sqrt(dot(difference, difference))
                projected.append(Line(point=point, direction=direction))
            opt = np.array([-line_i.direction[1], line_i.direction[0]])
            fail, new_result = linear_program2(projected, radius, opt, True)
            if fail == len(projected):
                result = new_result
            distance = det(line_i.direction, line_i.point - result)
    return result
