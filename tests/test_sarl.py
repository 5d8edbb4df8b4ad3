"""SARL (CrowdNav's value network with one-step look-ahead) on our task: the joint state,
the look-ahead on the LIP, the network, CrowdNav's training route at tiny scale (loadable
checkpoint, bit-identical resume) and the planner on both plants through `emonav sim`."""

import json
import math

import numpy as np
import pytest
import torch

from emonav_drake.cli import main
from emonav_drake.crowd.crowd import CrowdSnapshot
from emonav_drake.learning.config import SarlConfig
from emonav_drake.navigation.lip_world import NavigationWorld
from emonav_drake.params import ConfigError, EmoNavConfig
from emonav_drake.planners.sarl import RglValue, SarlValue, command_grid, load_sarl
from emonav_drake.planners.specs import DwaSpec
from emonav_drake.planning.sarl_state import (
    FEATURES,
    agents,
    current_rows,
    lookahead,
)
from emonav_drake.robot.lip import LipState
from emonav_drake.scenarios.scenario import sample_scenario

CFG = EmoNavConfig()
F = {name: i for i, name in enumerate(FEATURES)}


def _crowd(ped_xy, ped_v, disc_xy, disc_r, discomfort=None) -> CrowdSnapshot:
    ped_xy = np.asarray(ped_xy, float).reshape(-1, 2)
    return CrowdSnapshot(
        positions=ped_xy,
        velocities=np.asarray(ped_v, float).reshape(-1, 2),
        radius=0.3,
        emotions=np.zeros(len(ped_xy), np.int64),
        discomfort=np.full(len(ped_xy), 0.5) if discomfort is None else np.asarray(discomfort),
        static_centers=np.asarray(disc_xy, float).reshape(-1, 2),
        static_radii=np.asarray(disc_r, float),
        static_discomfort=0.2,
    )


def test_the_joint_state_is_seen_from_the_robot_with_x_to_the_goal():
    crowd = _crowd([[2.0, 3.0]], [[0.0, -1.0]], [[0.0, 2.0]], [0.3], discomfort=[0.8])
    robot = LipState(0.0, 0.0, math.pi / 2, 0.4)
    rows = current_rows(robot, np.array([0.0, 5.0]), crowd, CFG)  # goal straight up
    assert rows.shape == (2, len(FEATURES))
    ped, disc = rows
    assert ped[F["dg"]] == pytest.approx(5.0) and ped[F["theta"]] == pytest.approx(0.0)
    assert (ped[F["vx"]], ped[F["vy"]]) == pytest.approx((0.4, 0.0), abs=1e-6)
    # the pedestrian is 3 m ahead (towards the goal) and 2 m to the right, walking at us
    assert (ped[F["px1"]], ped[F["py1"]]) == pytest.approx((3.0, -2.0), abs=1e-6)
    assert (ped[F["vx1"]], ped[F["vy1"]]) == pytest.approx((-1.0, 0.0), abs=1e-6)
    assert ped[F["da"]] == pytest.approx(math.hypot(2, 3))
    assert (ped[F["zone1"]], ped[F["static1"]]) == (pytest.approx(0.8), 0.0)
    assert (disc[F["px1"]], disc[F["py1"]]) == pytest.approx((2.0, 0.0), abs=1e-6)
    assert (disc[F["zone1"]], disc[F["static1"]], disc[F["radius1"]]) == pytest.approx(
        (0.2, 1.0, 0.3)
    )
    # rotating the whole world leaves the joint state unchanged
    c, s = math.cos(0.7), math.sin(0.7)
    rot = np.array([[c, -s], [s, c]])
    turned = _crowd(
        crowd.positions @ rot.T,
        crowd.velocities @ rot.T,
        crowd.static_centers @ rot.T,
        [0.3],
        discomfort=[0.8],
    )
    robot2 = LipState(0.0, 0.0, math.pi / 2 + 0.7, 0.4)
    rows2 = current_rows(robot2, rot @ np.array([0.0, 5.0]), turned, CFG)
    np.testing.assert_allclose(rows2, rows, atol=1e-5)


