"""`NavigationPlanner` owns its rate: one plan per walking step, its memory in the Context.

Real systems and the real OSQP solver throughout (no mocks).
"""

import copy
import logging

import numpy as np
import pytest
from pydrake.common.value import AbstractValue
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder, EventStatus
from pydrake.systems.primitives import ConstantValueSource, ConstantVectorSource

from emonav_drake.crowd.crowd import Crowd
from emonav_drake.diagrams.navigation import NavigationDiagram, build_navigation_diagram
from emonav_drake.navigation.lip_world import NavigationWorld, PlannerInput
from emonav_drake.params import EmoNavConfig
from emonav_drake.planners import configure_for, make_planner
from emonav_drake.planners.dwa import DwaPlanner
from emonav_drake.planners.mpc import MpcMemory, MpcPlanner
from emonav_drake.planners.replay import ReplayPlanner
from emonav_drake.robot.lip import LipState, lip_in_step
from emonav_drake.scenarios.scenario import sample_scenario
from emonav_drake.systems.episode_monitor import episode_monitor_callback
from emonav_drake.systems.lip_robot_plant import LipRobotPlant
from emonav_drake.systems.navigation_planner import NavigationPlanner

SEED = 4  # 4 pedestrians and 3 static discs: the MPC uses its guide path and warm starts


def _config(max_steps: int = 30) -> EmoNavConfig:
    cfg = EmoNavConfig()
    cfg.episode.max_steps = max_steps
    return cfg


def _build(name: str, cfg: EmoNavConfig, seed: int = SEED) -> NavigationDiagram:
    planner = make_planner(name, cfg)
    cfg, kind = configure_for(planner, cfg)
    return build_navigation_diagram(
        sample_scenario(seed, cfg), cfg, planner, grid_kind=kind, goal_radius=0.2
    )


def _simulator(nav: NavigationDiagram, context=None, monitor=None) -> Simulator:
    sim = Simulator(nav.diagram) if context is None else Simulator(nav.diagram, context)
    sim.set_monitor(monitor or episode_monitor_callback(nav.diagram, nav.monitor))
    sim.Initialize()
    return sim


def _status(nav: NavigationDiagram, ctx):
    return nav.monitor.GetOutputPort("status").Eval(nav.monitor.GetMyContextFromRoot(ctx))


def _observe(nav: NavigationDiagram, ctx) -> tuple:
    """The world at t_k, before the updates at t_k: robot, command held (u_{k−1}),
    pedestrian positions, the planner's plan log."""
    return (
        ctx.get_time(),
        nav.robot.GetOutputPort("robot_state").Eval(nav.robot.GetMyContextFromRoot(ctx)).copy(),
        nav.planner.GetOutputPort("command").Eval(nav.planner.GetMyContextFromRoot(ctx)).copy(),
        nav.crowd.GetOutputPort("crowd").Eval(nav.crowd.GetMyContextFromRoot(ctx)).positions.copy(),
        nav.planner.plan_log(nav.planner.GetMyContextFromRoot(ctx)),
    )


def _step(nav: NavigationDiagram, sim: Simulator) -> tuple | None:
    """Advance one walking step (None if the episode is over)."""
    ctx = sim.get_mutable_context()
    if _status(nav, ctx).done:
        return None
    T = nav.planner.step_time
    sim.AdvanceTo((round(ctx.get_time() / T) + 1) * T)
    return _observe(nav, ctx)


def _play(nav: NavigationDiagram, sim: Simulator, steps: int | None = None) -> list:
    """Walk until the episode ends (or for `steps` steps); the per-step observations,
    then the episode record."""
    log = []
    while steps is None or len(log) < steps:
        obs = _step(nav, sim)
        if obs is None:
            break
        log.append(obs)
    if steps is None:
        log.append(_status(nav, sim.get_context()).record.to_json())
    return log


def _assert_same(a: list, b: list) -> None:
    assert len(a) == len(b)
    for x, y in zip(a, b, strict=True):
        if isinstance(x, tuple):
            assert x[0] == y[0] and x[4] == y[4]
            for u, v in zip(x[1:4], y[1:4], strict=True):
                assert np.array_equal(u, v)
        else:
            assert x == y


