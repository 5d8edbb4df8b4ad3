"""Per-step export: `emonav walk --steps-out` and `emonav sim --steps-out` (CSV).

Real walks and episodes, no mocks: the CSV has one row per step with the documented
columns, the desired step is the LIP step map (Eq. 1) of the row's start state and
command, the errors are achieved − desired, consecutive rows chain, and the Digit
episode's rows are the planner's trace. A bad path fails before any work.
"""

import csv
import json
import math

import numpy as np
import pytest

from emonav_drake.cli import main
from emonav_drake.diagrams.navigation_digit import run_digit_episode
from emonav_drake.params import load_config
from emonav_drake.planners import configure_for, make_planner
from emonav_drake.robot.lip import LipState, lip_step, wrap_angle
from emonav_drake.robot.tracking import COLUMNS, error_statistics, sequence_tracking
from emonav_drake.scenarios.scenario import sample_scenario
from emonav_drake.systems.walking_command_source import command_sequence


def _read(path):
    with open(path, newline="") as f:
        reader = csv.reader(f)
        header = next(reader)
        rows = np.array([[float(v) for v in r] for r in reader])
    return header, rows.reshape(-1, len(header))


def _col(header, rows, name):
    return rows[:, header.index(name)]


def _check_desired_and_errors(header, rows, omega, step_time, atol):
    """desired = lip_step(start, u); errors = achieved − desired (heading wrapped)."""
    c = {n: _col(header, rows, n) for n in header}
    for i in range(len(rows)):
        start = LipState(c["x_start"][i], c["y_start"][i], c["heading_start"][i], c["v_start"][i])
        d = lip_step(start, c["u_v"][i], c["u_dtheta"][i], omega, step_time)
        assert c["x_des"][i] == pytest.approx(d.x, abs=atol)
        assert c["y_des"][i] == pytest.approx(d.y, abs=atol)
        assert wrap_angle(c["heading_des"][i] - d.heading) == pytest.approx(0.0, abs=1e-12)
    np.testing.assert_allclose(c["err_x"], c["x"] - c["x_des"], rtol=0, atol=1e-15)
    np.testing.assert_allclose(c["err_y"], c["y"] - c["y_des"], rtol=0, atol=1e-15)
    dth = [wrap_angle(a - b) for a, b in zip(c["heading"], c["heading_des"], strict=True)]
    np.testing.assert_allclose(c["err_heading"], dth, rtol=0, atol=1e-15)
    np.testing.assert_allclose(c["heading_des"], c["heading_start"] + c["u_dtheta"], atol=1e-15)
    th = c["heading_des"]
    fwd = np.cos(th) * c["err_x"] + np.sin(th) * c["err_y"]
    lat = -np.sin(th) * c["err_x"] + np.cos(th) * c["err_y"]
    np.testing.assert_allclose(c["err_forward"], fwd, atol=1e-15)
    np.testing.assert_allclose(c["err_lateral"], lat, atol=1e-15)
    # consecutive rows chain: same clock, previous command
    np.testing.assert_array_equal(c["step"], np.arange(len(rows)) + c["step"][0])
    np.testing.assert_array_equal(c["t_start"][1:], c["t"][:-1])
    np.testing.assert_array_equal(c["u_v_prev"][1:], c["u_v"][:-1])
    np.testing.assert_array_equal(c["u_dtheta_prev"][1:], c["u_dtheta"][:-1])
    return c


