"""`emonav sim --json`'s trajectory section, `emonav plot` and the `emonav lgm` figure."""

import json
import math

import numpy as np
import pytest
from PIL import Image

from emonav_drake.cli import build_parser, main
from emonav_drake.crowd.crowd import Crowd
from emonav_drake.evaluation.trajectory import build_trajectory, load_trajectory
from emonav_drake.navigation.metrics import EpisodeRecord
from emonav_drake.palette import EMOTION_RGB, GOAL_RGB, ROBOT_RGB
from emonav_drake.params import EMOTION_NAMES, EmoNavConfig, load_config
from emonav_drake.scenarios.scenario import Scenario, StaticDiscSpec, sample_scenario

PNG = b"\x89PNG\r\n\x1a\n"


def _pixels_near(image, rgb, tol: int = 14) -> int:
    """How many pixels of the image (a path or a PIL image) are within `tol` (0…255 per
    channel) of `rgb`."""
    img = image if isinstance(image, Image.Image) else Image.open(image)
    img = np.asarray(img.convert("RGB")).astype(int)
    target = np.round(np.asarray(rgb) * 255).astype(int)
    return int((np.abs(img - target).max(axis=2) <= tol).sum())


def _sim_json(tmp_path_factory, name: str, *flags: str) -> dict:
    out = tmp_path_factory.mktemp(name) / "run.json"
    assert main(["sim", "--planner", "dwa", *flags, "--json", str(out)]) == 0
    return {"path": out, "data": json.loads(out.read_text())}


@pytest.fixture(scope="module")
def lip_run(tmp_path_factory):
    return _sim_json(tmp_path_factory, "lip", "--seed", "7")


@pytest.fixture(scope="module")
def varying_run(tmp_path_factory):
    return _sim_json(tmp_path_factory, "tv", "--seed", "3", "--time-varying")


# --------------------------------------------------------------------------- sim --json


def test_sim_json_trajectory_matches_the_record_and_the_scenario(lip_run):
    data = lip_run["data"]
    tr = data["trajectory"]
    steps = data["steps"]
    cfg = load_config()
    sc = sample_scenario(7, cfg)
    # one row per walking instant t_0 … t_K, one command per step
    assert len(tr["t"]) == len(tr["robot"]) == len(tr["pedestrians"]) == steps + 1
    assert len(tr["emotions"]) == steps + 1 and len(tr["command"]) == steps
    assert np.allclose(np.diff(tr["t"]), cfg.robot.step_time) and tr["t"][0] == 0.0
    assert (tr["planner"], tr["plant"], tr["seed"], tr["outcome"]) == (
        "dwa",
        "lip",
        7,
        data["outcome"],
    )
    # the path starts at the scenario's start and the pedestrians at theirs
    assert tr["robot"][0][:2] == pytest.approx(sc.robot_start, abs=1e-9)
    assert tr["scenario"]["start"] == sc.robot_start and tr["scenario"]["goal"] == sc.robot_goal
    starts = [p.start for p in sc.pedestrians]
    assert np.allclose(tr["pedestrians"][0], starts, atol=1e-3)
    assert tr["emotions"][0] == [EMOTION_NAMES.index(p.emotion) for p in sc.pedestrians]
    assert len(tr["scenario"]["obstacles"]) == len(sc.obstacles)
    assert tr["scenario"]["discomfort"] == {
        "happy": 0.2,
        "neutral": 0.35,
        "negative": 0.5,
        "static": cfg.reward.static_discomfort,
    }
    # the logged path is the one the record measured; commands within the robot's limits
    xy = np.array(tr["robot"])[:, :2]
    assert np.hypot(*np.diff(xy, axis=0).T).sum() == pytest.approx(data["path_length"], abs=0.02)
    u = np.array(tr["command"])
    assert (u[:, 0] >= -1e-9).all() and (u[:, 0] <= cfg.robot.max_speed + 1e-9).all()
    assert (np.abs(u[:, 1]) <= cfg.robot.max_heading_change + 1e-9).all()
    assert data["outcome"] == "success" and tr["collision"] is None
    assert math.dist(xy[-1], sc.robot_goal) <= cfg.episode.eval_goal_radius + 1e-3


def test_time_varying_emotions_follow_the_crowd_schedule(varying_run):
    tr = varying_run["data"]["trajectory"]
    cfg = load_config()
    cfg.crowd.time_varying_emotions = True
    crowd = Crowd(sample_scenario(3, cfg), cfg)
    # row k is the crowd before the updates at t_k: after t_k / dt crowd periods
    expected = [crowd.emotions_at(round(t / cfg.crowd.dt)).tolist() for t in tr["t"]]
    assert tr["emotions"] == expected
    assert len({tuple(row) for row in tr["emotions"]}) >= 2  # the emotion does change


# --------------------------------------------------------------------------- plot