def test_the_lookahead_walks_the_lip_step_of_the_world():
    world = NavigationWorld(sample_scenario(3, CFG), CFG)
    obs = world.planner_input()
    commands = command_grid(CFG)
    rows, rewards, done = lookahead(
        obs.robot, obs.goal_xy, obs.goal_state()[0], obs.crowd, commands, CFG, 0.2
    )
    assert rows.shape[0] == len(commands) == 99 and rewards.shape == done.shape == (99,)
    k = 57
    ev, _ = world.step(commands[k])
    after = world.planner_input()
    # the robot's predicted next state is the world's (the LIP step is exact)
    goal = np.asarray(after.goal_xy)
    expect = math.hypot(*(goal - [after.robot.x, after.robot.y]))
    assert rows[k, 0, F["dg"]] == pytest.approx(expect, abs=1e-5)
    assert rows[k, 0, F["vx"]] ** 2 + rows[k, 0, F["vy"]] ** 2 == pytest.approx(
        after.robot.speed**2, abs=1e-5
    )
    # the reward's progress term is the world's (pedestrians moved differently: close only)
    assert rewards[k] == pytest.approx(ev.reward, abs=0.11)


@pytest.mark.parametrize("network", [SarlValue, RglValue])
def test_the_value_ignores_padding_and_the_order_of_agents(network):
    torch.manual_seed(0)
    net = network().eval()
    world = NavigationWorld(sample_scenario(8, CFG), CFG)
    obs = world.planner_input()
    rows = current_rows(obs.robot, obs.goal_xy, obs.crowd, CFG)
    x = torch.from_numpy(rows[None])
    v = net(x, torch.ones(1, len(rows), dtype=torch.bool))
    padded = torch.cat([x, torch.randn(1, 3, x.shape[2])], dim=1)
    mask = torch.tensor([[True] * len(rows) + [False] * 3])
    flipped = x.flip(1)
    with torch.no_grad():
        torch.testing.assert_close(net(padded, mask), v)
        torch.testing.assert_close(net(flipped, torch.ones_like(mask[:, : len(rows)])), v)
    assert len(agents(obs.crowd)[0]) == len(rows)


@pytest.fixture(scope="module", params=["sarl", "rgl"])
def tiny_runs(tmp_path_factory, request):
    """One tiny run to the end, and the same run stopped after 3 RL episodes, resumed (each
    value network)."""
    from emonav_drake.learning.sarl_train import train_sarl

    root = tmp_path_factory.mktemp(request.param)
    cfg = SarlConfig(
        network=request.param,
        expert=DwaSpec(),
        il_episodes=3,
        il_epochs=2,
        rl_episodes=6,
        train_batches=3,
        batch_size=16,
        target_update=2,
        eval_every=3,
        eval_episodes=2,
    )
    train_sarl(root / "whole", cfg, progress=False, command="test")
    short = SarlConfig(**{**cfg.__dict__, "rl_episodes": 3})
    train_sarl(root / "split", short, progress=False)
    train_sarl(root / "split", cfg, resume=True, progress=False)
    return root, cfg


@pytest.mark.slow
def test_tiny_training_writes_a_loadable_checkpoint_and_resumes_bit_identically(tiny_runs):
    root, cfg = tiny_runs
    history = json.loads((root / "whole" / "history.json").read_text())
    assert [h["rl_episode"] for h in history] == [0, 3, 6]
    model, meta = load_sarl(root / "whole" / "policy.pt")
    assert meta["network"] == cfg.network
    assert isinstance(model, {"sarl": SarlValue, "rgl": RglValue}[cfg.network])
    prov = meta["provenance"]
    assert prov["route"] == "sarl" and prov["selection_seeds"] == [600_000, 600_001]
    assert prov["training_seeds"][0] == 4_000_000 and prov["command"] == "test"
    assert len(meta["commands"]) == 99 and meta["gamma"] == cfg.gamma
    split = json.loads((root / "split" / "history.json").read_text())
    assert split == history
    a = torch.load(root / "whole" / "sarl_state.pt", weights_only=True)["torch"]["model"]
    b = torch.load(root / "split" / "sarl_state.pt", weights_only=True)["torch"]["model"]
    for k in a:
        assert torch.equal(a[k], b[k]), k


