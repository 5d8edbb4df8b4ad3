"""The route on the known static map (`scenarios/global_route.py`): checked against the geometry."""

from __future__ import annotations

import math

import numpy as np
import pytest

from emonav_drake.scenarios.global_route import (
    NoRouteError,
    StaticMap,
    _segment_distances,
    lookahead_point,
    plan_route,
    route_length,
)
from emonav_drake.scenarios.walls import point_segment_distances

CLEARANCE = 0.35


def min_clearance(route: np.ndarray, static_map: StaticMap, step: float = 0.005) -> float:
    """The smallest distance from any point of the route (sampled every `step`) to any
    obstacle's surface (wall segment or disc)."""
    pts = []
    for a, b in zip(route[:-1], route[1:], strict=True):
        n = max(2, int(np.hypot(*(b - a)) / step) + 1)
        pts.append(a + np.linspace(0, 1, n)[:, None] * (b - a))
    pts = np.concatenate(pts)
    best = math.inf
    if len(static_map.walls):
        best = min(best, min(point_segment_distances(p, static_map.walls).min() for p in pts))
    if len(static_map.radii):
        d = (
            np.hypot(
                pts[:, None, 0] - static_map.centers[None, :, 0],
                pts[:, None, 1] - static_map.centers[None, :, 1],
            )
            - static_map.radii
        )
        best = min(best, float(d.min()))
    return best


def office() -> StaticMap:
    """Three rooms (4 × 4 m) side by side along x from 0 to 12, each wall between rooms with
    a 1.2 m door; the outer walls closed."""
    walls = [
        [[0, 0], [12, 0]],
        [[12, 0], [12, 4]],
        [[12, 4], [0, 4]],
        [[0, 4], [0, 0]],  # outside
        [[4, 0], [4, 1.4]],
        [[4, 2.6], [4, 4]],  # door at y 1.4-2.6
        [[8, 0], [8, 2.6]],
        [[8, 3.8], [8, 4]],  # door at y 2.6-3.8
    ]
    return StaticMap.of(walls, [[6.0, 1.5]], [0.4])


def test_an_empty_world_gives_the_straight_line():
    route = plan_route([-4, 0], [4, 0], StaticMap.of(), CLEARANCE)
    assert np.array_equal(route, [[-4, 0], [4, 0]])
    assert lookahead_point(route, [-4, 0.5], 2.0).tolist() == [-2.0, 0.0]


def test_a_wall_between_start_and_goal_is_walked_around_at_the_clearance():
    m = StaticMap.of([[[0, -1], [0, 1]]])
    route = plan_route([-2, 0], [2, 0], m, CLEARANCE)
    assert len(route) > 2 and min_clearance(route, m) >= CLEARANCE - 1e-6
    corner = math.hypot(2, 1)  # to the wall's end and on: a lower bound
    assert 2 * corner < route_length(route) < 2 * corner + CLEARANCE * math.pi / 2
    # same map, same route (bit for bit)
    assert np.array_equal(plan_route([-2, 0], [2, 0], m, CLEARANCE), route)


def test_the_route_crosses_an_office_floor_through_its_doors():
    m = office()
    route = plan_route([1, 1], [11, 1], m, CLEARANCE)
    assert min_clearance(route, m) >= CLEARANCE - 1e-6
    xs = np.linspace(0, 1, 2000)[:, None]
    dense = np.concatenate([a + xs * (b - a) for a, b in zip(route[:-1], route[1:], strict=True)])
    # where it crosses x = 4 and x = 8: inside the doors
    for x, (lo, hi) in ((4.0, (1.4, 2.6)), (8.0, (2.6, 3.8))):
        at = dense[np.argmin(np.abs(dense[:, 0] - x))]
        assert lo + CLEARANCE - 1e-3 <= at[1] <= hi - CLEARANCE + 1e-3, (x, at)


def test_no_route_is_an_error_that_says_why():
    m = office()
    with pytest.raises(NoRouteError, match=r"start .* within 0.35 m of wall 0"):
        plan_route([1, 0.1], [11, 1], m, CLEARANCE)
    with pytest.raises(NoRouteError, match="goal .* disc 0"):
        plan_route([1, 1], [6.0, 1.7], m, CLEARANCE)
    closed = StaticMap.of([*m.walls.tolist(), [[8, 2.6], [8, 3.8]]], m.centers, m.radii)
    with pytest.raises(NoRouteError, match="close it off"):
        plan_route([1, 1], [11, 1], closed, CLEARANCE)
    # a door narrower than the robot: closed too
    with pytest.raises(NoRouteError, match="close it off"):
        plan_route([1, 1], [11, 1], m, 0.65)


