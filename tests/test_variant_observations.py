"""Every observation variant of the paper runs in both diagrams, with the env's observation.

EmoBipedNav (9 LGM frames), Single-LGM (1 frame), OGM, LiDAR-SAC (stacked raw scans),
LNDNL (LSTM over scans) and DRL-VO* (scan OGM + pedestrian velocity map): a freshly
initialised policy checkpoint of each runs through `emonav sim --planner policy` on the LIP
plant and on Digit, and the diagram's `lgm_stack` is the Gymnasium env's bit for bit.
"""

import json

import numpy as np
import pytest
import torch

from emonav_drake.cli import main
from emonav_drake.diagrams.navigation import build_navigation_diagram
from emonav_drake.learning.env import EmoNavLIPEnv
from emonav_drake.params import EmoNavConfig
from emonav_drake.planners import configure_for
from emonav_drake.planners.networks import (
    Actor,
    LgmEncoder,
    LgmTracksEncoder,
    ScanEncoder,
    ScanLstmEncoder,
)
from emonav_drake.planners.policy import PolicyPlanner, save_policy
from emonav_drake.planners.replay import ReplayPlanner
from emonav_drake.scenarios.scenario import sample_scenario
from tests.diagram_stacks import diagram_stacks

# name: (grid kind, num_frames, grid_size, encoder spec) — tiny networks, random weights.
VARIANTS = {
    "emobipednav": ("lgm", 9, 50, {"type": "lgm", "frames": 9, "size": 50, "pool": 2}),
    "single_lgm": ("lgm", 1, 50, {"type": "lgm", "frames": 1, "size": 50, "pool": 2}),
    "ogm": ("ogm", 4, 60, {"type": "lgm", "frames": 4, "size": 60, "pool": 2}),
    "lidar_sac": ("scan", 3, 100, {"type": "scan", "frames": 3}),
    "lndnl": ("scan", 3, 100, {"type": "scan_lstm", "frames": 3, "hidden": 8}),
    "drlvo": ("drlvo", 1, 50, {"type": "lgm", "frames": 3, "size": 50, "pool": 2}),
    # ours (issue 53): 4 LGM frames + the two velocity planes
    "lgm_vel": ("lgm_vel", 4, 50, {"type": "lgm", "frames": 6, "size": 50, "pool": 2}),
    # ours: 4 LGM frames + the pedestrians' table, read by its own MLP
    "lgm_tracks": (
        "lgm_tracks",
        4,
        50,
        {"type": "lgm_tracks", "frames": 5, "size": 50, "pool": 2, "tracks": 8},
    ),
}
ENCODERS = {
    "lgm": LgmEncoder,
    "lgm_tracks": LgmTracksEncoder,
    "scan": ScanEncoder,
    "scan_lstm": ScanLstmEncoder,
}


def make_checkpoint(path, name: str, seed: int = 0):
    """A seeded, freshly initialised Gaussian policy of variant `name`, saved at `path`."""
    kind, frames, size, enc = VARIANTS[name]
    enc = enc | {"features": 8}
    if enc["type"] != "scan_lstm":
        enc["filters"] = 4
    torch.manual_seed(seed)
    args = {k: v for k, v in enc.items() if k != "type"}
    model = Actor(ENCODERS[enc["type"]](**args), hidden=8)
    meta = {
        "kind": "gaussian",
        "encoder": enc,
        "hidden": 8,
        "observation": {"grid_kind": kind, "num_frames": frames, "grid_size": size},
        "bounds": [0.4, 0.2],
    }
    save_policy(path, model, meta)
    return path


