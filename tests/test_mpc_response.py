"""The MPC planning with a fitted step-response model (`mpc_digit`, planning/mpc_response.py)."""

import copy
import json

import numpy as np
import pytest

from emonav_drake.cli import main
from emonav_drake.navigation.lip_world import NavigationWorld
from emonav_drake.params import EmoNavConfig
from emonav_drake.planners import make_planner
from emonav_drake.planners.model_aware import load_response
from emonav_drake.planners.mpc import MpcPlanner
from emonav_drake.planning.mpc_response import ResponseHorizonModel
from emonav_drake.robot.lip import LipState
from emonav_drake.scenarios.scenario import sample_scenario


def test_the_rollout_walks_the_response_model_and_the_jacobian_is_its_derivative():
    cfg, response = EmoNavConfig(), load_response("digit")
    committed = np.array([[0.3, 0.1], [0.35, -0.05]])
    model = ResponseHorizonModel(cfg, response).with_committed(committed)
    rng = np.random.default_rng(1)
    n = model.horizon
    u = np.column_stack([rng.uniform(0, 0.4, n), rng.uniform(-0.2, 0.2, n)])
    p0, th0, v0 = np.array([0.3, -0.2]), 0.7, 0.25
    pos, _, _ = model.rollout(p0, th0, v0, u[None])
    s, hist = LipState(p0[0], p0[1], th0, v0), committed
    for k in range(n):  # the calibrated world's step without its noise
        cmds = np.vstack([hist, u[k]])
        s = response.step(s, cmds)
        hist = cmds[1:]
        assert pos[0, k] == pytest.approx([s.x, s.y], abs=1e-12)
    end, jac = model.positions_and_jacobian(p0, th0, v0, u)
    assert end == pytest.approx(pos[0], abs=1e-12)  # one plan of a batch
    flat, eps = np.concatenate([u[:, 0], u[:, 1]]), 1e-5
    for c in range(2 * n):
        e = np.zeros(2 * n)
        e[c] = eps
        up, um = (flat + e).reshape(2, n).T, (flat - e).reshape(2, n).T
        fd = model.rollout(p0, th0, v0, up[None])[0] - model.rollout(p0, th0, v0, um[None])[0]
        assert jac[:, c, :] == pytest.approx(fd[0] / (2 * eps), abs=1e-6)
    # the commands already sent move the robot: a different u_{k−1}, a different walk
    other = model.with_committed(np.zeros((2, 2)))
    assert np.abs(other.rollout(p0, th0, v0, u[None])[0] - pos).max() > 0.01
    assert np.array_equal(model.committed, committed)  # the view did not touch the model


def test_mpc_digit_reaches_the_goal_in_the_calibrated_world_and_is_a_pure_function():
    cfg, response = EmoNavConfig(), load_response("digit")
    planner = make_planner("mpc_digit", cfg)
    assert isinstance(planner, MpcPlanner) and planner.response is not None
    world = NavigationWorld(sample_scenario(700_003, cfg), cfg, goal_radius=0.2, response=response)
    memory, outcome, sent = planner.initial_memory(), None, []
    while outcome is None:
        obs = world.planner_input()
        kept = copy.deepcopy(memory)
        command, nxt = planner.plan_with_memory(obs, memory)
        again, _ = MpcPlanner(cfg, response=response).plan_with_memory(obs, kept)
        assert np.array_equal(command, again)  # bit for bit, whatever the object solved
        assert np.array_equal(nxt.response.command, obs.last_command)  # u_{k−2} next step
        memory = nxt
        sent.append(command)
        _, outcome = world.step(command)
    assert outcome == "success" and planner.fallbacks == 0
    assert len({tuple(c) for c in sent}) > 3  # it steers


def test_mpc_digit_runs_through_emonav_sim_on_both_plants(tmp_path):
    cfg = tmp_path / "c.yaml"
    cfg.write_text("episode: {max_steps: 5}\n")
    for plant in ("lip", "digit"):
        out = tmp_path / f"{plant}.json"
        argv = ["sim", "--planner", "mpc_digit", "--plant", plant, "--seed", "3"]
        assert main([*argv, "--config", str(cfg), "--json", str(out), "--quiet"]) == 0
        r = json.loads(out.read_text())
        assert r["steps"] == 5 and r["path_length"] > 0.3, plant