@pytest.mark.slow
def test_segment_distances_match_a_brute_force():
    rng = np.random.default_rng(5)
    p0, p1 = rng.uniform(-2, 2, (40, 2)), rng.uniform(-2, 2, (40, 2))
    q0, q1 = rng.uniform(-2, 2, (7, 2)), rng.uniform(-2, 2, (7, 2))
    p1[0] = p0[0]  # a point
    q1[1] = q0[1] + (q1[0] - q0[0])  # parallel to q[0]
    got = _segment_distances(p0, p1, q0, q1)
    u = np.linspace(0, 1, 801)[:, None]
    for e in range(len(p0)):
        a = p0[e] + u * (p1[e] - p0[e])
        for w in range(len(q0)):
            b = q0[w] + u * (q1[w] - q0[w])
            brute = np.hypot(a[:, None, 0] - b[None, :, 0], a[:, None, 1] - b[None, :, 1]).min()
            assert got[e, w] <= brute + 1e-12 and got[e, w] >= brute - 5e-3


def test_the_lookahead_walks_along_the_route_and_stops_at_its_end():
    route = np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 2.0]])
    assert np.allclose(lookahead_point(route, [0.5, 0.3], 1.0), [1.5, 0.0])
    assert np.allclose(lookahead_point(route, [1.5, 0.0], 1.0), [2.0, 0.5])
    assert np.allclose(lookahead_point(route, [2.1, 1.9], 5.0), [2.0, 2.0])


def test_the_route_planner_system_plans_gives_the_subgoal_and_replans_when_strayed():
    from pydrake.systems.analysis import Simulator

    from emonav_drake.systems.global_route_planner import GlobalRoutePlanner

    m = office()
    planner = GlobalRoutePlanner(m, [11.0, 1.0], CLEARANCE, 0.3, period=0.4, lookahead=2.0)
    ctx = planner.CreateDefaultContext()
    port = planner.GetInputPort("robot_state")
    port.FixValue(ctx, np.array([1.0, 1.0, 0.0, 0.0]))
    sim = Simulator(planner, ctx)
    sim.Initialize()
    route = planner.GetOutputPort("route").Eval(ctx)
    assert np.allclose(route[0], [1, 1]) and np.allclose(route[-1], [11, 1])
    sub = planner.GetOutputPort("subgoal").Eval(ctx)
    assert np.allclose(sub, lookahead_point(route, [1, 1], 2.0))
    # a few metres on, on the route: the same route, the sub-goal moves along
    port.FixValue(ctx, np.array([*lookahead_point(route, [1, 1], 1.0), 0.0, 0.0]))
    sim.AdvanceTo(0.5)
    assert np.array_equal(planner.GetOutputPort("route").Eval(ctx), route)
    # pushed 1.5 m off it, closer to a wall than the clearance: replanned from there
    port.FixValue(ctx, np.array([2.0, 3.68, 0.0, 0.0]))
    sim.AdvanceTo(0.9)
    new = planner.GetOutputPort("route").Eval(ctx)
    assert np.allclose(new[0], [2.0, 3.68]) and np.allclose(new[-1], [11, 1])
    assert min_clearance(new, m) >= 0.3 - 1e-6  # planned with the reduced clearance


