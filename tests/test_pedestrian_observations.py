"""The observations that give the student the pedestrians (issue 53, item 2), both the
LGM stack followed by the pedestrians now — of the tracked pedestrians when the maps ring
the tracks: "lgm_vel" (their velocities as planes on the LGM's polar grid) and
"lgm_tracks" (a table of the nearest, read by its own encoder: the tracks as a second
input). Built the same in the LIP world and the diagram, mirrored exactly, kept whole by
the DAgger store, trained by the CPU route."""

from __future__ import annotations

import dataclasses as dc

import numpy as np
import pytest

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
from emonav_drake.sensing.kinematic_maps import (
    LGM_VELOCITY_MAX_SPEED,
    lgm_velocity_planes,
    track_table_plane,
)
from tests.diagram_stacks import diagram_stacks

KINDS = ("lgm_vel", "lgm_tracks")
EXTRA = {"lgm_vel": 2, "lgm_tracks": 1}  # planes after the N LGM frames


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


def test_the_table_lists_the_nearest_pedestrians_in_range_in_the_robot_frame():
    positions = [[2.0, 1.0], [1.0, 0.0], [9.0, 0.0], [-1.0, -2.0]]
    velocities = [[1.0, 0.0], [0.0, -1.0], [0.0, 0.0], [0.5, 0.5]]
    plane = track_table_plane(np.zeros(2), 0.0, positions, velocities)
    assert plane.shape == (100, 100) and plane.dtype == np.uint8 and not plane[1:].any()
    table = plane[0, :40].reshape(8, 5).astype(int)

    def code(value, scale):
        return round(128 + 127 * value / scale)

    # nearest first: (1, 0) at 1 m, (2, 1) at 2.24 m, (−1, −2) at 2.24 m; (9, 0) out of range
    assert table[0].tolist() == [255, code(1, 6), 128, 128, code(-1, 2)]
    assert table[1].tolist() == [255, code(2, 6), code(1, 6), code(1, 2), 128]
    assert table[2].tolist() == [255, code(-1, 6), code(-2, 6), code(0.5, 2), code(0.5, 2)]
    assert (table[3:] == [0, 128, 128, 128, 128]).all()
    # from a robot at (1, 0) facing +y the nearest is at its origin, walking backwards
    turned = track_table_plane(np.array([1.0, 0.0]), np.pi / 2, positions, velocities)
    first = turned[0, :5].astype(int).tolist()
    assert first == [255, 128, 128, code(-1, 2), 128]


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
    for name in KINDS:
        frame = observation_frame(robot, crowd, cfg, name)
        assert frame.shape == (1 + EXTRA[name], 100, 100)
        assert (frame[1:] != (128 if name == "lgm_vel" else 0)).any()
        mirrored_frame = observation_frame(robot_m, mirrored, cfg, name)
        assert not np.array_equal(frame, mirrored_frame)
        assert np.array_equal(mirror_observation(frame, name), mirrored_frame), name
        # on a stack (N LGM planes, then the extra planes): mirroring twice is the identity
        stack = observation_kind(name).new_stack(cfg.lidar)
        stack.reset(frame)
        assert (
            stack.array.shape == observation_shape(name, cfg.lidar) == (9 + EXTRA[name], 100, 100)
        )
        twice = mirror_observation(mirror_observation(stack.array, name), name)
        assert np.array_equal(twice, stack.array)


def _deployable(rings: str) -> EmoNavConfig:
    cfg = EmoNavConfig()
    apply_deployable(cfg)  # VLP-16 scan with its faults, planners on LiDAR tracks
    cfg.perception.map_rings = rings
    cfg.lidar.num_frames = 4
    return cfg.validate()


@pytest.mark.parametrize("name", KINDS)
def test_the_diagram_builds_the_worlds_stack_with_the_tracked_pedestrians(name):
    """With the maps ringing the tracks, the pedestrians' planes are the tracker's — the
    same stacks in the LIP world and the diagram, and not those of the simulator's crowd."""
    seed, steps, extra = 5, 8, EXTRA[name]
    cfg, truth_cfg = _deployable("tracks"), _deployable("truth")
    scenario = sample_scenario(seed, cfg)
    world = NavigationWorld(scenario, cfg, goal_radius=0.2, grid_kind=name)
    truth = NavigationWorld(scenario, truth_cfg, goal_radius=0.2, grid_kind=name)
    dwa, actions = DwaPlanner(cfg), []
    stacks, truth_stacks = [world.planner_input().lgm_stack], [truth.planner_input().lgm_stack]
    for _ in range(steps):
        actions.append(dwa.plan(world.planner_input()))
        world.step(actions[-1])
        truth.step(actions[-1])
        stacks.append(world.planner_input().lgm_stack)
        truth_stacks.append(truth.planner_input().lgm_stack)
    assert stacks[-1].shape == (4 + extra, 100, 100)
    nobody = {  # the extra planes with nobody in view
        "lgm_vel": lgm_velocity_planes(np.zeros(2), 0.0, np.zeros((0, 2)), np.zeros((0, 2)), 0.3),
        "lgm_tracks": track_table_plane(np.zeros(2), 0.0, np.zeros((0, 2)), np.zeros((0, 2)))[None],
    }[name]
    assert any(not np.array_equal(s[-extra:], nobody) for s in stacks)
    pairs = zip(stacks, truth_stacks, strict=True)
    assert any(not np.array_equal(a[-extra:], b[-extra:]) for a, b in pairs)
    nav = build_navigation_diagram(
        scenario, cfg, ReplayPlanner(np.array(actions)), grid_kind=name, goal_radius=0.2
    )
    for k, got in enumerate(diagram_stacks(nav, cfg.robot.step_time, steps)):
        assert np.array_equal(got, stacks[k]), k