def test_walk_steps_out_one_row_per_step(tmp_path, capsys):
    out, js = tmp_path / "steps.csv", tmp_path / "walk.json"
    seed = 2
    args = ["walk", "--seconds", "3", "--seed", str(seed), "--steps-out", str(out)]
    assert main([*args, "--json", str(js)]) == 0
    assert "steps written to" in capsys.readouterr().out
    summary = json.loads(js.read_text())
    header, rows = _read(out)
    assert tuple(header) == COLUMNS
    assert summary["steps"] >= 6 and len(rows) == summary["steps"] - 1  # switch k → k + 1
    cfg = load_config()
    omega = math.sqrt(cfg.robot.gravity / summary["com_height"])  # H rounded to 0.1 mm
    c = _check_desired_and_errors(header, rows, omega, cfg.robot.step_time, atol=1e-5)
    # the commands are the seeded random sequence, step n reading command n
    seq = command_sequence("random", len(rows), cfg.robot, seed)
    np.testing.assert_allclose(c["u_v"], seq[:, 0], atol=1e-12)
    np.testing.assert_allclose(c["u_dtheta"], seq[:, 1], atol=1e-12)
    assert c["u_v_prev"][0] == 0.0 and c["u_dtheta_prev"][0] == 0.0  # it stood before
    # open loop: the LIP starts from the measured CoM and the accumulated commanded heading
    np.testing.assert_array_equal(c["x_start"][1:], c["x"][:-1])
    np.testing.assert_allclose(c["heading_start"][1:], c["heading_des"][:-1], atol=1e-12)
    # switches are locked to the step clock (stand_time + k T): at most the early-touchdown
    # window (10 % of T) ahead of an instant, never behind, so they never drift
    T, early = cfg.robot.step_time, 1.0 - cfg.walking.early_touchdown
    lead = (
        np.ceil((c["t"] - cfg.walking.stand_time) / T - 1e-9) * T + cfg.walking.stand_time - c["t"]
    )
    assert np.all(lead >= -1e-9) and np.all(lead <= early * T + 1e-9)
    # the walk's RMS in the JSON is the CSV's errors
    rms_x = math.sqrt(np.mean(c["err_x"] ** 2))
    assert summary["tracking_rms"]["x"] == pytest.approx(rms_x, abs=1e-5)
    assert 0.0 < rms_x < 0.1


@pytest.mark.slow
def test_sim_digit_steps_out_matches_the_trace(tmp_path, capsys):
    cfg_file = tmp_path / "short.yaml"
    cfg_file.write_text("episode:\n  max_steps: 5\n")
    out = tmp_path / "digit.csv"
    seed = 1
    argv = ["sim", "--plant", "digit", "--planner", "dwa", "--seed", str(seed)]
    assert main([*argv, "--config", str(cfg_file), "--steps-out", str(out)]) == 0
    assert "5 steps written to" in capsys.readouterr().out
    header, rows = _read(out)
    assert tuple(header) == COLUMNS and len(rows) == 5
    # the same episode in-process, with the trace the CSV is made from
    cfg = load_config(cfg_file)
    planner = make_planner("dwa", cfg)
    cfg, grid_kind = configure_for(planner, cfg)
    record, episode = run_digit_episode(
        sample_scenario(seed, cfg),
        cfg,
        planner,
        grid_kind=grid_kind,
        goal_radius=cfg.episode.eval_goal_radius,
        trace=True,
    )
    trace = episode.rows()  # the calibration files' row dicts
    assert record.steps == 5 and len(trace) == 6
    c = _check_desired_and_errors(header, rows, cfg.robot.omega, cfg.robot.step_time, 1e-12)
    robot = np.array([e["robot"] for e in trace])
    held = np.array([e["held"] for e in trace])
    np.testing.assert_array_equal(c["step"], [e["k"] for e in trace[:-1]])
    np.testing.assert_allclose(c["t_start"], [e["t"] for e in trace[:-1]], atol=1e-12)
    np.testing.assert_allclose(c["t"], [e["t"] for e in trace[1:]], atol=1e-12)
    # step k: the robot at t_k, the command u_k (held from t_k, read at t_{k+1}), the
    # robot at t_{k+1}; headings unwrapped along the episode (no wrap near 0 here)
    np.testing.assert_allclose(c["x_start"], robot[:-1, 0], atol=1e-12)
    np.testing.assert_allclose(c["y_start"], robot[:-1, 1], atol=1e-12)
    np.testing.assert_allclose(c["heading_start"], robot[:-1, 2], atol=1e-12)
    np.testing.assert_allclose(c["v_start"], robot[:-1, 3], atol=1e-12)
    np.testing.assert_allclose(c["u_v"], held[1:, 0], atol=1e-12)
    np.testing.assert_allclose(c["u_dtheta"], held[1:, 1], atol=1e-12)
    np.testing.assert_allclose(c["u_v_prev"], held[:-1, 0], atol=1e-12)
    np.testing.assert_allclose(np.column_stack([c["x"], c["y"]]), robot[1:, :2], atol=1e-12)
    # Digit stood during the first planner step while the LIP walked off at u_0
    assert c["u_v"][0] > 0.05 and abs(c["x"][0] - c["x_start"][0]) < 0.02
    assert c["err_forward"][0] < -0.02