def test_with_a_global_route_the_planner_steers_to_the_subgoal_and_without_to_the_goal():
    from pydrake.systems.framework import DiagramBuilder

    from emonav_drake.diagrams.navigation import AddNavigationStack, build_navigation_diagram
    from emonav_drake.params import EmoNavConfig
    from emonav_drake.planners import make_planner
    from emonav_drake.scenarios.scenario import sample_scenario
    from emonav_drake.systems.lip_robot_plant import LipRobotPlant

    cfg = EmoNavConfig()
    cfg.crowd.family = "corner_traffic"
    scenario = sample_scenario(6001, cfg)
    assert scenario.walls
    b = DiagramBuilder()
    robot = b.AddNamedSystem("robot", LipRobotPlant(scenario, cfg))
    stack = AddNavigationStack(
        b,
        scenario,
        cfg,
        make_planner("dwa", cfg),
        robot.GetOutputPort("robot_state"),
        global_route=True,
    )
    b.Connect(stack.planner.GetOutputPort("command"), robot.GetInputPort("command"))
    diagram = b.Build()
    ctx = diagram.CreateDefaultContext()
    diagram.ExecuteInitializationEvents(ctx)
    route_sys = diagram.GetSubsystemByName("global_route")
    route = route_sys.GetOutputPort("route").Eval(route_sys.GetMyContextFromRoot(ctx))
    goal = stack.planner.planner_input(stack.planner.GetMyContextFromRoot(ctx)).goal_xy
    assert len(route) > 2  # around the corner
    assert np.allclose(
        goal, route_sys.GetOutputPort("subgoal").Eval(route_sys.GetMyContextFromRoot(ctx))
    )
    assert not np.allclose(goal, scenario.robot_goal)
    default = build_navigation_diagram(scenario, cfg, make_planner("dwa", cfg))
    assert default.diagram.HasSubsystemNamed("global_route")  # on by default where walls are
    cfg.route.enabled = False
    plain = build_navigation_diagram(scenario, cfg, make_planner("dwa", cfg))
    assert not plain.diagram.HasSubsystemNamed("global_route")
    pctx = plain.diagram.CreateDefaultContext()
    assert np.allclose(
        plain.planner.planner_input(plain.planner.GetMyContextFromRoot(pctx)).goal_xy,
        scenario.robot_goal,
    )


def test_a_scene_whose_goal_no_route_reaches_is_refused_when_built():
    from emonav_drake.diagrams.navigation import build_navigation_diagram, make_route_planner
    from emonav_drake.params import ConfigError, EmoNavConfig
    from emonav_drake.planners import make_planner
    from emonav_drake.scenarios.scenario import Scenario, WallSpec

    cfg = EmoNavConfig()
    box = [[3, -1], [5, -1], [5, 1], [3, 1], [3, -1]]  # a closed room round the goal (4, 0)
    walls = [WallSpec(start=a, end=b) for a, b in zip(box[:-1], box[1:], strict=True)]
    closed = Scenario(walls=walls)
    with pytest.raises(ConfigError, match="cannot be reached: no route .* close it off"):
        make_route_planner(closed, cfg)
    # a 1.2 m door in the room's west wall opens it; without the route layer nothing is checked
    door = [
        *walls[:3],
        WallSpec(start=[3, 1], end=[3, 0.6]),
        WallSpec(start=[3, -0.6], end=[3, -1]),
    ]
    assert len(make_route_planner(Scenario(walls=door), cfg).follower.static_map.walls) == 5
    with pytest.raises(ConfigError, match="cannot be reached"):  # the layer is on by default
        build_navigation_diagram(closed, cfg, make_planner("dwa", cfg))
    cfg.route.enabled = False
    build_navigation_diagram(closed, cfg, make_planner("dwa", cfg))


def test_the_route_and_its_subgoal_are_drawn_in_meshcat():
    from pydrake.systems.analysis import Simulator
    from pydrake.systems.framework import DiagramBuilder

    from emonav_drake.diagrams.meshcat_viewing import make_meshcat
    from emonav_drake.diagrams.navigation import AddNavigationStack, AddNavigationVisualizer
    from emonav_drake.params import EmoNavConfig
    from emonav_drake.planners import make_planner
    from emonav_drake.scenarios.scenario import sample_scenario
    from emonav_drake.systems.lip_robot_plant import LipRobotPlant

    cfg = EmoNavConfig()
    cfg.crowd.family = "corner_traffic"
    scenario = sample_scenario(6001, cfg)
    meshcat = make_meshcat(live=False)
    b = DiagramBuilder()
    robot = b.AddNamedSystem("robot", LipRobotPlant(scenario, cfg))
    state = robot.GetOutputPort("robot_state")
    stack = AddNavigationStack(b, scenario, cfg, make_planner("dwa", cfg), state, global_route=True)
    b.Connect(stack.planner.GetOutputPort("command"), robot.GetInputPort("command"))
    AddNavigationVisualizer(b, stack, state, meshcat)
    diagram = b.Build()
    sim = Simulator(diagram)
    sim.Initialize()
    sim.AdvanceTo(2 * cfg.robot.step_time)
    assert meshcat.HasPath("/emonav/route/0") and meshcat.HasPath("/emonav/subgoal")
    route = stack.route.route(stack.route.GetMyContextFromRoot(sim.get_context()))
    assert len(route) > 2  # round the corner