def _mpc_memory_bits(memory: MpcMemory) -> tuple:
    plan = memory.plan
    return (
        None if plan is None else (plan.u.tobytes(), plan.y.tobytes(), plan.key, plan.step),
        memory.guide_key,
        None if memory.guide is None else memory.guide.dist.tobytes(),
    )


# ----------------------------------------------------------------------------- (a) rate


def test_the_command_is_a_state_output_and_the_plant_reads_it():
    nav = _build("dwa", _config())
    plan = nav.planner
    # robot_state, crowd, lgm_stack, goal (a route's sub-goal, unconnected): no last_command
    assert plan.num_input_ports() == 4
    assert not plan.HasAnyDirectFeedthrough()
    for i in range(plan.num_input_ports()):
        assert not plan.HasDirectFeedthrough(i, plan.GetOutputPort("command").get_index())
    # the plant shows the command of the step in progress: feedthrough command → state
    robot = nav.robot
    assert robot.num_output_ports() == 1  # robot_state only: no last_command
    assert robot.HasDirectFeedthrough(
        robot.GetInputPort("command").get_index(), robot.GetOutputPort("robot_state").get_index()
    )


def test_the_planner_alone_plans_every_0_4_s_from_t_0():
    """With constant inputs the planner's own event is the only one: the simulator stops
    exactly at its times, which are k·0.4 (period 0.4, offset 0)."""
    cfg = _config()
    sc = sample_scenario(SEED, cfg)
    crowd = Crowd(sc, cfg)
    b = DiagramBuilder()
    plan = b.AddNamedSystem("planner", NavigationPlanner(DwaPlanner(cfg), sc.robot_goal, cfg))
    robot = b.AddSystem(ConstantVectorSource(np.array([*sc.robot_start, 0.0, 0.0])))
    snapshot = crowd.snapshot(crowd.initial_state())
    crowd_src = b.AddSystem(ConstantValueSource(AbstractValue.Make(snapshot)))
    b.Connect(robot.get_output_port(), plan.GetInputPort("robot_state"))
    b.Connect(crowd_src.get_output_port(), plan.GetInputPort("crowd"))
    diagram = b.Build()
    seen = []

    def monitor(root):
        seen.append((root.get_time(), plan.plan_log(plan.GetMyContextFromRoot(root))))
        return EventStatus.Succeeded()

    sim = Simulator(diagram)
    sim.set_monitor(monitor)
    sim.Initialize()
    t0, log0 = seen[-1]
    assert t0 == 0.0 and np.isnan(log0[0]) and log0[1:] == (0, 0)
    sim.AdvanceTo(2.0)
    times = [t for t, _ in seen if t > 0]
    assert times == [k * 0.4 for k in range(1, 6)]
    # before the update at t_k the planner has planned at t_0 … t_{k−1}
    for k, (_, (t_plan, plans, clips)) in enumerate(seen[-5:], start=1):
        assert t_plan == (k - 1) * 0.4 and plans == k and clips == 0
    # the planner's input: its own previous command, (0, 0) before the first step
    ctx = plan.GetMyContextFromRoot(sim.get_context())
    obs = plan.planner_input(ctx)
    assert np.array_equal(obs.last_command, plan.GetOutputPort("command").Eval(ctx))
    fresh = plan.GetMyContextFromRoot(diagram.CreateDefaultContext())
    assert np.array_equal(plan.planner_input(fresh).last_command, [0.0, 0.0])


