"""Tests of the numpy ORCA implementation (emonav_drake.crowd.orca)."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

# The reference implementation lives in benchmarks/, which is not part of the installed
# package: make the repository root importable.
_REPO_ROOT = str(Path(__file__).resolve().parents[1])
if _REPO_ROOT not in sys.path:
    sys.path.insert(0, _REPO_ROOT)

from benchmarks.reference.orca_reference import orca_velocities_reference  # noqa: E402
from emonav_drake.crowd import orca_lp  # noqa: E402
from emonav_drake.crowd.orca import OrcaParams, orca_velocities  # noqa: E402

DT = 0.1


def pref_towards(positions: np.ndarray, goals: np.ndarray, speed: float, dt: float) -> np.ndarray:
    """Preferred velocities towards the goals at ``speed``, slowing to land on the goal."""
    delta = goals - positions
    dist = np.linalg.norm(delta, axis=1, keepdims=True)
    step_speed = np.minimum(speed, dist / dt)
    return np.where(dist > 0.0, delta / np.maximum(dist, 1e-12) * step_speed, 0.0)


def random_crowd(seed: int, n: int = 20, m: int = 3, side: float = 4.0) -> dict:
    """A crowded random configuration (many overlaps and LP3 fallbacks at side = 4 m)."""
    rng = np.random.default_rng(seed)
    positions = rng.uniform(-side / 2, side / 2, (n, 2))
    goals = rng.uniform(-side, side, (n, 2))
    direction = goals - positions
    direction /= np.linalg.norm(direction, axis=1, keepdims=True)
    return {
        "positions": positions,
        "velocities": rng.normal(0.0, 0.6, (n, 2)),
        "radii": rng.uniform(0.2, 0.35, n),
        "pref_velocities": direction * rng.uniform(0.5, 1.6, (n, 1)),
        "max_speeds": rng.uniform(0.8, 1.6, n),
        "dt": DT,
        "obstacle_centers": rng.uniform(-side / 2, side / 2, (m, 2)),
        "obstacle_radii": rng.uniform(0.2, 0.5, m),
    }


def pair_distances(positions: np.ndarray) -> np.ndarray:
    return np.linalg.norm(positions[:, None, :] - positions[None, :, :], axis=2)


def test_head_on_agents_pass_without_overlap_and_reach_goals() -> None:
    positions = np.array([[-4.0, 0.025], [4.0, -0.025]])  # 5 cm lateral offset
    goals = positions[::-1].copy()
    radii = np.full(2, 0.3)
    max_speeds = np.ones(2)
    velocities = pref_towards(positions, goals, 1.0, DT)
    min_dist = np.inf
    max_lateral = 0.0
    for _ in range(100):  # 10 s
        pref = pref_towards(positions, goals, 1.0, DT)
        velocities = orca_velocities(positions, velocities, radii, pref, max_speeds, DT)
        positions = positions + velocities * DT
        min_dist = min(min_dist, np.linalg.norm(positions[0] - positions[1]))
        max_lateral = max(max_lateral, np.abs(positions[:, 1]).max())
    assert min_dist >= 0.6 - 1e-3
    assert max_lateral > 0.2  # they really stepped aside
    np.testing.assert_allclose(positions, goals, atol=0.05)


def test_speeds_never_exceed_max_speed_in_long_random_simulation() -> None:
    rng = np.random.default_rng(7)
    n = 10
    angles = np.linspace(0.0, 2.0 * np.pi, n, endpoint=False)
    positions = 4.0 * np.column_stack([np.cos(angles), np.sin(angles)])
    positions += rng.normal(0.0, 0.05, positions.shape)
    goals = -positions
    radii = rng.uniform(0.2, 0.35, n)
    max_speeds = rng.uniform(0.6, 1.5, n)
    velocities = np.zeros((n, 2))
    obstacle_centers = np.array([[0.0, 0.0], [1.5, 0.3], [-1.0, -1.2]])
    obstacle_radii = np.array([0.6, 0.3, 0.4])
    for step in range(400):
        if step % 100 == 99:  # new goals keep the crowd moving
            goals = rng.uniform(-4.0, 4.0, (n, 2))
        pref = pref_towards(positions, goals, 2.0, DT)  # often faster than max speed
        velocities = orca_velocities(
            positions,
            velocities,
            radii,
            pref,
            max_speeds,
            DT,
            obstacle_centers=obstacle_centers,
            obstacle_radii=obstacle_radii,
        )
        assert np.all(np.isfinite(velocities))
        assert np.all(np.linalg.norm(velocities, axis=1) <= max_speeds + 1e-12)
        positions = positions + velocities * DT


def test_same_inputs_give_bit_identical_outputs_and_inputs_untouched() -> None:
    crowd = random_crowd(3)
    copies = {key: np.copy(value) for key, value in crowd.items()}
    first = orca_velocities(**crowd)
    second = orca_velocities(**crowd)
    assert np.array_equal(first, second)
    for key, value in copies.items():
        assert np.array_equal(crowd[key], value), key


def test_agent_goes_round_static_disc_without_penetrating() -> None:
    # Heading straight at the disc (1 cm off-axis: an exactly symmetric start is ORCA's
    # well-known deadlock, the agent then stops in front of the disc).
    positions = np.array([[-3.0, 0.01]])
    goals = np.array([[3.0, 0.01]])
    center = np.array([[0.0, 0.0]])
    velocities = np.zeros((1, 2))
    min_dist = np.inf
    for _ in range(120):
        pref = pref_towards(positions, goals, 1.0, DT)
        velocities = orca_velocities(
            positions,
            velocities,
            np.array([0.3]),
            pref,
            np.array([1.0]),
            DT,
            obstacle_centers=center,
            obstacle_radii=np.array([0.5]),
        )
        positions = positions + velocities * DT
        min_dist = min(min_dist, np.linalg.norm(positions[0] - center[0]))
    assert min_dist >= 0.8 - 1e-3
    assert min_dist < 0.9  # it actually went round close to the disc
    np.testing.assert_allclose(positions, goals, atol=0.05)


def head_on_pair() -> dict:
    return {
        "positions": np.array([[0.0, 0.0], [2.0, 0.05]]),
        "velocities": np.array([[1.0, 0.0], [-1.0, 0.0]]),
        "radii": np.array([0.3, 0.3]),
        "pref_velocities": np.array([[1.0, 0.0], [-1.0, 0.0]]),
        "max_speeds": np.array([1.2, 1.2]),
        "dt": DT,
    }


def test_invisible_agent_is_ignored() -> None:
    pair = head_on_pair()
    both_see = orca_velocities(**pair)
    assert not np.allclose(both_see[0], pair["pref_velocities"][0])  # would avoid agent 1

    visible = np.array([[False, False], [True, False]])  # 0 ignores 1, 1 sees 0
    result = orca_velocities(**pair, visible=visible)
    np.testing.assert_array_equal(result[0], pair["pref_velocities"][0])
    assert not np.allclose(result[1], pair["pref_velocities"][1])


def test_inactive_agent_keeps_its_velocity_but_is_still_avoided() -> None:
    pair = head_on_pair()
    pair["velocities"][1] = [-5.0, 0.3]  # even above its max speed: returned as is
    result = orca_velocities(**pair, active=np.array([True, False]))
    np.testing.assert_array_equal(result[1], [-5.0, 0.3])
    assert not np.allclose(result[0], pair["pref_velocities"][0])
    alone = orca_velocities(**pair, active=np.array([True, False]), visible=np.zeros((2, 2), bool))
    np.testing.assert_array_equal(alone[0], pair["pref_velocities"][0])


def test_lp3_fallback_for_squeezed_agent(monkeypatch: pytest.MonkeyPatch) -> None:
    lp3_calls = []
    real_lp3 = orca_lp.linear_program3

    def spy(*args: object) -> object:
        lp3_calls.append(args)
        return real_lp3(*args)

    monkeypatch.setattr(orca_lp, "linear_program3", spy)
    # Agent 0 squeezed by four overlapping agents: each asks it to move away at 1 m/s.
    positions = np.array([[0.0, 0.0], [0.4, 0.0], [-0.4, 0.0], [0.0, 0.4], [0.0, -0.4]])
    velocities = np.zeros((5, 2))
    pref = np.array([[1.0, 0.0], [1.0, 0.0], [-1.0, 0.0], [0.0, 1.0], [0.0, -1.0]])
    result = orca_velocities(positions, velocities, np.full(5, 0.3), pref, np.full(5, 1.5), DT)
    assert lp3_calls  # LP2 was infeasible
    assert np.all(np.isfinite(result))
    assert np.all(np.linalg.norm(result, axis=1) <= 1.5 + 1e-12)
    # By symmetry the least-violating velocity of the squeezed agent is zero.
    np.testing.assert_allclose(result[0], [0.0, 0.0], atol=1e-9)


def violation(lines: list[tuple[float, float, float, float]], v: np.ndarray) -> np.ndarray:
    """Signed distance by which velocities ``v`` (k, 2) violate each line -> (k, n_lines)."""
    d = np.array(lines)
    return d[:, 0] * (d[:, 3] - v[:, 1:2]) - d[:, 1] * (d[:, 2] - v[:, 0:1])


@pytest.mark.parametrize("seed", range(5))
def test_lp3_minimises_largest_violation(seed: int) -> None:
    rng = np.random.default_rng(seed)
    radius = 1.5
    # One hard obstacle line through the origin, then agent lines "v . normal >= c > 0" whose
    # normals positively span the plane, so that together they are infeasible.
    angle = rng.uniform(0.0, 2.0 * np.pi)
    lines = [(np.cos(angle), np.sin(angle), 0.0, 0.0)]
    normal_angles = np.arange(5) * 2.0 * np.pi / 5 + rng.uniform(-0.3, 0.3, 5)
    for normal_angle in rng.permutation(normal_angles):
        normal = np.array([np.cos(normal_angle), np.sin(normal_angle)])
        point = normal * rng.uniform(0.1, 1.0)
        lines.append((normal[1], -normal[0], point[0], point[1]))  # permitted: left side
    fail, rx, ry = orca_lp.linear_program2(lines, radius, 0.2, 0.1, False)
    assert fail < len(lines)  # LP2 detects the infeasibility
    rx, ry = orca_lp.linear_program3(lines, 1, fail, radius, rx, ry)
    result = np.array([[rx, ry]])
    assert rx * rx + ry * ry <= radius * radius + 1e-12
    assert violation(lines[:1], result)[0, 0] <= 1e-12  # obstacle line kept hard

    grid = np.linspace(-radius, radius, 301)
    gx, gy = np.meshgrid(grid, grid)
    candidates = np.column_stack([gx.ravel(), gy.ravel()])
    candidates = candidates[np.linalg.norm(candidates, axis=1) <= radius]
    candidates = candidates[violation(lines[:1], candidates)[:, 0] <= 0.0]
    best_on_grid = violation(lines[1:], candidates).max(axis=1).min()
    achieved = violation(lines[1:], result).max()
    assert achieved > 0.0  # infeasible: some violation is unavoidable
    assert achieved <= best_on_grid + 1e-9
    assert achieved >= best_on_grid - 2.0 * (grid[1] - grid[0])


@pytest.mark.parametrize("seed", range(8))
def test_fast_matches_reference_on_crowded_configurations(
    seed: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    lp3_calls = []
    real_lp3 = orca_lp.linear_program3

    def spy(*args: object) -> object:
        lp3_calls.append(args)
        return real_lp3(*args)

    monkeypatch.setattr(orca_lp, "linear_program3", spy)
    crowd = random_crowd(seed, side=3.0 + seed)
    rng = np.random.default_rng(100 + seed)
    n = crowd["positions"].shape[0]
    params = OrcaParams(
        neighbor_dist=[10.0, 2.0][seed % 2],
        max_neighbors=[10, 4, 25][seed % 3],
        time_horizon=rng.uniform(1.0, 5.0),
        time_horizon_obst=rng.uniform(0.5, 5.0),
    )
    options = {
        "params": params,
        "visible": rng.random((n, n)) < 0.8,
        "active": rng.random(n) < 0.9,
    }
    fast = orca_velocities(**crowd, **options)
    reference = orca_velocities_reference(**crowd, **options)
    np.testing.assert_allclose(fast, reference, rtol=0.0, atol=1e-9)
    if seed < 2:
        assert lp3_calls  # the cross-check covers the fallback


def test_fast_matches_reference_along_a_simulation() -> None:
    crowd = random_crowd(11, n=12, side=6.0)
    goals = -crowd["positions"]
    for _ in range(60):
        crowd["pref_velocities"] = pref_towards(crowd["positions"], goals, 1.3, DT)
        fast = orca_velocities(**crowd)
        reference = orca_velocities_reference(**crowd)
        np.testing.assert_allclose(fast, reference, rtol=0.0, atol=1e-9)
        crowd["velocities"] = fast
        crowd["positions"] = crowd["positions"] + fast * DT


def test_coincident_agents_are_pushed_apart() -> None:
    # w == 0 (same position, same velocity) is undefined in RVO2; we push the lower index to +x.
    state = {
        "positions": np.array([[1.0, 1.0], [1.0, 1.0], [3.0, 1.0]]),
        "velocities": np.zeros((3, 2)),
        "radii": np.full(3, 0.3),
        "pref_velocities": np.zeros((3, 2)),
        "max_speeds": np.full(3, 1.0),
        "dt": DT,
        "obstacle_centers": np.array([[3.0, 1.0]]),  # agent 2 sits on the disc centre
        "obstacle_radii": np.array([0.2]),
    }
    result = orca_velocities(**state)
    assert np.all(np.isfinite(result))
    assert result[0, 0] > 0.1 and result[1, 0] < -0.5
    np.testing.assert_allclose(result, orca_velocities_reference(**state), rtol=0.0, atol=1e-12)


def test_speed_limited_and_no_agents_edge_cases() -> None:
    pair = head_on_pair()
    pair["positions"][1] = [50.0, 0.0]  # out of range: unconstrained
    pair["pref_velocities"][0] = [3.0, 4.0]
    result = orca_velocities(**pair)
    np.testing.assert_allclose(result[0], [0.72, 0.96], atol=1e-12)  # clipped to 1.2 m/s
    empty = orca_velocities(
        np.zeros((0, 2)), np.zeros((0, 2)), np.zeros(0), np.zeros((0, 2)), np.zeros(0), DT
    )
    assert empty.shape == (0, 2)


@pytest.mark.parametrize(
    ("key", "value"),
    [
        ("positions", np.zeros((2, 3))),
        ("positions", np.array([[0.0, np.nan], [1.0, 1.0]])),
        ("velocities", np.zeros((3, 2))),
        ("velocities", np.array([[np.inf, 0.0], [0.0, 0.0]])),
        ("radii", np.zeros((2, 1))),
        ("radii", np.array([0.3, -0.1])),
        ("pref_velocities", np.array([[np.nan, 0.0], [0.0, 0.0]])),
        ("max_speeds", np.array([1.0])),
        ("max_speeds", np.array([1.0, np.nan])),
        ("dt", 0.0),
        ("dt", float("nan")),
        ("visible", np.ones((2, 3), dtype=bool)),
        ("visible", np.ones((2, 2))),
        ("active", np.ones(3, dtype=bool)),
        ("obstacle_centers", np.zeros((1, 2))),  # radii missing
        ("params", "not params"),
    ],
)
def test_bad_input_raises_value_error(key: str, value: object) -> None:
    pair = head_on_pair()
    pair[key] = value
    with pytest.raises(ValueError, match=key if key != "obstacle_centers" else "together"):
        orca_velocities(**pair)


def test_bad_obstacles_and_params_raise_value_error() -> None:
    pair = head_on_pair()
    with pytest.raises(ValueError, match="obstacle_centers"):
        orca_velocities(**pair, obstacle_centers=np.zeros((2, 3)), obstacle_radii=np.ones(2))
    with pytest.raises(ValueError, match="obstacle_radii"):
        orca_velocities(**pair, obstacle_centers=np.zeros((2, 2)), obstacle_radii=np.ones(3))
    with pytest.raises(ValueError, match="obstacle_centers"):
        orca_velocities(
            **pair, obstacle_centers=np.array([[np.nan, 0.0]]), obstacle_radii=np.ones(1)
        )
    with pytest.raises(ValueError, match="time_horizon"):
        OrcaParams(time_horizon=0.0)
    with pytest.raises(ValueError, match="max_neighbors"):
        OrcaParams(max_neighbors=-1)
    with pytest.raises(ValueError, match="neighbor_dist"):
        OrcaParams(neighbor_dist=float("nan"))


def test_unchecked_path_gives_the_same_velocities():
    rng = np.random.default_rng(7)
    pos = rng.uniform(-3, 3, (8, 2))
    vel = rng.uniform(-1, 1, (8, 2))
    pref = -pos / np.linalg.norm(pos, axis=1, keepdims=True)
    args = (pos, vel, np.full(8, 0.5), pref, np.ones(8), 0.1, OrcaParams())
    kw = dict(
        obstacle_centers=np.array([[0.0, 0.5]]),
        obstacle_radii=np.array([0.3]),
        visible=~np.eye(8, dtype=bool),
        active=np.ones(8, dtype=bool),
    )
    checked = orca_velocities(*args, **kw)
    unchecked = orca_velocities(*args, **kw, check_inputs=False)
    assert np.array_equal(checked, unchecked)