def test_a_resume_refuses_another_configuration(tiny_runs, tmp_path):
    from emonav_drake.learning.sarl_train import train_sarl

    root, cfg = tiny_runs
    other = SarlConfig(**{**cfg.__dict__, "gamma": 0.8})
    with pytest.raises(ConfigError, match="gamma"):
        train_sarl(root / "whole", other, resume=True, progress=False)
    with pytest.raises(ConfigError, match="already holds a SARL run"):
        train_sarl(root / "whole", cfg, progress=False)
    with pytest.raises(ConfigError, match="expert = 'orca' is invalid: must be one of !DwaSpec"):
        SarlConfig(expert="orca").validate()
    with pytest.raises(ConfigError, match="network"):
        SarlConfig(network="gcn").validate()
    other = SarlConfig(**{**cfg.__dict__, "network": {"sarl": "rgl", "rgl": "sarl"}[cfg.network]})
    with pytest.raises(ConfigError, match="network"):
        train_sarl(root / "whole", other, resume=True, progress=False)


@pytest.mark.slow
def test_sarl_runs_on_both_plants_through_emonav_sim_deterministically(
    tiny_runs, sim_on_both_plants
):
    root, cfg = tiny_runs
    ckpt = str(root / "whole" / "policy.pt")
    records = sim_on_both_plants(["--planner", cfg.network, "--checkpoint", ckpt], 7)
    for plant, record in records.items():
        assert record["steps"] >= 1, plant


@pytest.mark.slow
def test_a_benchmark_runs_sarl_beside_a_policy(tiny_runs, tmp_path):
    from emonav_drake.diagrams.trials import method_specs
    from emonav_drake.evaluation.benchmark import run_benchmark
    from emonav_drake.evaluation.run_directory import load_run
    from emonav_drake.params import load_config

    root, _ = tiny_runs
    methods = method_specs("sarl,dwa", [f"sarl={root / 'whole' / 'policy.pt'}"])
    run_benchmark(tmp_path / "b", methods, "lip", 2, 5, load_config(), workers=1, progress=False)
    settings, trials = load_run(tmp_path / "b")
    assert sorted(t["method"] for t in trials) == ["dwa", "dwa", "sarl", "sarl"]
    assert settings["methods"]["sarl"]["observation"] == "state"


@pytest.mark.slow
@pytest.mark.parametrize("name", ["sarl", "rgl"])
def test_the_shipped_value_planner_runs_by_name_on_both_plants(sim_on_both_plants, name):
    """SARL's and RGL's shipped checkpoints load as their value network and run by name
    through `emonav sim` on each plant, twice each with the same seed, to the same record."""
    import emonav_drake.planners as planners

    _, meta = load_sarl(planners.VALUE_CHECKPOINTS[name])
    assert meta.get("network", "sarl") == name
    assert meta["provenance"]["route"] == "sarl"
    assert meta["provenance"]["selection_seeds"] == [600_000, 600_199]
    records = sim_on_both_plants(["--planner", name], 11)
    for plant, record in records.items():
        assert record["outcome"] in ("success", "collision", "timeout"), plant


@pytest.mark.parametrize("name", ["sarl", "rgl"])
def test_sarl_without_a_checkpoint_says_how_to_train(tmp_path, capsys, monkeypatch, name):
    import emonav_drake.planners as planners

    monkeypatch.setitem(planners.VALUE_CHECKPOINTS, name, tmp_path / "not_shipped.pt")
    assert main(["sim", "--planner", name, "--json", str(tmp_path / "r.json")]) == 2
    err = capsys.readouterr().err
    assert "emonav train --algo sarl" in err and name in err


@pytest.mark.slow
def test_an_old_sarl_state_resumes_as_sarl(tmp_path):
    """A run saved before `network` existed (no such key) resumes as the SARL it was."""
    from emonav_drake.learning.run_state import read_run_state, write_run_state
    from emonav_drake.learning.sarl_train import SARL_STATE_FORMAT, STATE_FILE, train_sarl

    cfg = SarlConfig(expert=DwaSpec(), il_episodes=2, il_epochs=1, rl_episodes=1, train_batches=1)
    cfg.batch_size, cfg.eval_every, cfg.eval_episodes = 8, 1, 1
    train_sarl(tmp_path, cfg, progress=False)
    state, tensors = read_run_state(tmp_path / STATE_FILE, SARL_STATE_FORMAT)
    del state["config"]["network"]
    write_run_state(tmp_path / STATE_FILE, SARL_STATE_FORMAT, state, tensors)
    longer = SarlConfig(**{**cfg.__dict__, "rl_episodes": 2})
    train_sarl(tmp_path, longer, resume=True, progress=False)
    assert json.loads((tmp_path / "history.json").read_text())[-1]["rl_episode"] == 2
    assert load_sarl(tmp_path / "policy.pt")[1]["network"] == "sarl"