def test_over_an_episode_the_planner_plans_exactly_at_each_step():
    cfg = _config(max_steps=125)
    nav = _build("dwa", cfg)
    T = cfg.robot.step_time
    seen = []
    stop = episode_monitor_callback(nav.diagram, nav.monitor)

    def monitor(root):
        seen.append((root.get_time(), nav.planner.plan_log(nav.planner.GetMyContextFromRoot(root))))
        return stop(root)

    sim = _simulator(nav, monitor=monitor)
    log = _play(nav, sim)
    record = log[-1]
    steps = _status(nav, sim.get_context()).record.steps
    assert record["outcome"] == "success" and steps > 20
    # at every stop of the simulator (crowd periods included) the planner has planned
    # once at each t_k = k·T strictly before now, the last one exactly at k·T
    assert len(seen) > 3 * steps
    for t, (t_plan, plans, clips) in seen[1:]:
        assert plans == sum(k * T < t for k in range(steps + 1))
        assert t_plan == (plans - 1) * T and clips == 0
    # one plan per walking step: the episode ends at t_K without planning there
    assert seen[-1][0] == steps * T and seen[-1][1][1] == steps
    # at t_k the robot ends the step walked with the command held since t_{k−1}: its
    # speed at the foot switch is that command's u_v (the LIP step map, Eq. 1)
    for k, (t, robot, command, _, (t_plan, plans, _)) in enumerate(log[:-1], start=1):
        assert t == k * T and t_plan == (k - 1) * T and plans == k
        assert robot[3] == command[0]


# ------------------------------------------------------- (b) fresh contexts, no reset()


@pytest.mark.slow
@pytest.mark.parametrize("name", ["dwa", "mpc", "policy"])
def test_two_simulations_of_the_same_diagram_are_identical_without_reset(name):
    cfg = _config()
    nav = _build(name, cfg)
    planner = nav.planner.planner
    first = _play(nav, _simulator(nav))
    # The planner object is used elsewhere in between (its own memory, OSQP workspaces):
    # the diagram does not care.
    world_cfg, kind = configure_for(planner, cfg)
    world = NavigationWorld(sample_scenario(SEED + 1, cfg), world_cfg, grid_kind=kind)
    for _ in range(3):
        world.step(planner.plan(world.planner_input()))
    # again in the same simulator, from the diagram's default context
    sim = _simulator(nav)
    sim.get_mutable_context().SetTimeStateAndParametersFrom(nav.diagram.CreateDefaultContext())
    sim.Initialize()
    second = _play(nav, sim)
    # and in a new simulator
    third = _play(nav, _simulator(nav))
    _assert_same(first, second)
    _assert_same(first, third)
    commands = np.array([obs[2] for obs in first[:-1]])
    assert len(commands) == first[-1]["steps"]
    assert np.abs(commands).sum() > 0  # it did walk


# ------------------------------------------------------------- (c) cloned contexts


@pytest.mark.slow
@pytest.mark.parametrize("name", ["mpc", "dwa"])
def test_a_cloned_context_continues_independently(name):
    cfg = _config(max_steps=40)
    nav = _build(name, cfg)
    reference = _play(nav, _simulator(nav))
    k0 = 8
    sim_a = _simulator(nav)
    _assert_same(_play(nav, sim_a, steps=k0), reference[:k0])
    ctx_a = sim_a.get_mutable_context()
    clone = ctx_a.Clone()
    pa = nav.planner.GetMyContextFromRoot(ctx_a)
    pb = nav.planner.GetMyContextFromRoot(clone)
    memory_index = 0  # the planner's only abstract state
    mem_a = pa.get_abstract_state(memory_index).get_value()
    mem_b = pb.get_abstract_state(memory_index).get_value()
    if name == "mpc":
        assert mem_a.plan is not None and mem_a.plan.step == k0 - 1  # a warm start
        assert mem_a is not mem_b and mem_a.plan.u is not mem_b.plan.u
        assert _mpc_memory_bits(mem_a) == _mpc_memory_bits(mem_b)
    before = (copy.deepcopy(mem_a), ctx_a.get_time(), _observe(nav, ctx_a))
    sim_b = _simulator(nav, clone)
    # advancing the clone does not change the original …
    log_b = _play(nav, sim_b, steps=3)
    _assert_same(log_b, reference[k0 : k0 + 3])
    after = pa.get_abstract_state(memory_index).get_value()
    assert ctx_a.get_time() == before[1]
    _assert_same([_observe(nav, ctx_a)], [before[2]])
    if name == "mpc":
        assert _mpc_memory_bits(after) == _mpc_memory_bits(before[0])
    # … and both continue the reference, interleaved step by step
    log_a = []
    while True:
        a, b = _step(nav, sim_a), _step(nav, sim_b)
        if a is not None:
            log_a.append(a)
        if b is not None:
            log_b.append(b)
        if a is None and b is None:
            break
    log_a.append(_status(nav, ctx_a).record.to_json())
    log_b.append(_status(nav, clone).record.to_json())
    _assert_same(log_a, reference[k0:])
    _assert_same(log_b, reference[k0:])