@pytest.mark.slow
def test_plot_png_draws_the_episode(lip_run, tmp_path):
    png = tmp_path / "plot.png"
    assert main(["plot", str(lip_run["path"]), "--png", str(png), "--times", "0,8,16"]) == 0
    assert png.read_bytes()[:8] == PNG
    img = Image.open(png)
    assert img.size[0] == 1298 and 500 <= img.size[1] <= 1200  # (7.5 + 4.3) in at 110 dpi
    assert len(np.unique(np.asarray(img.convert("RGB")).reshape(-1, 3), axis=0)) > 100
    tr = lip_run["data"]["trajectory"]
    for e in {e for row in tr["emotions"] for e in row}:  # every emotion of the run is drawn
        assert _pixels_near(png, EMOTION_RGB[e]) > 200, EMOTION_NAMES[e]
    assert _pixels_near(png, ROBOT_RGB) > 200 and _pixels_near(png, GOAL_RGB) > 20


def test_plot_shows_every_emotion_of_a_time_varying_pedestrian(varying_run, tmp_path):
    png = tmp_path / "tv.png"
    assert main(["plot", str(varying_run["path"]), "--png", str(png)]) == 0
    codes = {e for row in varying_run["data"]["trajectory"]["emotions"] for e in row}
    assert len(codes) >= 2
    for e in codes:
        assert _pixels_near(png, EMOTION_RGB[e]) > 100, EMOTION_NAMES[e]


@pytest.mark.slow
def test_plot_gif_one_frame_per_step(tmp_path):
    # a short hand-made episode: 4 steps, so the animation test stays quick
    out = tmp_path / "short.json"
    sc_file = tmp_path / "sc.yaml"
    sc_file.write_text(
        "robot_start: [-4.0, 0.0]\nrobot_goal: [4.0, 0.0]\n"
        "obstacles:\n  - {center: [-2.5, 1.0], radius: 0.3}\n"
        "pedestrians:\n  - {start: [-2.0, -2.0], goal: [-2.0, 2.0], emotion: negative}\n"
    )
    cfg_file = tmp_path / "c.yaml"
    cfg_file.write_text("episode: {max_steps: 4}\n")
    argv = ["sim", "--scenario", str(sc_file), "--config", str(cfg_file), "--json", str(out)]
    assert main(argv) == 0
    tr = json.loads(out.read_text())["trajectory"]
    assert len(tr["t"]) == 5 and tr["outcome"] == "timeout"
    gif = tmp_path / "run.gif"
    assert main(["plot", str(out), "--gif", str(gif), "--fps", "5"]) == 0
    img = Image.open(gif)
    assert img.format == "GIF" and img.n_frames >= 5  # identical still frames may merge
    img.seek(img.n_frames - 1)
    assert _pixels_near(img, EMOTION_RGB[2], tol=20) > 50  # the negative pedestrian


def test_collision_point_is_on_the_touched_disc():
    cfg = EmoNavConfig()
    sc = Scenario(obstacles=[StaticDiscSpec(center=[0.0, 0.0], radius=0.4)])
    record = EpisodeRecord(outcome="collision", steps=2, seed=-1, collided_with="static")
    robot = [[-1.5, 0.0, 0.0, 0.0], [-1.1, 0.0, 0.0, 0.4], [-0.6, 0.1, 0.0, 0.4]]
    traj = build_trajectory(
        sc,
        cfg,
        record,
        t=[0.0, 0.4, 0.8],
        robot=robot,
        command=[[0.4, 0.0], [0.4, 0.0]],
        pedestrians=np.zeros((3, 0, 2)),
        emotions=np.zeros((3, 0), int),
        planner="dwa",
        plant="lip",
    )
    c = traj.collision
    assert c["with"] == "static" and c["k"] == 2 and c["t"] == pytest.approx(0.8)
    assert math.hypot(*c["point"]) == pytest.approx(0.4, abs=1e-3)  # on the surface
    # ... on the side facing the robot
    assert c["point"][0] < 0 and math.dist(c["point"], robot[-1][:2]) < cfg.robot.radius


def test_plot_marks_the_collision(tmp_path):
    cfg = EmoNavConfig()
    sc = Scenario(
        pedestrians=[],
        obstacles=[StaticDiscSpec(center=[0.0, 0.0], radius=0.4)],
    )
    record = EpisodeRecord(outcome="collision", steps=1, seed=-1, collided_with="static")
    traj = build_trajectory(
        sc,
        cfg,
        record,
        t=[0.0, 0.4],
        robot=[[-1.0, 0.0, 0.0, 0.0], [-0.6, 0.0, 0.0, 0.4]],
        command=[[0.4, 0.0]],
        pedestrians=np.zeros((2, 0, 2)),
        emotions=np.zeros((2, 0), int),
        planner="dwa",
        plant="lip",
    )
    run = tmp_path / "c.json"
    run.write_text(json.dumps({"outcome": "collision", "trajectory": traj.to_json()}))
    assert load_trajectory(run).collision == traj.collision
    png = tmp_path / "c.png"
    assert main(["plot", str(run), "--png", str(png)]) == 0
    assert _pixels_near(png, (0.0, 0.0, 0.0), tol=10) > 100  # the black collision cross


