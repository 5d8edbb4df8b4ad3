"""The model-based planners' sections of the configuration: DWA, the OSQP MPC, the route.

Part of `EmoNavConfig` (`params.py`, which re-exports every name here). Each field gives
its default, doc, unit and allowed range (`config_fields.setting`). Units are SI
throughout (metres, seconds, radians).
"""

# No `from __future__ import annotations`: Drake's typed YAML loader needs real types.
import dataclasses as dc
import math

from emonav_drake.config_fields import setting

# A weight of a score or a cost: >= 0, bounded (DWA's and the MPC's alike).
_WEIGHT = (0.0, 1e4)


@dc.dataclass
class DwaParams:
    """Dynamic Window Approach on the LIP model (the paper's DWA baseline)."""

    speed_samples: int = setting(9, "candidate speeds, evenly spread over [0, ū_v]", "", (2, 101))
    heading_samples: int = setting(
        11, "candidate heading changes, evenly over [−ū_Δθ, ū_Δθ]", "", (2, 101)
    )
    horizon_steps: int = setting(5, "walking steps rolled out per candidate", "", (1, 50))
    goal_weight: float = setting(
        1.0, "score of progress to the goal (per horizon's full-speed reach)", "", _WEIGHT
    )
    clearance_weight: float = setting(1.0, "score of clearance (per clearance_cap)", "", _WEIGHT)
    discomfort_weight: float = setting(
        3.0, "penalty per metre of discomfort-zone intrusion", "1/m", _WEIGHT
    )
    speed_weight: float = setting(0.1, "score of speed (per ū_v)", "", _WEIGHT)
    clearance_cap: float = setting(
        1.0, "clearance beyond this earns nothing more", "m", (0.01, 10.0)
    )
    safety_margin: float = setting(0.05, "extra collision margin in the rollout", "m", (0.0, 2.0))
    hard_steps: int = setting(
        2, "predicted pedestrian contact within this many steps: rejected", "", (1, 50)
    )


@dc.dataclass
class MpcParams:
    """MPC on the LIP model solved with OSQP (the model-based baseline, `planners/mpc.py`)."""

    horizon_steps: int = setting(8, "walking steps of T in the horizon", "", (2, 40))
    scp_iterations: int = setting(3, "QPs per planning step (re-linearisations)", "", (1, 20))
    # Costs (per walking step of the horizon).
    goal_weight: float = setting(1.0, "cost on |p_k − p_k^ref|²", "1/m²", _WEIGHT)
    terminal_weight: float = setting(4.0, "extra weight on |p_N − p_N^ref|²", "", _WEIGHT)
    reference_lead: float = setting(
        1.0, "reference p_k^ref runs this far ahead of full speed", "m", (0.0, 100.0)
    )
    speed_smoothness_weight: float = setting(2.0, "cost on (u_v,k − u_v,k−1)²", "(s/m)²", _WEIGHT)
    turn_smoothness_weight: float = setting(2.0, "cost on (u_Δθ,k − u_Δθ,k−1)²", "1/rad²", _WEIGHT)
    turn_weight: float = setting(0.2, "cost on u_Δθ,k²", "1/rad²", _WEIGHT)
    discomfort_weight: float = setting(
        20.0, "slack penalty per metre inside a discomfort zone", "1/m", (0.0, 1e6)
    )
    collision_weight: float = setting(
        200.0, "slack penalty per metre of predicted late contact", "1/m", (0.0, 1e6)
    )
    slack_quadratic_weight: float = setting(
        1.0, "small quadratic term on every slack", "1/m²", (1e-6, 1e4)
    )
    prediction_discount: float = setting(
        0.85, "pedestrian penalties weighted by this^k", "", (0.01, 1.0)
    )
    # Margins.
    collision_margin: float = setting(
        0.05, "added to r_obstacle + r_robot for contact", "m", (0.0, 1.0)
    )
    discomfort_margin: float = setting(0.03, "added to the discomfort zones", "m", (0.0, 1.0))
    hard_pedestrian_steps: int = setting(
        2, "pedestrian contact is a hard constraint this many steps ahead", "", (0, 40)
    )
    # Guide path around the static discs (grid Dijkstra), followed by the reference.
    guide_resolution: float = setting(0.1, "cell size of the guide grid", "m", (0.01, 1.0))
    guide_padding: float = setting(
        3.0, "grid margin around robot, goal and discs", "m", (0.5, 50.0)
    )
    guide_zone_cost: float = setting(
        3.0, "cost factor of cells inside a disc's discomfort zone", "", (1.0, 100.0)
    )
    # SCP and initial guess.
    trust_region: float = setting(0.12, "|u_Δθ − ū_Δθ| per SCP iteration", "rad", (0.01, math.pi))
    seed_headings: int = setting(
        7, "seed headings: offsets spread over ±seed_max_offset", "", (1, 41)
    )
    seed_max_offset: float = setting(
        1.2, "largest offset of the seed headings", "rad", (0.0, math.pi)
    )
    previous_plan_bonus: float = setting(
        0.05, "hysteresis for the previous plan (relative cost)", "", (0.0, 1.0)
    )
    # Fallback and solver.
    fallback_speed_scale: float = setting(
        0.5, "fallback: u_v = this × current speed, keep heading", "", (0.0, 1.0)
    )
    osqp_eps: float = setting(
        1e-3, "absolute and relative tolerances (solutions are polished)", "", (1e-8, 1e-1)
    )
    osqp_max_iter: int = setting(400, "OSQP iteration limit per QP", "", (10, 100000))
    # A safety only (a QP takes ~1 ms; the work is bounded by osqp_max_iter); each time it
    # fires the plan depends on the load, and the planner counts it (time_limit_hits) and
    # warns.
    time_limit: float = setting(
        1.0, "OSQP wall-clock limit per QP, a safety only", "s", (1e-4, 10.0)
    )


@dc.dataclass
class RouteParams:
    """The global route layer: a route on the known map in scenes with walls (docs/global_route.md).

    On by default; in a scene without walls (the paper's arena) it is never built,
    whatever `enabled` says, so results there do not depend on it. The defaults were
    chosen on tuning seeds (benchmarks/results/route_tuning/): margins tried widest first
    keep a route through a door to its middle, and the line-of-sight sub-goal never sends
    the local planner across a jamb's corner.
    """

    enabled: bool = setting(
        True,
        "in a scene with walls, plan a route on the known map (walls and static discs) and "
        "give the planner a sub-goal along it",
    )
    margins: list[float] = setting(
        [0.3, 0.2, 0.1],
        "the route's distance from walls and static discs beyond the robot's radius, tried "
        "in order (the first that gives a route wins; then the radius alone)",
        "m",
        (None, 0.0, 2.0),
    )
    lookahead: float = setting(
        2.0, "the sub-goal's distance along the route beyond the robot", "m", (0.2, 20.0)
    )
    line_of_sight: bool = setting(
        True,
        "pull the sub-goal back along the route until the straight line from the robot to "
        "it keeps the robot's radius from every wall and disc (no corner cut)",
    )
    stray: float = setting(
        1.0, "replan when the robot is farther than this from the route", "m", (0.05, 20.0)
    )