# --------------------------------------------- (d) MPC: a function of (input, memory)


@pytest.mark.slow
def test_mpc_command_and_memory_depend_only_on_input_and_memory():
    cfg = _config()
    # an episode in the numpy world: (input, memory) → (command, next memory) per step
    world = NavigationWorld(sample_scenario(SEED, cfg), cfg, grid_kind=None)
    a = MpcPlanner(cfg)
    memory = a.initial_memory()
    steps = []
    for _ in range(30):
        obs = world.planner_input()
        u, new = a.plan_with_memory(obs, memory)
        steps.append((obs, memory, u, new))
        memory = new
        if world.step(u)[1]:
            break
    # random problems with far goals (large linear costs: where OSQP's re-scaling once
    # depended on the previous problem's q)
    rng = np.random.default_rng(1)
    cases = []
    for _ in range(60):
        xy = rng.uniform(-4, 4, 2)
        crowd = world.planner_input().crowd
        p, s = int(rng.integers(0, 3)), int(rng.integers(0, 2))
        crowd = _crowd(
            crowd,
            xy + rng.uniform(-2, 2, (p, 2)),
            rng.uniform(-1, 1, (p, 2)),
            xy + rng.uniform(-2, 2, (s, 2)),
            rng.uniform(0.2, 0.4, s),
        )
        obs = PlannerInput(
            robot=LipState(*xy, rng.uniform(-np.pi, np.pi), rng.uniform(0, 0.4)),
            goal_xy=rng.uniform(-5, 5, 2) * rng.choice([1.0, 100.0]),
            last_command=np.array([rng.uniform(0, 0.4), rng.uniform(-0.2, 0.2)]),
            crowd=crowd,
            lgm_stack=None,
            step=0,
        )
        u, new = a.plan_with_memory(obs, None)
        cases.append((obs, None, u, new))
    # Replayed in another order on the same planner object (its OSQP workspaces have
    # solved other problems since) and on fresh planners: the same bits.
    order = rng.permutation(len(steps) + len(cases))
    everything = steps + cases
    for i in order:
        obs, mem, u, new = everything[i]
        kept = copy.deepcopy(mem)
        for planner in (a, MpcPlanner(cfg)):
            u2, new2 = planner.plan_with_memory(obs, mem)
            assert np.array_equal(u, u2), i
            assert _mpc_memory_bits(new) == _mpc_memory_bits(new2), i
        if mem is not None:  # the memory given is never modified
            assert _mpc_memory_bits(mem) == _mpc_memory_bits(kept)


def _crowd(base, positions, velocities, centers, radii):
    """`base` with other pedestrians (emotion 1) and discs."""
    import dataclasses as dc

    n = len(positions)
    return dc.replace(
        base,
        positions=np.asarray(positions, float).reshape(-1, 2),
        velocities=np.asarray(velocities, float).reshape(-1, 2),
        emotions=np.ones(n, np.int64),
        discomfort=np.full(n, float(base.discomfort[0]) if len(base.discomfort) else 0.5),
        static_centers=np.asarray(centers, float).reshape(-1, 2),
        static_radii=np.asarray(radii, float),
    )