# --------------------------------------------------------------------------- errors


@pytest.mark.parametrize(
    "content, culprit",
    [
        ({"planner": "dwa", "summary": {"SR": 1.0}, "episodes": []}, "emonav eval"),
        ({"outcome": "success", "steps": 3, "seed": 0}, "older version"),
        ([1, 2, 3], "not an `emonav sim --json` file"),
    ],
)
def test_plot_without_a_trajectory_is_a_one_line_error(tmp_path, capsys, content, culprit):
    run = tmp_path / "old.json"
    run.write_text(json.dumps(content))
    png = tmp_path / "p.png"
    assert main(["plot", str(run), "--png", str(png)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("emonav: error:") and "\n" not in err
    assert "no 'trajectory' section" in err and culprit in err and str(run) in err
    assert not png.exists() and sorted(p.name for p in tmp_path.iterdir()) == ["old.json"]


def test_plot_flag_errors(tmp_path, capsys, lip_run):
    run = str(lip_run["path"])
    cases = [
        (["plot", run], "nothing to draw"),
        (["plot", run, "--png", str(tmp_path / "a.png"), "--times", "0,99"], "--times"),
        (["plot", run, "--png", str(tmp_path / "a.png"), "--times", "x"], "--times"),
        (["plot", run, "--gif", str(tmp_path / "a.avi")], ".gif or .mp4"),
        (["plot", str(tmp_path / "missing.json"), "--png", str(tmp_path / "a.png")], "missing"),
    ]
    for argv, culprit in cases:
        assert main(argv) == 2, argv
        assert culprit in capsys.readouterr().err
    bad = tmp_path / "bad.json"
    bad.write_text("{not json")
    assert main(["plot", str(bad), "--png", str(tmp_path / "b.png")]) == 2
    assert "not a JSON file" in capsys.readouterr().err
    assert not list(tmp_path.glob("*.png"))


# --------------------------------------------------------------------------- Digit


@pytest.mark.slow
def test_digit_sim_json_has_the_same_trajectory_section(tmp_path):
    """Three walking steps of the full-order Digit through `emonav sim --json`."""
    cfg_file = tmp_path / "c.yaml"
    cfg_file.write_text("episode: {max_steps: 3}\n")
    out = tmp_path / "d.json"
    argv = ["sim", "--plant", "digit", "--seed", "3", "--config", str(cfg_file)]
    assert main([*argv, "--json", str(out)]) == 0
    data = json.loads(out.read_text())
    tr = data["trajectory"]
    assert tr["plant"] == "digit" and data["steps"] == 3
    assert len(tr["t"]) == len(tr["robot"]) == len(tr["pedestrians"]) == len(tr["emotions"]) == 4
    assert len(tr["command"]) == 3
    sc = sample_scenario(3, load_config(cfg_file))
    # Digit's CoM starts within a few centimetres of the scenario's start
    assert math.dist(tr["robot"][0][:2], sc.robot_start) < 0.1
    assert np.allclose(tr["pedestrians"][0], [p.start for p in sc.pedestrians], atol=1e-3)
    png = tmp_path / "d.png"
    assert main(["plot", str(out), "--png", str(png)]) == 0 and png.read_bytes()[:8] == PNG


# --------------------------------------------------------------------------- lgm


@pytest.mark.slow
def test_lgm_figure_colours_pedestrians_by_emotion_and_shows_the_goal(tmp_path):
    png = tmp_path / "lgm.png"
    assert main(["lgm", "--seed", "5", "--time-varying", "--steps", "4", "--png", str(png)]) == 0
    assert png.read_bytes()[:8] == PNG
    img = Image.open(png)
    assert img.size == (1920, 816)  # 16 × 6.8 in at 120 dpi
    cfg = load_config()
    cfg.crowd.time_varying_emotions = True
    shown = {EMOTION_NAMES.index(p.emotion) for p in sample_scenario(5, cfg).pedestrians}
    for e in shown:
        assert _pixels_near(png, EMOTION_RGB[e]) > 50, EMOTION_NAMES[e]
    # the goal (7 m away) is beyond panel (a): drawn as an arrow at its edge
    assert _pixels_near(png, GOAL_RGB) > 50


def test_lgm_takes_only_its_own_flags():
    parser = build_parser()
    args = parser.parse_args(
        ["lgm", "--png", "x.png", "--seed", "1", "--steps", "2", "--time-varying"]
    )
    assert args.time_varying and args.steps == 2
    for flag in (["--checkpoint", "p.pt"], ["--device", "cuda"], ["--emotion-estimate", "e"]):
        with pytest.raises(SystemExit) as e:
            parser.parse_args(["lgm", "--png", "x.png", *flag])
        assert e.value.code == 2
