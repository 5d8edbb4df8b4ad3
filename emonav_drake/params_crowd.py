"""The world's sections of the configuration: the crowd and its scenarios, the rewards and
the episode rules, and the emotion codes.

Part of `EmoNavConfig` (`params.py`, which re-exports every name here). Each field gives
its default, doc, unit and allowed range (`config_fields.setting`). Units are SI
throughout (metres, seconds, radians).
"""

# No `from __future__ import annotations`: Drake's typed YAML loader needs real types.
import dataclasses as dc

from emonav_drake.config_fields import setting

# Emotion codes used everywhere (crowd, grid maps, metrics).
HAPPY, NEUTRAL, NEGATIVE = 0, 1, 2
EMOTION_NAMES = ("happy", "neutral", "negative")

# The named scenario samplers (`CrowdParams.family`, scenarios/scenario_families.py).
SCENARIO_FAMILIES = (
    "paper",
    "circle_crossing",
    "parallel_traffic",
    "perpendicular_traffic",
    "robot_crowding",
    "delayed_crossing",
    "crossing_with_obstacles",
    "corner_traffic",
    "blocker",
    "group_approach",
    "all_dynamic",
    "corridor_head_on",
    "dense_8",
    "dense_12",
    "dense_20",
    "fast_pedestrians",
    "t_junction",
    "doorway",
    "office",
    "mixed",
    "mixed_buildings",
)

_COUNT = (0, 20)  # pedestrians or static discs in a sampled scenario
_DISCOMFORT_DISTANCE = (0.0, 3.0)  # [m]


@dc.dataclass
class CrowdParams:
    """Pedestrians (ORCA), static discs and scenario sampling (paper §IV-B)."""

    dt: float = setting(0.1, "pedestrian dynamics period (10 Hz)", "s", (0.01, 1.0))
    pedestrian_radius: float = setting(0.3, "r_ped, pedestrian radius", "m", (0.05, 1.0))
    preferred_speed: float = setting(1.0, "pedestrians' preferred (ORCA) speed", "m/s", (0.0, 3.0))
    min_pedestrians: int = setting(1, "fewest pedestrians in a sampled scenario", "", _COUNT)
    max_pedestrians: int = setting(4, "most pedestrians in a sampled scenario", "", _COUNT)
    min_static: int = setting(1, "fewest static discs in a sampled scenario", "", _COUNT)
    max_static: int = setting(3, "most static discs in a sampled scenario", "", _COUNT)
    static_radius_min: float = setting(0.2, "static disc radius: lower bound", "m", (0.05, 2.0))
    static_radius_max: float = setting(0.4, "static disc radius: upper bound", "m", (0.05, 2.0))
    circle_radius_min: float = setting(
        3.5, "radius of the pedestrians' start circle: lower bound", "m", (0.5, 20.0)
    )
    circle_radius_max: float = setting(
        4.5, "radius of the pedestrians' start circle: upper bound", "m", (0.5, 20.0)
    )
    static_x_range: list[float] = setting(
        [-3.0, 3.0], "[low, high] of the static discs' centre x", "m", (2, -20.0, 20.0)
    )
    static_y_range: list[float] = setting(
        [-1.5, 1.5], "[low, high] of the static discs' centre y", "m", (2, -20.0, 20.0)
    )
    goal_tolerance: float = setting(
        0.1, "a pedestrian turns round within this of its goal", "m", (0.01, 2.0)
    )
    # ORCA (RVO2 semantics), the authors' settings.
    neighbor_dist: float = setting(
        10.0, "ORCA: neighbours are the pedestrians closer than this", "m", (0.1, 100.0)
    )
    max_neighbors: int = setting(10, "ORCA: at most this many nearest neighbours", "", (0, 100))
    time_horizon: float = setting(
        5.0, "ORCA horizon of pedestrians' velocity obstacles", "s", (0.1, 30.0)
    )
    time_horizon_obst: float = setting(
        5.0, "ORCA horizon of static discs' velocity obstacles", "s", (0.1, 30.0)
    )
    safety_space: float = setting(0.2, "added to every ORCA radius", "m", (0.0, 1.0))
    emotion_probs: list[float] = setting(
        [1 / 3, 1 / 3, 1 / 3],
        "probabilities of happy, neutral, negative when a pedestrian's emotion is drawn",
        "",
        (3, 0.0, 1.0),
    )
    time_varying_emotions: bool = setting(False, "one pedestrian's emotion changes periodically")
    emotion_change_period: float = setting(
        2.0, "time-varying mode: period of the changes", "s", (0.1, 100.0)
    )
    family: str = setting(
        "paper", 'the scenario sampler (scenarios/scenario_families.py): "paper" is §IV-B\'s arena'
    )


@dc.dataclass
class RewardParams:
    """Rewards, paper Eq. 6–9, and the discomfort distances of §III-C.

    The rewards are bounded so that an episode's total stays finite and printable: at most
    |collision| + |discomfort| + goal + progress_gain × (the longest step) per step, over
    at most `episode.max_steps` steps: 7 × 10^7 at the bounds.
    """

    collision: float = setting(-0.6, "reward of a collision (a penalty)", "", (-100.0, 0.0))
    discomfort: float = setting(
        -0.1,
        "reward inside a discomfort zone, counted once per step (a penalty)",
        "",
        (-100.0, 0.0),
    )
    goal: float = setting(0.5, "reward of reaching the goal", "", (0.0, 100.0))
    progress_gain: float = setting(
        0.3, "reward per metre of progress towards the goal", "1/m", (0.0, 100.0)
    )
    static_discomfort: float = setting(
        0.2, "d_static, discomfort distance of static discs", "m", _DISCOMFORT_DISTANCE
    )
    happy_discomfort: float = setting(
        0.2, "discomfort distance of happy pedestrians", "m", _DISCOMFORT_DISTANCE
    )
    neutral_discomfort: float = setting(
        0.35, "discomfort distance of neutral pedestrians", "m", _DISCOMFORT_DISTANCE
    )
    negative_discomfort: float = setting(
        0.5, "discomfort distance of negative pedestrians", "m", _DISCOMFORT_DISTANCE
    )

    def emotion_distances(self) -> tuple[float, float, float]:
        """Discomfort distance per emotion code (HAPPY, NEUTRAL, NEGATIVE) [m]."""
        return (self.happy_discomfort, self.neutral_discomfort, self.negative_discomfort)


# A goal radius d_goal [m] (the training routes read it: `learning/config_common.py`).
_GOAL_RADIUS = (0.01, 2.0)


@dc.dataclass
class EpisodeParams:
    """Episode rules (the authors' code): time limit, goal radii, discount."""

    max_steps: int = setting(
        125, "time limit in walking steps (50 s of 0.4 s steps)", "", (1, 100000)
    )
    goal_radius: float = setting(
        0.1, "d_goal, goal reached within this, training", "m", _GOAL_RADIUS
    )
    eval_goal_radius: float = setting(0.2, "d_goal in evaluation", "m", _GOAL_RADIUS)
    discount: float = setting(0.99, "γ, discount factor", "", (0.0, 1.0))
    # A safety only (`watchdog.py`): it turns a planner that hangs into the episode's
    # error; a decision that returns in time is untouched, so no result depends on it.
    decision_timeout: float = setting(
        60.0,
        "wall-clock limit of one planner decision: a planner still deciding after it ends "
        "the episode with an error naming it (PlannerTimeout); 0 = no limit",
        "s",
        (0.0, 86400.0),
    )
