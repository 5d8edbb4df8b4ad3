"""Pedestrian behaviours of the scenario families: own speed, waypoints, standing, groups.

Every test steps the real crowd (`crowd/crowd.py`, ORCA) from a hand-written scenario.
"""

import math

import numpy as np
import pytest

from emonav_drake.crowd.crowd import Crowd, CrowdState
from emonav_drake.crowd.pedestrian_routes import WAYPOINT_TOLERANCE
from emonav_drake.params import EmoNavConfig
from emonav_drake.scenarios.scenario import PedestrianSpec, Scenario, StaticDiscSpec
from emonav_drake.typed_yaml import ConfigError

FAR = np.array([40.0, 40.0])  # the robot, out of everyone's way
STILL = np.zeros(2)


def _run(scenario: Scenario, seconds: float, config: EmoNavConfig | None = None):
    """Positions (T+1, P, 2) of the crowd stepped for `seconds` with the robot far away."""
    crowd = Crowd(scenario.validate(), config or EmoNavConfig())
    state = crowd.initial_state()
    out = [state.positions.copy()]
    for _ in range(round(seconds / crowd.dt)):
        state = crowd.step(state, FAR, STILL)
        out.append(state.positions.copy())
    return np.array(out), crowd, state


def _ped(start, goal, **kw) -> PedestrianSpec:
    return PedestrianSpec(start=list(start), goal=list(goal), emotion="neutral", **kw)


def test_a_pedestrian_walks_at_its_own_speed():
    slow = _ped((-3, 1), (3, 1), speed=0.5)
    default = _ped((-3, -1), (3, -1))
    xy, crowd, _ = _run(Scenario(pedestrians=[slow, default]), 4.0)
    speeds = np.linalg.norm(np.diff(xy, axis=0), axis=2) / crowd.dt
    assert speeds[5:, 0] == pytest.approx(0.5, abs=1e-9)
    assert speeds[5:, 1] == pytest.approx(EmoNavConfig().crowd.preferred_speed, abs=1e-9)


def test_a_blocker_walks_to_its_goal_and_stands_there_for_good():
    # the paper's hardware case: a pedestrian steps into the robot's path and stands
    blocker = _ped((0, 3), (0, 0), at_goal="stand")
    xy, crowd, state = _run(Scenario(pedestrians=[blocker]), 30.0)
    arrived = np.flatnonzero(np.linalg.norm(xy[:, 0] - [0, 0], axis=1) < 0.1)[0]
    assert arrived * crowd.dt == pytest.approx(3.0, abs=0.3)  # 3 m at 1 m/s
    after = xy[arrived:, 0]
    assert np.linalg.norm(after - after[0], axis=1).max() < 0.1  # stands: < 10 cm in 27 s
    assert state.waits[0] == -1


def test_stand_time_at_each_end_and_a_delayed_start():
    ped = _ped((-2, 0), (2, 0), stand_time=2.0, start_delay=1.5)
    xy, crowd, _ = _run(Scenario(pedestrians=[ped]), 12.0)
    moved = np.linalg.norm(xy - xy[0], axis=2)[:, 0]
    first_move = np.flatnonzero(moved > 1e-6)[0]
    assert first_move * crowd.dt == pytest.approx(1.5 + crowd.dt, abs=1e-9)
    # 4 m at 1 m/s: at the goal after 5.5 s, stands 2 s, then walks back
    x = xy[:, 0, 0]
    at_goal = np.flatnonzero(np.abs(x - 2.0) < 0.1)
    assert at_goal[0] * crowd.dt == pytest.approx(5.4, abs=0.3)
    assert (at_goal[-1] - at_goal[0]) * crowd.dt == pytest.approx(2.0, abs=0.3)
    assert x[-1] < 1.0  # on its way back


def test_a_route_passes_through_its_waypoints_and_back():
    ped = _ped((-3, -3), (3, 3), waypoints=[[-3, 3], [3, -3]])
    xy, _, state = _run(Scenario(pedestrians=[ped]), 30.0)
    route = [(-3, 3), (3, -3), (3, 3)]
    # waypoints are passed within WAYPOINT_TOLERANCE (corners cut), the goal is reached
    near = [WAYPOINT_TOLERANCE, WAYPOINT_TOLERANCE, 0.1]
    first = [
        np.flatnonzero(np.linalg.norm(xy[:, 0] - p, axis=1) < d)[0]
        for p, d in zip(route, near, strict=True)
    ]
    assert first == sorted(first)  # in order
    # at 1 m/s, the 20.5 m route less what cutting two corners saves (each < 2 x 0.5 m)
    assert 6 + math.hypot(6, 6) + 6 - 2.0 < first[-1] * 0.1 <= 6 + math.hypot(6, 6) + 6 + 0.2
    # about 19 m to the goal, then back: after 30 s it walks back
    assert bool(state.backwards[0])