@pytest.mark.slow
def test_sim_global_route_flag_builds_the_route_layer_and_says_so(tmp_path):
    """`emonav sim` on the office floor: the route layer runs by default (and with
    `--global-route`), the JSON says so, and the robot walks from its room into the goal's
    room; `--no-global-route` leaves it out."""
    import json

    from emonav_drake.cli import main

    out = tmp_path / "r.json"
    args = ["sim", "--family", "office", "--seed", "3", "--plant", "lip", "--planner", "mpc"]
    assert main([*args, "--global-route", "--json", str(out), "--quiet"]) == 0
    rec = json.loads(out.read_text())
    assert rec["global_route"] is True and rec["outcome"] == "success"
    default = tmp_path / "default.json"
    assert main([*args, "--json", str(default), "--quiet"]) == 0
    assert json.loads(default.read_text()) == rec
    plain = tmp_path / "plain.json"
    assert main([*args, "--no-global-route", "--json", str(plain), "--quiet"]) == 0
    assert json.loads(plain.read_text())["global_route"] is False


def two_doors() -> list[list[list[float]]]:
    """Two 4 × 4 m rooms side by side along x (0-8), the wall between them at x = 4 with two
    1.2 m doors (y 0.4-1.6 and 2.4-3.6); the outer walls closed."""
    return [
        [[0, 0], [8, 0]],
        [[8, 0], [8, 4]],
        [[8, 4], [0, 4]],
        [[0, 4], [0, 0]],
        [[4, 0], [4, 0.4]],
        [[4, 1.6], [4, 2.4]],
        [[4, 3.6], [4, 4]],
    ]


def test_a_disc_put_in_a_doorway_replans_through_the_other_door_then_leaves_no_route():
    from pydrake.systems.analysis import Simulator

    from emonav_drake.systems.global_route_planner import GlobalRoutePlanner

    m = StaticMap.of(two_doors(), [[4.0, 1.0], [4.0, 3.0]], [0.5, 0.5])
    planner = GlobalRoutePlanner(m, [7.0, 1.0], CLEARANCE, 0.3, period=0.4, appear_times=[0.5, 1.0])
    ctx = planner.CreateDefaultContext()
    planner.GetInputPort("robot_state").FixValue(ctx, np.array([1.0, 1.0, 0.0, 0.0]))
    sim = Simulator(planner, ctx)
    sim.Initialize()
    route = planner.GetOutputPort("route").Eval(ctx)
    has_route = planner.GetOutputPort("has_route")
    crossing = route[np.argmin(np.abs(route[:, 0] - 4.0))]
    assert has_route.Eval(ctx)[0] == 1.0 and crossing[1] < 1.6  # through the lower door
    sim.AdvanceTo(0.45)  # before the first disc: the same route
    assert np.array_equal(planner.GetOutputPort("route").Eval(ctx), route)
    sim.AdvanceTo(0.85)  # the lower door blocked at 0.5 s: replanned at 0.8 s
    new = planner.GetOutputPort("route").Eval(ctx)
    ys = [y for x, y in new if 3.0 < x < 5.0]
    assert min(ys) > 2.4 - 1e-9 and has_route.Eval(ctx)[0] == 1.0  # through the upper door
    assert min_clearance(new, planner.map_at(0.85)) >= CLEARANCE - 1e-6
    sim.AdvanceTo(1.25)  # both doors blocked: no route left, the last one kept
    assert has_route.Eval(ctx)[0] == 0.0
    assert np.array_equal(planner.GetOutputPort("route").Eval(ctx), new)


def _doorway_scene(appears_at: float):
    from emonav_drake.scenarios.scenario import Scenario, StaticDiscSpec, WallSpec

    walls = [WallSpec(start=a, end=b) for a, b in two_doors()[:5]]  # the lower door only
    walls.append(WallSpec(start=[4, 1.6], end=[4, 4]))
    cart = StaticDiscSpec(center=[4.0, 1.0], radius=0.5, appears_at=appears_at)
    return Scenario(
        walls=walls, obstacles=[cart], robot_start=[1.0, 1.0], robot_goal=[7.0, 1.0], seed=5
    )