def test_sim_lip_steps_out_has_zero_error(tmp_path, capsys):
    out = tmp_path / "lip.csv"
    assert main(["sim", "--plant", "lip", "--seed", "3", "--steps-out", str(out)]) == 0
    n = int(capsys.readouterr().out.split(" steps written")[0].split()[-1])
    header, rows = _read(out)
    assert len(rows) == n > 10
    cfg = load_config()
    _check_desired_and_errors(header, rows, cfg.robot.omega, cfg.robot.step_time, 1e-12)
    stats = error_statistics(rows)  # the plant is the LIP: it walks the planner's steps
    assert max(s["max"] for s in stats.values()) < 1e-9
    np.testing.assert_array_equal(_col(header, rows, "x_start")[1:], _col(header, rows, "x")[:-1])


@pytest.mark.parametrize("command", ["walk", "sim"])
def test_bad_steps_out_path_fails_before_any_work(tmp_path, capsys, command):
    missing = tmp_path / "no_such_folder" / "steps.csv"
    argv = [command, "--steps-out"]
    assert main([*argv, str(missing)]) == 2
    err = capsys.readouterr().err
    assert "--steps-out" in err and "does not exist" in err
    assert main([*argv, str(tmp_path)]) == 2  # a directory
    assert "is a directory" in capsys.readouterr().err
    same = tmp_path / "same.csv"
    assert main([*argv, str(same), "--json", str(same)]) == 2
    assert "the same file" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []  # nothing written, no temporary file left


def test_error_statistics_and_sequence_tracking():
    """The statistics of a known error sequence; a sequence of LIP steps tracks itself."""
    cfg = load_config()
    r = cfg.robot
    rng = np.random.default_rng(0)
    u = np.column_stack([rng.uniform(0, 0.4, 20), rng.uniform(-0.2, 0.2, 20)])
    states = [LipState(0.0, 0.0, 3.0, 0.0)]  # crosses ±π: headings are unwrapped
    for c in u:
        states.append(lip_step(states[-1], c[0], c[1], r.omega, r.step_time))
    x = np.array(states)
    x[5:, 0] += 0.01  # the robot is 1 cm ahead in x from step 4's end on
    table = sequence_tracking(np.arange(21) * 0.4, x, u, r.omega, r.step_time)
    h = COLUMNS.index
    err_x = table[:, h("err_x")]
    np.testing.assert_allclose(err_x, np.where(np.arange(20) == 4, 0.01, 0.0), atol=1e-12)
    assert np.abs(table[:, h("err_heading")]).max() < 1e-12
    assert np.all(np.abs(np.diff(table[:, h("heading")])) < 0.21)  # unwrapped
    s = error_statistics(table)["err_x"]
    assert s["mean"] == pytest.approx(0.0005) and s["max"] == pytest.approx(0.01)
    assert s["rms"] == pytest.approx(0.01 / math.sqrt(20))
    assert s["std"] == pytest.approx(np.std(err_x)) and s["p50"] == pytest.approx(0.0, abs=1e-12)
    assert math.isnan(error_statistics(table[:0])["err_y"]["rms"])
