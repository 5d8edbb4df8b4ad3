"""The building families (t_junction, doorway, office): the goal out of sight, a route for
the robot and for every pedestrian that keeps off the walls, and pedestrians who really
walk those routes through the doors in the crowd simulation."""

import numpy as np
import pytest

from emonav_drake.crowd.crowd import Crowd
from emonav_drake.params import EmoNavConfig
from emonav_drake.scenarios.global_route import StaticMap, clearance_violations, plan_route
from emonav_drake.scenarios.scenario import dump_scenario
from emonav_drake.scenarios.scenario_families import MIXED_FAMILIES, _crosses, sample_family

CFG = EmoNavConfig()
BUILDINGS = ("t_junction", "doorway", "office")
SEEDS = range(10)


def _map(scene) -> StaticMap:
    return StaticMap.of([[w.start, w.end] for w in scene.walls])


def _clear(path, walls: StaticMap, clearance: float) -> bool:
    """Whether every point of the polyline (sampled every few centimetres) keeps
    `clearance` [m] off every wall."""
    path = np.asarray(path, dtype=float)
    dense = [
        np.linspace(a, b, 40, endpoint=False) for a, b in zip(path[:-1], path[1:], strict=True)
    ]
    return not any(clearance_violations(np.concatenate([*dense, path[-1:]]), walls, clearance))


@pytest.mark.slow
@pytest.mark.parametrize("family", BUILDINGS)
def test_the_goal_is_out_of_sight_and_a_route_reaches_it_clear_of_the_walls(family):
    r = CFG.robot.radius
    for seed in SEEDS:
        scene = sample_family(family, seed)
        assert dump_scenario(scene) == dump_scenario(sample_family(family, seed))
        assert scene.walls
        assert _crosses(scene.robot_start, scene.robot_goal, scene.walls)  # a wall between
        walls = _map(scene)
        route = plan_route(scene.robot_start, scene.robot_goal, walls, r)
        assert len(route) >= 3  # it turns at least once
        assert _clear(route, walls, r - 1e-6)


@pytest.mark.parametrize("family", BUILDINGS)
def test_every_pedestrian_route_keeps_its_orca_disc_off_the_walls(family):
    c = CFG.crowd
    orca = c.pedestrian_radius + c.safety_space
    for seed in SEEDS:
        scene = sample_family(family, seed)
        walls = _map(scene)
        for ped in scene.pedestrians:
            path = [ped.start, *ped.waypoints, ped.goal]
            assert _clear(path, walls, orca), (family, seed)


def test_the_office_robot_leaves_one_room_and_enters_another():
    for seed in SEEDS:
        scene = sample_family("office", seed)
        assert scene.robot_start[1] < 0.0 and scene.robot_goal[1] < 0.0  # in rooms
        route = plan_route(scene.robot_start, scene.robot_goal, _map(scene), CFG.robot.radius)
        assert route[:, 1].max() > 0.0  # through the corridor, so through two doors
        # the rooms are side by side: start and goal are separated by a dividing wall
        dividers = [
            w for w in scene.walls if w.start[0] == w.end[0] and max(w.start[1], w.end[1]) == 0
        ]
        xs = sorted(w.start[0] for w in dividers)
        room = [int(np.searchsorted(xs, p[0])) for p in (scene.robot_start, scene.robot_goal)]
        assert room[0] != room[1]


@pytest.mark.slow
def test_pedestrians_walk_through_the_door_in_the_crowd_simulation():
    # doorway: the first one to three pedestrians start in the right room and walk to the
    # left one (and back: they walk to and fro); ORCA among themselves and the walls takes
    # them through the door, never through a wall
    through = arrived = crossed_a_wall = 0
    for seed in range(4):
        scene = sample_family("doorway", seed)
        crowd = Crowd(scene, CFG)
        state = crowd.initial_state()
        far, still = np.array([40.0, 40.0]), np.zeros(2)
        previous = np.array(state.positions, dtype=float)
        nearest = np.full(len(scene.pedestrians), np.inf)
        for _ in range(300):  # 30 s
            state = crowd.step(state, far, still)
            now = np.array(state.positions, dtype=float)
            crossed_a_wall += sum(
                _crosses(list(a), list(b), scene.walls) for a, b in zip(previous, now, strict=True)
            )
            previous = now
            goals = np.array([p.goal for p in scene.pedestrians])
            nearest = np.minimum(nearest, np.linalg.norm(now - goals, axis=1))
        for k, ped in enumerate(scene.pedestrians):
            if ped.start[0] > 0.0 and ped.goal[0] < 0.0:  # through the door
                through += 1
                arrived += nearest[k] < 0.3
    assert crossed_a_wall == 0
    assert through >= 4 and arrived == through


def test_the_mixed_training_family_keeps_its_scenes():
    # the buildings are not in `mixed`, so a mixed seed draws what it drew before they came
    assert not set(BUILDINGS) & set(MIXED_FAMILIES)
    assert len(MIXED_FAMILIES) == 15 and "paper" not in MIXED_FAMILIES


@pytest.mark.slow
def test_the_buildings_training_family_draws_every_family():
    from emonav_drake.scenarios.scenario_families import MIXED_BUILDINGS_FAMILIES

    assert set(BUILDINGS) <= set(MIXED_BUILDINGS_FAMILIES)
    assert len(MIXED_BUILDINGS_FAMILIES) == 18 and not any(
        n == "paper" or n.startswith("mixed") for n in MIXED_BUILDINGS_FAMILIES
    )
    scenes = [sample_family("mixed_buildings", seed) for seed in range(60)]
    walls = [len(s.walls) for s in scenes]
    # the office (10 walls) and the arena (none) both occur; the same seed, the same scene
    assert 10 in walls and 0 in walls
    assert sample_family("mixed_buildings", 7) == sample_family("mixed_buildings", 7)


@pytest.mark.slow
def test_walled_families_are_the_families_whose_scenes_have_walls():
    """The route layer is built only where a family's scenes have walls, and the labels
    name it only there: `WALLED_FAMILIES` must agree with the scenes drawn (`mixed` draws
    walled and open scenes alike, so both kinds occur among its seeds)."""
    from emonav_drake.scenarios.scenario_families import FAMILIES, WALLED_FAMILIES

    for name in FAMILIES:
        walled = [
            bool(sample_family(name, seed).walls)
            for seed in range(40 if name.startswith("mixed") else 3)
        ]
        if name.startswith("mixed"):
            assert name in WALLED_FAMILIES and any(walled) and not all(walled)
        else:
            assert all(walled) == (name in WALLED_FAMILIES) and len(set(walled)) == 1, name