@pytest.mark.slow
def test_a_robot_whose_only_door_is_closed_ends_its_trial_with_no_route():
    from emonav_drake.crowd.crowd import Crowd
    from emonav_drake.diagrams.episode import EpisodeRequest, run_navigation_episode
    from emonav_drake.diagrams.navigation import build_episode, make_route_planner
    from emonav_drake.params import ConfigError, EmoNavConfig
    from emonav_drake.planners import make_planner

    cfg = EmoNavConfig()
    cfg.route.enabled = False
    scenario = _doorway_scene(appears_at=1.0)
    crowd = Crowd(scenario, cfg)
    assert len(crowd.static_discs(0.9)[1]) == 0 and len(crowd.static_discs(1.0)[1]) == 1
    routed = EmoNavConfig()  # the route layer is on by default
    request = EpisodeRequest(scenario, routed, make_planner("dwa", routed))
    record, _ = run_navigation_episode(request, build_episode)
    # placed at 1.0 s, seen by the route layer at its update at 1.2 s, the trial ends at
    # the next walking step (1.6 s): an outcome, not a timeout
    assert record.outcome == "no_route" and record.steps == 4
    # without the route layer the same robot walks on into the closed door
    plain = EpisodeRequest(scenario, cfg, make_planner("dwa", cfg))
    assert run_navigation_episode(plain, build_episode)[0].outcome in {"timeout", "collision"}
    # placed before the scene starts, the cart makes the scene one no route solves
    with pytest.raises(ConfigError, match="cannot be reached"):
        make_route_planner(_doorway_scene(appears_at=0.0), routed)


@pytest.mark.slow
def test_the_closed_door_example_replans_through_the_other_door(tmp_path):
    """The shipped `closed_door`: a cart closes the robot's door at 3 s; DWA with the route
    layer goes round through the other door and arrives, DWA alone does not."""
    import json

    from emonav_drake.cli import main

    outcomes = {}
    for flags in (["--no-global-route"], []):
        out = tmp_path / f"{len(flags)}.json"
        args = ["sim", "--scenario", "closed_door", "--plant", "lip", "--planner", "dwa"]
        assert main([*args, *flags, "--json", str(out), "--quiet"]) == 0
        rec = json.loads(out.read_text())
        outcomes[not flags] = rec["outcome"]
        if not flags:  # by default (the route layer): through the upper door (y > 1)
            robot = np.asarray(rec["trajectory"]["robot"])
            near_wall = robot[np.abs(robot[:, 0]) < 0.3]
            assert len(near_wall) and (near_wall[:, 1] > 1.0).all()
    assert outcomes == {False: "timeout", True: "success"}


def test_widest_clearance_first_keeps_to_the_middle_of_a_door():
    from emonav_drake.systems.global_route_planner import GlobalRoutePlanner

    m = office()  # the first door: x = 4, y 1.4-2.6
    planner = GlobalRoutePlanner(m, [11.0, 1.0], [0.55, 0.4], 0.3, period=0.4)
    ctx = planner.CreateDefaultContext()
    planner.GetInputPort("robot_state").FixValue(ctx, np.array([1.0, 1.0, 0.0, 0.0]))
    planner.ExecuteInitializationEvents(ctx)  # only 0.05 m to spare each side: planned at 0.55
    route = planner.GetOutputPort("route").Eval(ctx)
    assert min_clearance(route, m) >= 0.55 - 1e-6
    tight = plan_route([1, 1], [11, 1], m, 0.3)  # at the radius alone it grazes the jamb
    for r, far in ((route, 0.05 + 1e-6), (tight, 0.3)):
        dense = np.concatenate(
            [
                a + np.linspace(0, 1, 400)[:, None] * (b - a)
                for a, b in zip(r[:-1], r[1:], strict=True)
            ]
        )
        y = dense[np.argmin(np.abs(dense[:, 0] - 4.0)), 1]
        assert abs(y - 2.0) <= far
    assert abs(tight[np.argmin(np.abs(tight[:, 0] - 4.0)), 1] - 2.0) > 0.2