def test_a_group_keeps_its_formation_while_avoiding():
    # three walk side by side towards a disc and a pedestrian coming the other way
    group = [
        _ped((-3.5, 0.0), (3.5, 0.0), group=0),
        _ped((-3.5, 0.8), (0, 0), group=0),
        _ped((-4.1, -0.6), (0, 0), group=0),
    ]
    other = _ped((3.5, 0.3), (-3.5, 0.3))
    scenario = Scenario(
        pedestrians=[*group, other],
        obstacles=[StaticDiscSpec(center=[0.0, -2.0], radius=0.3)],
        robot_start=[-4.0, -3.0],
    )
    xy, _, _ = _run(scenario, 7.0)
    offsets = np.array([[0.0, 0.8], [-0.6, -0.6]])
    slot_error = np.linalg.norm(xy[:, 1:3] - (xy[:, :1] + offsets), axis=2)
    # the formation gives way to the oncoming pedestrian (the upper member, 0.8 m from its
    # leader, lets it through) and closes again
    assert slot_error.max() < 0.9
    assert np.median(slot_error) < 0.2
    assert slot_error[-1].max() < 0.05
    assert xy[-1, 0, 0] > 2.5  # the group got past
    gaps = np.linalg.norm(xy[:, :3, None] - xy[:, None, 3:], axis=3)
    assert gaps.min() > 2 * EmoNavConfig().crowd.pedestrian_radius  # and avoided the other


def test_route_progress_survives_the_plain_state_round_trip():
    ped = _ped((-2, 0), (2, 0), waypoints=[[0, 1]], stand_time=1.0)
    crowd = Crowd(Scenario(pedestrians=[ped]).validate(), EmoNavConfig())
    state = crowd.initial_state()
    for _ in range(37):
        state = crowd.step(state, FAR, STILL)
    again = CrowdState.from_plain(state.to_plain())
    a, b = state, again
    for _ in range(60):
        a, b = crowd.step(a, FAR, STILL), crowd.step(b, FAR, STILL)
    assert np.array_equal(a.positions, b.positions)


def test_a_paper_pedestrian_state_saved_before_routes_still_steps():
    ped = _ped((-2, 0), (2, 0))
    crowd = Crowd(Scenario(pedestrians=[ped]).validate(), EmoNavConfig())
    state = crowd.initial_state()
    old = {k: v for k, v in state.to_plain().items() if k not in ("targets", "backwards", "waits")}
    a, b = state, CrowdState.from_plain(old)
    for _ in range(80):
        a, b = crowd.step(a, FAR, STILL), crowd.step(b, FAR, STILL)
    assert np.array_equal(a.positions, b.positions)


@pytest.mark.parametrize(
    "change, message",
    [
        ({"at_goal": "wander"}, "at_goal"),
        ({"waypoints": [[1.0, 2.0, 3.0]]}, "waypoints[0]"),
        ({"waypoints": [[0.0, 99.0]]}, "waypoints"),
        ({"speed": 0.0}, "speed"),
        ({"speed": 5.0}, "speed"),
        ({"stand_time": -1.0}, "stand_time"),
        ({"group": -2}, "group"),
    ],
)
def test_bad_behaviour_fields_name_the_field(change, message):
    with pytest.raises(ConfigError, match=r"pedestrians\[0\]\." + message.replace("[", r"\[")):
        Scenario(pedestrians=[_ped((0, 3), (0, -3), **change)]).validate()


def test_a_waypoint_inside_an_obstacle_is_refused():
    ped = _ped((0, 3), (0, -3), waypoints=[[2.0, 0.0]])
    disc = StaticDiscSpec(center=[2.0, 0.0], radius=0.3)
    with pytest.raises(ConfigError, match=r"waypoints\[0\].*inside obstacles\[0\]"):
        Scenario(pedestrians=[ped], obstacles=[disc]).validate()


def test_speeds_are_checked_against_orca():
    # the follower's maximum ORCA speed lets it catch up: 1.5 x its own
    group = [_ped((-3, 0), (3, 0), group=4), _ped((-3, 1), (3, 1), group=4, speed=0.6)]
    crowd = Crowd(Scenario(pedestrians=group).validate(), EmoNavConfig())
    assert crowd.routes.max_speeds.tolist() == [1.0, pytest.approx(0.9)]
    assert crowd.routes.leaders.tolist() == [-1, 0]
    assert math.isclose(crowd.routes.speeds[1], 0.6)
