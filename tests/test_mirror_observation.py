"""`mirror_observation` is the observation of the mirrored world, for every variant.

The DAgger route mirrors half of every batch left-right (labels mirrored too); that is
only sound if the mirrored frame is what the robot would see in the world reflected about
its heading line. Checked against the real sensor models on crowded scenes.
"""

import dataclasses as dc

import numpy as np
import pytest

from emonav_drake.navigation.lip_world import NavigationWorld
from emonav_drake.navigation.observations import mirror_observation, observation_frame
from emonav_drake.params import EmoNavConfig
from emonav_drake.robot.lip import LipState
from emonav_drake.scenarios.scenario import sample_scenario


def _reflect(points: np.ndarray, origin: np.ndarray, heading: float) -> np.ndarray:
    """Reflect world points about the line through `origin` along `heading`."""
    c, s = np.cos(2 * heading), np.sin(2 * heading)
    ref = np.array([[c, s], [s, -c]])
    return (np.asarray(points, float) - origin) @ ref.T + origin


def _mirrored_world(seed: int, steps: int):
    cfg = EmoNavConfig()
    world = NavigationWorld(sample_scenario(seed, cfg), cfg, goal_radius=0.2)
    for _ in range(steps):  # pedestrians move: non-zero velocities in the maps
        world.step(np.array([0.3, 0.05]))
    robot = world.robot
    snap = world.crowd.snapshot(world.crowd_state)
    o = np.array([robot.x, robot.y])
    c, s = np.cos(2 * robot.heading), np.sin(2 * robot.heading)
    mirrored = dc.replace(
        snap,
        positions=_reflect(snap.positions, o, robot.heading),
        velocities=snap.velocities @ np.array([[c, s], [s, -c]]).T,
        static_centers=_reflect(snap.static_centers, o, robot.heading),
    )
    return cfg, robot, snap, mirrored


@pytest.mark.parametrize("kind", ["lgm", "ogm", "scan", "drlvo"])
@pytest.mark.parametrize("seed", [3, 11])
def test_mirrored_frame_is_the_frame_of_the_mirrored_world(kind, seed):
    cfg, robot, snap, mirrored = _mirrored_world(seed, steps=3)
    frame = observation_frame(robot, snap, cfg, kind)
    seen = observation_frame(robot, mirrored, cfg, kind)
    flipped = mirror_observation(frame, kind)
    assert flipped.shape == frame.shape and flipped.dtype == frame.dtype
    assert not np.array_equal(frame, flipped), "the scene is not symmetric: a weak check"
    if kind == "scan":
        np.testing.assert_allclose(flipped, seen, atol=1e-9)
        return
    # cells on a boundary may round to a neighbour; everything else is identical
    differ = np.count_nonzero(flipped != seen)
    assert differ <= 0.002 * frame.size, f"{differ} of {frame.size} cells differ"
    if kind == "drlvo":  # the velocity planes carry pedestrians; v_y changes sign
        assert (frame[2] != 128).any()
        np.testing.assert_array_equal(mirror_observation(flipped, kind), frame)


def test_mirror_applies_to_batches_of_stacks():
    rng = np.random.default_rng(0)
    batch = rng.integers(0, 256, (4, 9, 20, 20), dtype=np.uint8)
    one = mirror_observation(batch, "lgm")
    for b in range(4):
        np.testing.assert_array_equal(one[b], mirror_observation(batch[b], "lgm"))
    with pytest.raises(ValueError, match="grid kind"):
        mirror_observation(batch, "polar")


def test_the_reflection_is_about_the_robots_heading_line():
    # a robot facing +y at (2, -1): mirroring about the world x axis would be wrong
    cfg = EmoNavConfig()
    world = NavigationWorld(sample_scenario(5, cfg), cfg, goal_radius=0.2)
    robot = LipState(2.0, -1.0, np.pi / 2, 0.0)
    snap = world.crowd.snapshot(world.crowd_state)
    o = np.array([robot.x, robot.y])
    frame = observation_frame(robot, snap, cfg, "scan")
    about_heading = dc.replace(
        snap,
        positions=_reflect(snap.positions, o, robot.heading),
        static_centers=_reflect(snap.static_centers, o, robot.heading),
    )
    about_x_axis = dc.replace(
        snap,
        positions=_reflect(snap.positions, o, 0.0),
        static_centers=_reflect(snap.static_centers, o, 0.0),
    )
    flipped = mirror_observation(frame, "scan")
    np.testing.assert_allclose(flipped, observation_frame(robot, about_heading, cfg, "scan"))
    assert not np.allclose(flipped, observation_frame(robot, about_x_axis, cfg, "scan"))