@pytest.mark.parametrize("name", list(VARIANTS))
def test_every_variant_runs_a_short_episode_on_lip_and_on_digit(tmp_path, name):
    ckpt = make_checkpoint(tmp_path / f"{name}.pt", name)
    config = tmp_path / "short.yaml"
    config.write_text("episode: {max_steps: 3}\n")
    for plant in ("lip", "digit"):
        out = tmp_path / f"{plant}.json"
        argv = ["sim", "--planner", "policy", "--checkpoint", str(ckpt), "--plant", plant]
        assert main([*argv, "--config", str(config), "--seed", "2", "--json", str(out)]) == 0
        record = json.loads(out.read_text())
        assert record["steps"] == 3 and record["outcome"] == "timeout", (plant, record)


@pytest.mark.parametrize("name", list(VARIANTS))
def test_the_diagram_builds_the_observation_the_policy_reads(tmp_path, name):
    planner = PolicyPlanner(make_checkpoint(tmp_path / "p.pt", name))
    cfg = EmoNavConfig()
    cfg, kind = configure_for(planner, cfg)
    nav = build_navigation_diagram(sample_scenario(1, cfg), cfg, planner, grid_kind=kind)
    ctx = nav.diagram.CreateDefaultContext()
    obs = nav.grid_maps.GetOutputPort("lgm_stack").Eval(nav.grid_maps.GetMyContextFromRoot(ctx))
    assert obs.shape == planner.expected_shape and obs.dtype == planner.expected_dtype
    assert kind == VARIANTS[name][0]


def _env_observations(kind, cfg, seed, actions):
    env = EmoNavLIPEnv(cfg, grid_kind=kind, goal_radius=0.2)
    obs, _ = env.reset(seed=seed)
    out = [obs[env.map_key]]
    for u in actions:
        obs, *_ = env.step(u)
        out.append(obs[env.map_key])
    return out


@pytest.mark.parametrize("kind", ["scan", "drlvo", "ogm", "lgm_vel", "lgm_tracks"])
def test_the_diagrams_observation_is_the_envs_bit_for_bit(kind):
    cfg = EmoNavConfig()
    cfg.lidar.num_frames = 4
    seed, steps = 5, 6
    rng = np.random.default_rng(1)
    actions = np.column_stack([rng.uniform(0.2, 0.4, steps), rng.uniform(-0.2, 0.2, steps)])
    expected = _env_observations(kind, cfg, seed, actions)
    nav = build_navigation_diagram(
        sample_scenario(seed, cfg), cfg, ReplayPlanner(actions), grid_kind=kind, goal_radius=0.2
    )
    for k, got in enumerate(diagram_stacks(nav, cfg.robot.step_time, steps + 1)):
        assert got.dtype == expected[k].dtype and got.shape == expected[k].shape
        assert np.array_equal(got, expected[k]), f"{kind}: step {k}"
    shape = {"scan": (4, 1800), "drlvo": (1, 3, 100, 100), "ogm": (4, 100, 100)}
    shape["lgm_vel"], shape["lgm_tracks"] = (6, 100, 100), (5, 100, 100)
    shape = shape[kind]
    assert expected[-1].shape == shape and len({f.tobytes() for f in expected}) == steps + 1


def test_observations_the_env_cannot_give_are_refused_when_configuring(tmp_path):
    path = make_checkpoint(tmp_path / "scan.pt", "lidar_sac")
    cfg = EmoNavConfig()
    cfg.lidar.num_beams = 900
    with pytest.raises(ValueError, match="1800-beam scans"):
        configure_for(PolicyPlanner(path), cfg)
    torch.manual_seed(0)
    enc = {"type": "lgm", "frames": 6, "size": 50, "pool": 2, "features": 8, "filters": 4}
    meta = {
        "kind": "gaussian",
        "encoder": enc,
        "hidden": 8,
        "observation": {"grid_kind": "drlvo", "num_frames": 2, "grid_size": 50},
        "bounds": [0.4, 0.2],
    }
    save_policy(tmp_path / "d.pt", Actor(LgmEncoder(6, 50, 8, 4, 2), hidden=8), meta)
    with pytest.raises(ValueError, match="num_frames = 2"):
        configure_for(PolicyPlanner(tmp_path / "d.pt"), EmoNavConfig())
