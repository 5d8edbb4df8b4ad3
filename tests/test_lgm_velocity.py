"""The "lgm_vel" observation (issue 53, item 2): the LGM stack followed by the velocities
of the pedestrians now, on the LGM's polar grid, in the robot frame — of the tracked
pedestrians when the maps ring the tracks. Built the same in the LIP world and the
diagram, mirrored exactly, kept whole by the DAgger store, trained by the CPU route."""

from __future__ import annotations

import dataclasses as dc

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator

from emonav_drake.crowd.crowd import CrowdSnapshot
from emonav_drake.diagrams.navigation import build_navigation_diagram
from emonav_drake.navigation.lip_world import NavigationWorld
from emonav_drake.navigation.observations import (
    mirror_observation,
    observation_frame,
    observation_kind,
    observation_shape,
)
from emonav_drake.params import EmoNavConfig, apply_deployable
from emonav_drake.planners.dwa import DwaPlanner
from emonav_drake.planners.replay import ReplayPlanner
from emonav_drake.robot.lip import LipState
from emonav_drake.scenarios.scenario import sample_scenario
from emonav_drake.sensing.kinematic_maps import LGM_VELOCITY_MAX_SPEED, lgm_velocity_planes

KIND = observation_kind("lgm_vel")


def _snapshot(positions, velocities) -> CrowdSnapshot:
    p = np.asarray(positions, float).reshape(-1, 2)
    return CrowdSnapshot(
        positions=p,
        velocities=np.asarray(velocities, float).reshape(-1, 2),
        radius=0.3,
        emotions=np.zeros(len(p), int),
        discomfort=np.full(len(p), 0.5),
        static_centers=np.array([[1.5, -2.0]]),
        static_radii=np.array([0.4]),
        static_discomfort=0.2,
    )


def test_a_walking_pedestrian_writes_its_robot_frame_velocity_under_its_disc():
    # 2 m ahead of a robot looking along +x, walking +x at 1 m/s: v_x = +1, v_y = 0
    planes = lgm_velocity_planes(np.zeros(2), 0.0, [[2.0, 0.0]], [[1.0, 0.0]], 0.3)
    assert planes.shape == (2, 100, 100) and planes.dtype == np.uint8
    cells = planes[0] != 128
    code = round(128 + 127 * 1.0 / LGM_VELOCITY_MAX_SPEED)
    assert set(np.unique(planes[0][cells])) == {code}
    assert (planes[1] == 128).all()  # no sideways velocity
    rows, cols = np.nonzero(cells)
    # the disc spans 1.7-2.3 m (rings of 6 cm: columns 28-38) straight ahead (the middle
    # sectors: the LGM's sector 0 looks behind the robot)
    assert 27 <= cols.min() and cols.max() <= 38 and set(rows) <= set(range(45, 55))
    # the robot turned to +y: the same walk is to its right (v_y < 0) and not forward
    turned = lgm_velocity_planes(np.zeros(2), np.pi / 2, [[0.0, 2.0]], [[1.0, 0.0]], 0.3)
    moving = turned[1] != 128
    assert moving.sum() == cells.sum()
    assert set(np.unique(turned[1][moving])) == {round(128 - 127 * 1.0 / 2.0)}
    assert (turned[0] == 128).all()
    # nobody in range, nobody at all: every cell at rest
    far = lgm_velocity_planes(np.zeros(2), 0.0, [[9.0, 0.0]], [[1.0, 0.0]], 0.3)
    assert (far == 128).all()
    assert (
        lgm_velocity_planes(np.zeros(2), 0.0, np.zeros((0, 2)), np.zeros((0, 2)), 0.3) == 128
    ).all()


def test_the_observation_of_the_mirrored_world_is_the_mirrored_observation():
    cfg = EmoNavConfig()
    robot = LipState(0.3, -0.2, 0.0, 0.3)
    positions = np.array([[2.0, 0.8], [1.0, -1.5], [-1.5, 2.5]])
    velocities = np.array([[0.4, -0.9], [-1.1, 0.3], [0.2, 0.6]])
    crowd = _snapshot(positions, velocities)
    flip = np.array([1.0, -1.0])
    mirrored = dc.replace(
        _snapshot(positions * flip, velocities * flip),
        static_centers=crowd.static_centers * flip,
    )
    robot_m = LipState(0.3, 0.2, 0.0, 0.3)
    frame = observation_frame(robot, crowd, cfg, "lgm_vel")
    assert frame.shape == (3, 100, 100) and (frame[1:] != 128).any()
    assert np.array_equal(
        mirror_observation(frame, "lgm_vel"),
        observation_frame(robot_m, mirrored, cfg, "lgm_vel"),
    )
    # on a stack (N LGM planes + the two velocity planes): mirroring twice is the identity
    stack = KIND.new_stack(cfg.lidar)
    stack.reset(frame)
    assert stack.array.shape == observation_shape("lgm_vel", cfg.lidar) == (11, 100, 100)
    twice = mirror_observation(mirror_observation(stack.array, "lgm_vel"), "lgm_vel")
    assert np.array_equal(twice, stack.array)