def test_mpc_step_in_a_fresh_context_with_the_same_memory_is_bit_identical():
    """Step k planned in context A (planner object 1, which has solved other problems in
    the meantime) and in a fresh context B of another diagram (planner object 2, new)
    holding the same state: the same command and the same next memory."""
    cfg = _config()
    nav1, nav2 = _build("mpc", cfg), _build("mpc", cfg)
    k = 10
    sim_a = _simulator(nav1)
    _play(nav1, sim_a, steps=k)
    ctx_a = sim_a.get_mutable_context()
    ctx_b = nav2.diagram.CreateDefaultContext()
    ctx_b.SetTimeStateAndParametersFrom(ctx_a)
    sim_b = _simulator(nav2, ctx_b)
    # pollute planner 1's OSQP workspaces with other problems of the same layout
    world = NavigationWorld(sample_scenario(SEED, cfg), cfg, grid_kind=None)
    for _ in range(5):
        world.step(nav1.planner.planner.plan(world.planner_input()))
    a, b = _step(nav1, sim_a), _step(nav2, sim_b)
    _assert_same([a], [b])
    # after the update at t_k (run by the step above) both hold u_k and the same memory
    mem_a = nav1.planner.memory(nav1.planner.GetMyContextFromRoot(ctx_a))
    mem_b = nav2.planner.memory(nav2.planner.GetMyContextFromRoot(ctx_b))
    assert mem_a.plan.step == k and _mpc_memory_bits(mem_a) == _mpc_memory_bits(mem_b)


# ------------------------------------------------------------- command checks


def test_out_of_range_commands_are_clipped_counted_and_logged_once_per_step(caplog):
    cfg = _config(max_steps=4)
    planner = ReplayPlanner([[0.9, 0.5], [0.3, 0.0], [0.5, -0.3], [0.2, 0.1]])
    nav = build_navigation_diagram(sample_scenario(0, cfg), cfg, planner)
    with caplog.at_level(logging.WARNING):
        log = _play(nav, _simulator(nav))
    commands = np.array([obs[2] for obs in log[:-1]])
    assert np.array_equal(commands, [[0.4, 0.2], [0.3, 0.0], [0.4, -0.2], [0.2, 0.1]])
    assert log[-2][4] == (3 * cfg.robot.step_time, 4, 2)  # plans, clipped commands
    warnings = [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING]
    assert len(warnings) == 2
    assert "planner" in warnings[0] and "t = 0.00 s" in warnings[0] and "0.9" in warnings[0]
    assert "planner" in warnings[1] and "t = 0.80 s" in warnings[1] and "-0.3" in warnings[1]


def test_the_plant_walks_the_held_command_and_clips_it_with_one_warning_per_step(caplog):
    """Any command source works: the plant clips silently in its output and warns once
    per walked step in its update."""
    cfg = _config()
    sc = sample_scenario(0, cfg)
    b = DiagramBuilder()
    robot = b.AddNamedSystem("robot", LipRobotPlant(sc, cfg))
    source = b.AddSystem(ConstantVectorSource(np.array([0.9, 0.0])))
    b.Connect(source.get_output_port(), robot.GetInputPort("command"))
    diagram = b.Build()
    sim = Simulator(diagram)
    sim.Initialize()
    T = cfg.robot.step_time
    port = robot.GetOutputPort("robot_state")
    with caplog.at_level(logging.WARNING):
        sim.AdvanceTo(3 * T)
        state = port.Eval(robot.GetMyContextFromRoot(sim.get_context()))
    assert state[3] == cfg.robot.max_speed  # v_{k+1} = u_v, clipped to 0.4
    warnings = [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING]
    assert len(warnings) == 2  # steps 0 and 1 ended at t = 0.4 and 0.8; step 2 is at its end
    assert all("LipRobotPlant" in w and "robot" in w and "clipped" in w for w in warnings)
    # mid-step, the output is the LIP trajectory of the command in force (Eq. 1)
    ctx = sim.get_mutable_context()
    sim.AdvanceTo(3 * T + 0.25)
    mid = port.Eval(robot.GetMyContextFromRoot(ctx))
    start = LipState(*state)
    r = cfg.robot
    expected = lip_in_step(start, r.max_speed, 0.0, r.omega, T, 0.25)
    assert mid == pytest.approx(np.array(expected), abs=1e-12)
