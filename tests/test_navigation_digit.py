import json

import numpy as np

from emonav_drake.cli import main
from emonav_drake.core.dwa import DwaPlanner
from emonav_drake.core.scenario import Scenario, StaticDiscSpec
from emonav_drake.diagrams.navigation_digit import build_digit_navigation_diagram
from emonav_drake.params import EmoNavConfig


def test_digit_com_state_at_the_start():
    cfg = EmoNavConfig()
    sc = Scenario(
        robot_start=[-4.0, 0.5],
        robot_heading=0.3,
        obstacles=[StaticDiscSpec(center=[0.0, 0.0], radius=0.3)],
    )
    nd = build_digit_navigation_diagram(sc, cfg, DwaPlanner(cfg))
    ctx = nd.diagram.CreateDefaultContext()
    nd.model.plant.SetPositionsAndVelocities(
        nd.model.plant.GetMyMutableContextFromRoot(ctx), nd.initial_state
    )
    x, y, th, v = nd.com.GetOutputPort("robot_state").Eval(nd.com.GetMyContextFromRoot(ctx))
    assert np.hypot(x + 4.0, y - 0.5) < 0.05 and abs(th - 0.3) < 1e-9 and v == 0.0


def test_sim_with_the_full_order_digit(tmp_path):
    cfg = tmp_path / "c.yaml"
    cfg.write_text("episode: {max_steps: 6}\n")
    out = tmp_path / "r.json"
    args = ["sim", "--plant", "digit", "--planner", "dwa", "--seed", "0", "--config", str(cfg)]
    assert main([*args, "--json", str(out)]) == 0
    r = json.loads(out.read_text())
    assert r["outcome"] == "timeout" and r["steps"] == 6  # walking, not fallen
    assert 0.3 < r["path_length"] < 6 * 0.4 * 0.45  # Digit walked forward, at LIP-like speed


def test_digit_episode_records_a_meshcat_replay(tmp_path):
    cfg = tmp_path / "c.yaml"
    cfg.write_text("episode: {max_steps: 3}\n")
    html = tmp_path / "digit.html"
    args = ["sim", "--plant", "digit", "--seed", "1", "--config", str(cfg), "--record", str(html)]
    assert main(args) == 0
    text = html.read_text()
    assert len(text) > 50_000 and "<html" in text.lower()