def _deployable(rings: str) -> EmoNavConfig:
    cfg = EmoNavConfig()
    apply_deployable(cfg)  # VLP-16 scan with its faults, planners on LiDAR tracks
    cfg.perception.map_rings = rings
    cfg.lidar.num_frames = 4
    return cfg.validate()


def test_the_diagram_builds_the_worlds_stack_with_the_tracked_velocities():
    """With the maps ringing the tracks, the velocity planes are the tracker's — the same
    stacks in the LIP world and the diagram, and not those from the simulator's crowd."""
    seed, steps = 5, 8
    cfg, truth_cfg = _deployable("tracks"), _deployable("truth")
    scenario = sample_scenario(seed, cfg)
    world = NavigationWorld(scenario, cfg, goal_radius=0.2, grid_kind="lgm_vel")
    truth = NavigationWorld(scenario, truth_cfg, goal_radius=0.2, grid_kind="lgm_vel")
    dwa, actions = DwaPlanner(cfg), []
    stacks, truth_stacks = [world.planner_input().lgm_stack], [truth.planner_input().lgm_stack]
    for _ in range(steps):
        actions.append(dwa.plan(world.planner_input()))
        world.step(actions[-1])
        truth.step(actions[-1])
        stacks.append(world.planner_input().lgm_stack)
        truth_stacks.append(truth.planner_input().lgm_stack)
    assert stacks[-1].shape == (6, 100, 100)
    assert any((s[-2:] != 128).any() for s in stacks)  # somebody walks in view
    assert any(
        not np.array_equal(a[-2:], b[-2:]) for a, b in zip(stacks, truth_stacks, strict=True)
    )
    nav = build_navigation_diagram(
        scenario, cfg, ReplayPlanner(np.array(actions)), grid_kind="lgm_vel", goal_radius=0.2
    )
    sim = Simulator(nav.diagram)
    sim.Initialize()
    ctx = sim.get_mutable_context()
    port = nav.grid_maps.GetOutputPort("lgm_stack")
    for k in range(steps):
        if k > 0:
            sim.AdvanceTo(k * cfg.robot.step_time)
        assert np.array_equal(port.Eval(nav.grid_maps.GetMyContextFromRoot(ctx)), stacks[k]), k


def test_a_saved_world_and_the_dagger_store_keep_the_whole_stack():
    cfg = _deployable("tracks")
    scenario = sample_scenario(7, cfg)
    world, dwa = NavigationWorld(scenario, cfg, grid_kind="lgm_vel"), DwaPlanner(cfg)
    items, stacks = [], []
    for _ in range(6):
        stack = world.planner_input().lgm_stack
        stacks.append(stack)
        items.append(KIND.newest(stack))
        world.step(dwa.plan(world.planner_input()))
    # what DAgger's frame store keeps per step rebuilds every stack of the episode
    n = cfg.lidar.num_frames
    assert items[0].shape == KIND.item_shape(cfg.lidar) == (3, 100, 100)
    for k, stack in enumerate(stacks):
        window = np.stack([items[max(0, k - n + 1 + j)] for j in range(n)])
        assert np.array_equal(KIND.from_items(window), stack), k
    batch = np.stack([np.stack([items[max(0, k - n + 1 + j)] for j in range(n)]) for k in (2, 5)])
    assert np.array_equal(KIND.from_items(batch), np.stack([stacks[2], stacks[5]]))
    # a saved world gives the same stack and walks on identically
    copy = NavigationWorld.from_state_dict(world.state_dict(), cfg)
    assert np.array_equal(copy.planner_input().lgm_stack, world.planner_input().lgm_stack)
    for _ in range(3):
        u = dwa.plan(world.planner_input())
        world.step(u)
        copy.step(u)
        assert np.array_equal(copy.planner_input().lgm_stack, world.planner_input().lgm_stack)


@pytest.mark.slow
def test_the_cpu_route_trains_a_student_on_lgm_vel(tmp_path):
    """The DAgger route end to end on the new observation (tiny budget): its checkpoint
    declares lgm_vel, its encoder reads N + 2 planes, and it runs in the diagram."""
    from emonav_drake.cli import main
    from emonav_drake.learning.config import DaggerConfig
    from emonav_drake.learning.dagger import train_dagger
    from emonav_drake.planners.policy import load_policy

    cfg = DaggerConfig(grid_kind="lgm_vel", num_frames=3, hidden=16)
    cfg.expert_episodes, cfg.episodes_per_round, cfg.rounds = 2, 1, 1
    cfg.grad_steps_first, cfg.grad_steps_per_round, cfg.batch_size = 4, 2, 8
    cfg.eval_episodes = 1
    train_dagger(tmp_path, cfg.validate(), command="test lgm_vel")
    _, meta = load_policy(tmp_path / "policy.pt")
    assert meta["observation"]["grid_kind"] == "lgm_vel"
    assert meta["observation"]["num_frames"] == 3 and meta["encoder"]["frames"] == 5
    short = tmp_path / "short.yaml"
    short.write_text("episode: {max_steps: 3}\n")
    argv = ["sim", "--planner", "policy", "--checkpoint", str(tmp_path / "policy.pt")]
    assert main([*argv, "--plant", "lip", "--config", str(short), "--seed", "4"]) == 0