@pytest.mark.parametrize("name", KINDS)
def test_a_saved_world_and_the_dagger_store_keep_the_whole_stack(name):
    KIND = observation_kind(name)
    cfg = _deployable("tracks")
    scenario = sample_scenario(7, cfg)
    world, dwa = NavigationWorld(scenario, cfg, grid_kind=name), DwaPlanner(cfg)
    items, stacks = [], []
    for _ in range(6):
        stack = world.planner_input().lgm_stack
        stacks.append(stack)
        items.append(KIND.newest(stack))
        world.step(dwa.plan(world.planner_input()))
    # what DAgger's frame store keeps per step rebuilds every stack of the episode
    n = cfg.lidar.num_frames
    assert items[0].shape == KIND.item_shape(cfg.lidar) == (1 + EXTRA[name], 100, 100)
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
@pytest.mark.parametrize("name", KINDS)
def test_the_cpu_route_trains_a_student_on_it(tmp_path, name):
    """The DAgger route end to end on the new observation (tiny budget): its checkpoint
    declares the kind, its encoder reads N + extra planes, and it runs in the diagram."""
    from emonav_drake.cli import main
    from emonav_drake.learning.config import DaggerConfig
    from emonav_drake.learning.dagger import train_dagger
    from emonav_drake.planners.policy import load_policy

    cfg = DaggerConfig(grid_kind=name, num_frames=3, hidden=16)
    cfg.expert_episodes, cfg.episodes_per_round, cfg.rounds = 2, 1, 1
    cfg.grad_steps_first, cfg.grad_steps_per_round, cfg.batch_size = 4, 2, 8
    cfg.eval_episodes = 1
    train_dagger(tmp_path, cfg.validate(), command=f"test {name}")
    _, meta = load_policy(tmp_path / "policy.pt")
    assert meta["observation"]["grid_kind"] == name
    assert meta["observation"]["num_frames"] == 3
    assert meta["encoder"]["frames"] == 3 + EXTRA[name]
    assert meta["encoder"]["type"] == ("lgm_tracks" if name == "lgm_tracks" else "lgm")
    short = tmp_path / "short.yaml"
    short.write_text("episode: {max_steps: 3}\n")
    argv = ["sim", "--planner", "policy", "--checkpoint", str(tmp_path / "policy.pt")]
    assert main([*argv, "--plant", "lip", "--config", str(short), "--seed", "4"]) == 0


def test_the_tracks_encoder_reads_the_table_apart_from_the_maps():
    """`LgmTracksEncoder`: the maps through the LGM CNN, the table through its own MLP —
    a change of the table alone changes only the table's features."""
    import torch

    from emonav_drake.planners.networks import LgmTracksEncoder

    torch.manual_seed(0)
    enc = LgmTracksEncoder(frames=4, size=50, features=8, filters=4, pool=2, tracks=8)
    assert enc.features == 8 + 32
    cfg = EmoNavConfig()
    cfg.lidar.grid_size = 50
    robot = LipState(0.0, 0.0, 0.0, 0.3)
    crowd = _snapshot([[2.0, 0.5]], [[-1.0, 0.0]])
    frame = observation_frame(robot, crowd, cfg, "lgm_tracks")
    stack = np.concatenate([np.repeat(frame[:1], 3, axis=0), frame[1:]])[None]  # (1, 4, 50, 50)
    moved = stack.copy()
    moved[0, -1] = track_table_plane(np.zeros(2), 0.0, [[2.0, 0.5]], [[1.0, 0.0]], 50)
    a, b = enc(torch.from_numpy(stack)), enc(torch.from_numpy(moved))
    assert a.shape == (1, 40)
    assert torch.equal(a[:, :8], b[:, :8]) and not torch.equal(a[:, 8:], b[:, 8:])


def test_the_tables_say_whose_pedestrians_the_new_kinds_read():
    """The reads column: the pedestrian planes are the tracker's (deployable on a real
    sensor) only when the maps ring the tracks; else the simulator's (privileged)."""
    from emonav_drake.evaluation.tables import method_reads

    tracked = method_reads("LGM_TRACKS", "lidar", "vlp16", maps_ring_tracks=True)
    assert tracked.endswith("table of tracks in the vlp16 scan — deployable")
    assert method_reads("LGM_VEL", "lidar", "vlp16").endswith("simulator's crowd — privileged")
    assert method_reads("LGM_VEL", "truth", "ideal", maps_ring_tracks=True).endswith("privileged")