def test_the_line_of_sight_subgoal_never_sends_the_robot_across_a_corner():
    from emonav_drake.scenarios.global_route import segments_clear
    from emonav_drake.systems.global_route_planner import GlobalRoutePlanner

    m = office()
    route = plan_route([1, 1], [11, 1], m, 0.4)
    cut = 0
    for seen in (False, True):
        planner = GlobalRoutePlanner(m, [11.0, 1.0], 0.4, 0.3, lookahead=3.0, line_of_sight=seen)
        ctx = planner.CreateDefaultContext()
        port = planner.GetInputPort("robot_state")
        port.FixValue(ctx, np.array([1.0, 1.0, 0.0, 0.0]))
        planner.ExecuteInitializationEvents(ctx)
        assert np.array_equal(planner.GetOutputPort("route").Eval(ctx), route)
        for s in np.linspace(0.0, route_length(route), 60):  # the robot along its route
            xy = lookahead_point(route, route[0], s)
            port.FixValue(ctx, np.array([*xy, 0.0, 0.0]))
            sub = planner.GetOutputPort("subgoal").Eval(ctx)
            clear = segments_clear(np.stack([xy, sub]), m, 0.3)
            if seen:
                assert clear, (xy, sub)
                # still ahead, not at the robot's feet (but near the goal: the goal)
                assert math.dist(xy, sub) > 0.3 or np.allclose(sub, [11, 1])
            else:
                cut += not clear
    assert cut > 0  # without it, a 3 m look-ahead cuts the jambs' corners


def _first_command(name: str, routed: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(the planner's first command, the goal it was given, the route layer's sub-goal or
    the goal) in a room whose wall stands across the straight line to the goal."""
    from pydrake.systems.analysis import Simulator

    from emonav_drake.diagrams.navigation import build_navigation_diagram
    from emonav_drake.params import EmoNavConfig
    from emonav_drake.planners import configure_for, make_planner
    from emonav_drake.scenarios.scenario import Scenario, WallSpec

    cfg = EmoNavConfig()
    cfg.route.enabled = routed
    scene = Scenario(
        walls=[WallSpec(start=[-2.5, -0.6], end=[-2.5, 4.0])],
        robot_start=[-4.0, 0.0],
        robot_goal=[4.0, 0.0],
    )
    planner = make_planner(name, cfg)
    cfg, kind = configure_for(planner, cfg)
    nav = build_navigation_diagram(scene, cfg, planner, grid_kind=kind)
    sim = Simulator(nav.diagram)
    sim.Initialize()
    sim.AdvanceTo(0.01)
    ctx = nav.planner.GetMyContextFromRoot(sim.get_context())
    goal = nav.planner.planner_input(ctx).goal_xy
    command = nav.planner.GetOutputPort("command").Eval(ctx)
    route = nav.diagram.GetSubsystemByName("global_route") if routed else None
    sub = (
        route.GetOutputPort("subgoal").Eval(route.GetMyContextFromRoot(sim.get_context()))
        if route is not None
        else np.asarray(scene.robot_goal, float)
    )
    return np.asarray(command), np.asarray(goal), np.asarray(sub)


@pytest.mark.parametrize("name", ["dwa", "mpc", "sarl", "rgl", "policy"])
def test_every_local_planner_steers_to_the_route_s_subgoal(name):
    command, goal, sub = _first_command(name, routed=True)
    assert np.allclose(goal, sub) and sub[1] < -0.5  # below the wall's end, not the goal
    if name in ("dwa", "policy"):  # these head for the goal without it; with it they turn
        plain, plain_goal, _ = _first_command(name, routed=False)
        assert np.allclose(plain_goal, [4.0, 0.0])
        assert command[1] < plain[1]  # the heading change: towards the sub-goal (right)


def test_the_route_layer_is_on_by_default_and_never_built_without_walls():
    """The default configuration enables the route layer, yet a scene of the paper's arena
    (no walls) gets no `global_route` system: the planner's goal is the episode's goal."""
    from emonav_drake.diagrams.navigation import build_navigation_diagram
    from emonav_drake.params import EmoNavConfig
    from emonav_drake.planners import make_planner
    from emonav_drake.scenarios.scenario import sample_scenario

    cfg = EmoNavConfig()
    assert cfg.route.enabled
    for seed in range(3):
        scenario = sample_scenario(seed, cfg)
        assert not scenario.walls
        nav = build_navigation_diagram(scenario, cfg, make_planner("dwa", cfg))
        assert not nav.diagram.HasSubsystemNamed("global_route")
        ctx = nav.diagram.CreateDefaultContext()
        goal = nav.planner.planner_input(nav.planner.GetMyContextFromRoot(ctx)).goal_xy
        assert np.array_equal(goal, scenario.robot_goal)
