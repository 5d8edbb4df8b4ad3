"""RVO2's 2-D linear programs for ORCA (`linearProgram1/2/3`), in plain Python on floats.

Used by `crowd/orca.py` (`orca_velocities`). Each active agent's new velocity is the one
closest to its preferred velocity inside the disc of radius ``max_speed`` that satisfies
its ORCA half-planes (`linear_program2`, which calls `linear_program1` on a violated
line); if that is infeasible, `linear_program3` minimises the largest violation of the
agent lines while keeping the obstacle lines hard. Python floats are much faster than
numpy for such tiny problems.

Frame and units: the world frame; velocities and speeds in m/s. A line is a tuple
``(direction_x, direction_y, point_x, point_y)`` (`Line`); the permitted half-plane is to
the left of the (unit) direction. RVO2's epsilon `RVO_EPSILON` is used for parallel-line
tests.
"""

from __future__ import annotations

import math

import numpy as np

RVO_EPSILON = 1e-5
"""RVO2's tolerance for treating two ORCA lines as parallel."""

Line = tuple[float, float, float, float]
"""An ORCA line ``(direction_x, direction_y, point_x, point_y)``, world frame, m/s."""


def solve_linear_programs(
    agents: np.ndarray,
    lines: list[Line],
    offsets: list[int],
    n_obstacle_lines: list[int],
    pref: np.ndarray,
    vmax: np.ndarray,
) -> list[tuple[float, float]]:
    """Run LP2 (and the LP3 fallback) for every active agent; return the new velocities.

    ``lines[offsets[k]:offsets[k + 1]]`` are the lines of the k-th active agent
    ``agents[k]``, of which the first ``n_obstacle_lines[k]`` are obstacle lines.
    """
    pref_list = pref[agents].tolist()
    vmax_list = vmax[agents].tolist()
    results = []
    for k, ((opt_x, opt_y), radius) in enumerate(zip(pref_list, vmax_list, strict=True)):
        agent_lines = lines[offsets[k] : offsets[k + 1]]
        fail, rx, ry = linear_program2(agent_lines, radius, opt_x, opt_y, False)
        if fail < len(agent_lines):
            rx, ry = linear_program3(agent_lines, n_obstacle_lines[k], fail, radius, rx, ry)
        results.append(clamp_speed(rx, ry, radius))
    return results


def clamp_speed(vx: float, vy: float, max_speed: float) -> tuple[float, float]:
    """Scale ``(vx, vy)`` down to ``max_speed`` if rounding pushed it marginally above."""
    speed_sq = vx * vx + vy * vy
    if speed_sq > max_speed * max_speed:
        scale = max_speed / math.sqrt(speed_sq)
        return vx * scale, vy * scale
    return vx, vy


def linear_program1(
    lines: list[Line],
    line_no: int,
    radius: float,
    opt_x: float,
    opt_y: float,
    direction_opt: bool,
) -> tuple[float, float] | None:
    """Optimise on line ``line_no`` subject to lines ``0..line_no-1`` and the speed circle.

    Returns the optimum on the line, or ``None`` if that line segment is empty.
    """
    ldx, ldy, lpx, lpy = lines[line_no]
    dot = lpx * ldx + lpy * ldy
    discriminant = dot * dot + radius * radius - (lpx * lpx + lpy * lpy)
    if discriminant < 0.0:
        return None  # the speed circle fully invalidates this line
    sqrt_disc = math.sqrt(discriminant)
    t_left = -dot - sqrt_disc
    t_right = -dot + sqrt_disc
    for i in range(line_no):
        idx, idy, ipx, ipy = lines[i]
        denominator = ldx * idy - ldy * idx
        numerator = idx * (lpy - ipy) - idy * (lpx - ipx)
        if abs(denominator) <= RVO_EPSILON:
            if numerator < 0.0:
                return None  # (almost) parallel and on the forbidden side
            continue
        t = numerator / denominator
        if denominator >= 0.0:
            if t < t_right:
                t_right = t  # line i bounds this line on the right
        elif t > t_left:
            t_left = t  # line i bounds this line on the left
        if t_left > t_right:
            return None
    if direction_opt:
        t = t_right if opt_x * ldx + opt_y * ldy > 0.0 else t_left
    else:
        t = ldx * (opt_x - lpx) + ldy * (opt_y - lpy)
        if t < t_left:
            t = t_left
        elif t > t_right:
            t = t_right
    return lpx + t * ldx, lpy + t * ldy


def linear_program2(
    lines: list[Line],
    radius: float,
    opt_x: float,
    opt_y: float,
    direction_opt: bool,
) -> tuple[int, float, float]:
    """Incremental 2-D LP inside the speed circle of ``radius``.

    With ``direction_opt`` the (unit) ``opt`` is a direction to go furthest in; otherwise the
    point closest to ``opt`` is sought. Returns ``(fail, x, y)``: ``fail == len(lines)`` on
    success, else the index of the first line that could not be satisfied, with ``(x, y)``
    the result before that line.
    """
    if direction_opt:
        rx = opt_x * radius
        ry = opt_y * radius
    elif opt_x * opt_x + opt_y * opt_y > radius * radius:
        norm = math.sqrt(opt_x * opt_x + opt_y * opt_y)
        rx = opt_x / norm * radius
        ry = opt_y / norm * radius
    else:
        rx = opt_x
        ry = opt_y
    for i, (ldx, ldy, lpx, lpy) in enumerate(lines):
        if ldx * (lpy - ry) - ldy * (lpx - rx) > 0.0:  # result violates line i
            optimum = linear_program1(lines, i, radius, opt_x, opt_y, direction_opt)
            if optimum is None:
                return i, rx, ry
            rx, ry = optimum
    return len(lines), rx, ry


def linear_program3(
    lines: list[Line],
    n_obstacle_lines: int,
    begin_line: int,
    radius: float,
    rx: float,
    ry: float,
) -> tuple[float, float]:
    """Fallback when LP2 fails: minimise the largest violation of the agent lines.

    The first ``n_obstacle_lines`` lines (obstacles) stay hard constraints. ``(rx, ry)`` is
    LP2's partial result, ``begin_line`` the line where LP2 failed.
    """
    distance = 0.0
    for i in range(begin_line, len(lines)):
        idx, idy, ipx, ipy = lines[i]
        if idx * (ipy - ry) - idy * (ipx - rx) <= distance:
            continue
        projected = lines[:n_obstacle_lines]
        for j in range(n_obstacle_lines, i):
            jdx, jdy, jpx, jpy = lines[j]
            determinant = idx * jdy - idy * jdx
            if abs(determinant) <= RVO_EPSILON:
                if idx * jdx + idy * jdy > 0.0:
                    continue  # parallel, same direction
                px = 0.5 * (ipx + jpx)
                py = 0.5 * (ipy + jpy)
            else:
                s = (jdx * (ipy - jpy) - jdy * (ipx - jpx)) / determinant
                px = ipx + s * idx
                py = ipy + s * idy
            ddx = jdx - idx
            ddy = jdy - idy
            norm = math.sqrt(ddx * ddx + ddy * ddy)
            projected.append((ddx / norm, ddy / norm, px, py))
        fail, nx, ny = linear_program2(projected, radius, -idy, idx, True)
        if fail == len(projected):
            rx, ry = nx, ny  # else keep the previous result (floating-point trouble)
        distance = idx * (ipy - ry) - idy * (ipx - rx)
    return rx, ry
