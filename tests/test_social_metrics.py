"""The field's social-navigation metrics (navigation/social_metrics.py, docs/metrics.md): each
on a hand-made walk whose answer is worked out by hand, then through real LIP episodes
(the fast world and the Drake diagram), old records and the benchmark's tables."""

import json
import math
from pathlib import Path

import numpy as np
import pytest

from emonav_drake.crowd.crowd import CrowdSnapshot
from emonav_drake.evaluation import tables
from emonav_drake.evaluation.run_directory import load_run
from emonav_drake.evaluation.trial_check import check_trial
from emonav_drake.navigation.lip_world import NavigationWorld
from emonav_drake.navigation.metrics import (
    EpisodeTracker,
    format_summary,
    record_from_json,
    summarize,
)
from emonav_drake.navigation.reward import StepEvaluation
from emonav_drake.navigation.social_metrics import (
    INTRUSION_DISTANCE,
    SOCIAL_FIELDS,
    TTC_THRESHOLD,
    check_social_fields,
    times_to_collision,
)
from emonav_drake.navigation.social_metrics import StepMotion as Motion
from emonav_drake.params import EmoNavConfig
from emonav_drake.planners.dwa import DwaPlanner
from emonav_drake.planners.replay import ReplayPlanner
from emonav_drake.robot.lip import LipState
from emonav_drake.scenarios.scenario import sample_scenario

ROOT = Path(__file__).resolve().parent.parent
LIP_RUN = ROOT / "benchmarks" / "results" / "lip_table2"
T = 0.4  # walking step [s]
R = 0.3  # robot and pedestrian radius [m]
GOAL = np.array([4.0, 0.0])


def _crowd(positions=(), velocities=None) -> CrowdSnapshot:
    p = np.asarray(positions, dtype=float).reshape(-1, 2)
    v = np.zeros_like(p) if velocities is None else np.asarray(velocities, float).reshape(-1, 2)
    return CrowdSnapshot(
        positions=p,
        velocities=v,
        radius=R,
        emotions=np.ones(len(p), dtype=np.int64),
        discomfort=np.full(len(p), 0.35),
        static_centers=np.zeros((0, 2)),
        static_radii=np.zeros(0),
        static_discomfort=0.2,
    )


def _quiet_step() -> StepEvaluation:
    """A step with no event: the paper's metrics are not what these tests look at."""
    return StepEvaluation(0.0, False, False, False, (0, 0, 0, 0), math.inf, 1.0)


def _walk(poses, crowds=None, commands=None, max_steps=100) -> EpisodeTracker:
    """A tracker fed the steps between consecutive `poses` (x, y, θ, v)."""
    tracker = EpisodeTracker(max_steps, T)
    states = [LipState(*map(float, p)) for p in poses]
    for k in range(len(states) - 1):
        crowd = crowds[k] if crowds is not None else _crowd()
        u = None if commands is None or commands[k] is None else np.asarray(commands[k], float)
        a, b = states[k], states[k + 1]
        motion = Motion(a, b, crowd, GOAL, R, u)
        tracker.add(_quiet_step(), math.hypot(b.x - a.x, b.y - a.y), motion=motion)
    return tracker


def _straight(n: int, y: float = 0.0, step: float = 0.4):
    return [(step * k, y, 0.0, 0.4 if k else 0.0) for k in range(n + 1)]


# --- path irregularity ------------------------------------------------------------------


def test_a_straight_walk_at_the_goal_has_no_irregularity():
    rec = _walk(_straight(5)).record
    assert rec.path_irregularity == 0.0 and rec.path_length == pytest.approx(2.0)


def test_a_zigzag_turns_0_4_rad_in_1_6_m():
    # θ: 0 → 0.2 → 0 → 0 → 0 while walking 0.4 m a step: 0.4 rad of turning that facing
    # the goal (straight ahead from the start) never needed, over 1.6 m.
    poses = [(0, 0, 0, 0), (0.4, 0, 0.2, 0.4), (0.8, 0, 0, 0.4), (1.2, 0, 0, 0.4), (1.6, 0, 0, 0.4)]
    assert _walk(poses).record.path_irregularity == pytest.approx(0.4 / 1.6)


def test_turning_to_face_the_goal_is_not_irregular():
    # starting sideways (θ0 = π/2, goal straight along x): the first quarter turn is needed
    poses = [(0, 0, math.pi / 2, 0), (0, 0.1, math.pi / 4, 0.2), (0.2, 0.1, 0, 0.4)]
    poses += [(0.6, 0.1, 0, 0.4), (1.0, 0.1, -0.3, 0.4)]
    path = 0.1 + 0.2 + 0.4 + 0.4
    assert _walk(poses).record.path_irregularity == pytest.approx(0.3 / path)


def test_irregularity_is_undefined_before_the_robot_moves():
    rec = _walk([(0, 0, 0, 0), (0, 0, 0.2, 0)]).record
    assert rec.path_irregularity is None and rec.steps == 1


# --- jerk of the commanded motion -----------------------------------------------------


def test_jerk_of_a_speed_ramp():
    # V = 0, 0.2, 0.4, 0.4 m/s along x: J_2 = (0.4 − 0.4 + 0) / T² = 0,
    # J_3 = (0.4 − 0.8 + 0.2) / 0.16 = −1.25 m/s³ → mean |J| = 0.625 m/s³
    commands = [(0.0, 0.0), (0.2, 0.0), (0.4, 0.0), (0.4, 0.0)]
    rec = _walk(_straight(4), commands=commands).record
    assert rec.jerk_mean == pytest.approx(0.625)


def test_jerk_of_a_steady_turn():
    # constant speed v turning φ per step: |V_k − 2V_{k−1} + V_{k−2}| = v |e^{iφ} − 1|²
    # = 4 v sin²(φ/2), so every J_k is 4 · 0.4 · sin²(0.1) / 0.16 = 10 sin²(0.1)
    rec = _walk(_straight(6), commands=[(0.4, 0.2)] * 6).record
    assert rec.jerk_mean == pytest.approx(10 * math.sin(0.1) ** 2)


def test_jerk_needs_three_commands_and_every_command():
    assert _walk(_straight(2), commands=[(0.4, 0.0)] * 2).record.jerk_mean is None
    assert _walk(_straight(3), commands=[(0.4, 0.0)] * 3).record.jerk_mean == 0.0
    gap = [(0.4, 0.0), None, (0.4, 0.0), (0.4, 0.0), (0.4, 0.0)]
    rec = _walk(_straight(5), commands=gap).record
    assert rec.jerk_mean is None and rec.intrusion_ratio == 0.0  # the others are measured


# --- time to collision --------------------------------------------------------------------


def test_time_to_collision_head_on_offset_missing_touching_and_leaving():
    contact = 2 * R
    rel_p = [[5.0, 0.0], [5.0, 0.5], [5.0, 0.7], [0.5, 0.0], [2.0, 0.0]]
    rel_v = [[-1.4, 0.0], [-1.4, 0.0], [-1.4, 0.0], [0.0, 0.0], [1.0, 0.0]]
    ttc = times_to_collision(np.array(rel_p), np.array(rel_v), contact)
    assert ttc[0] == pytest.approx((5.0 - 0.6) / 1.4)  # head on, closing at 1.4 m/s
    assert ttc[1] == pytest.approx((5.0 - math.sqrt(0.6**2 - 0.5**2)) / 1.4)  # 0.5 m off
    assert ttc[2] == math.inf  # 0.7 m off: passes by
    assert ttc[3] == 0.0  # already touching
    assert ttc[4] == math.inf  # moving apart


def test_a_pedestrian_walking_at_the_robot_is_below_the_threshold_when_close():
    # robot walks +x at 0.4 m/s, the pedestrian comes at it at 1 m/s along the same line:
    # TTC = (gap − 0.6) / 1.4 = 4.4 / 1.4 = 3.14 s (not below 3 s), then 3.4 / 1.4 = 2.43 s
    poses = [(0, 0, 0, 0), (0.4, 0, 0, 0.4), (0.8, 0, 0, 0.4)]
    crowds = [_crowd([[5.4, 0.0]], [[-1.0, 0.0]]), _crowd([[4.8, 0.0]], [[-1.0, 0.0]])]
    assert TTC_THRESHOLD == 3.0
    rec = _walk(poses, crowds).record
    assert rec.low_ttc_ratio == 0.5
    # a standing pedestrian the robot walks past 0.5 m off its line is never on course
    far = [_crowd([[3.0, 1.1]])] * 2
    assert _walk(poses, far).record.low_ttc_ratio == 0.0


# --- clearance and intrusions -------------------------------------------------------------


def test_passing_a_standing_pedestrian_0_2_m_apart():
    # centre 0.8 m to the side of the robot's line, at x = 2: surfaces 0.2 m apart at the
    # closest step (x = 2.0); at x = 1.6 and 2.4 they are √0.8 − 0.6 = 0.294 m apart, so
    # one step of ten is an intrusion (< 0.25 m), with clearance 0.2 m
    assert INTRUSION_DISTANCE == 0.25
    poses = _straight(10)
    crowds = [_crowd([[2.0, 0.8], [9.0, 5.0]])] * 10
    rec = _walk(poses, crowds).record
    assert rec.intrusion_ratio == 0.1
    assert rec.intrusion_clearance == pytest.approx(0.2)
    assert rec.min_ped_clearance == pytest.approx(0.2)
    # 0.9 m to the side: 0.3 m at the closest, no intrusion
    wide = _walk(poses, [_crowd([[2.0, 0.9]])] * 10).record
    assert wide.intrusion_ratio == 0.0 and wide.intrusion_clearance is None
    assert wide.min_ped_clearance == pytest.approx(0.3)


def test_no_pedestrian_no_clearance():
    rec = _walk(_straight(3)).record
    assert rec.min_ped_clearance is None and rec.intrusion_ratio == 0.0
    assert rec.low_ttc_ratio == 0.0


def test_a_step_without_motion_leaves_the_episode_unmeasured():
    tracker = _walk(_straight(3))
    tracker.add(_quiet_step(), 0.4)  # the old call: no motion
    assert all(getattr(tracker.record, f) is None for f in SOCIAL_FIELDS)
    state = LipState(1.6, 0.0, 0.0, 0.4)
    tracker.add(_quiet_step(), 0.0, motion=Motion(state, state, _crowd(), GOAL, R))
    assert tracker.record.intrusion_ratio is None and tracker.record.steps == 5


# --- real LIP episodes ------------------------------------------------------------------


def _world_episode(seed: int, planner, cfg: EmoNavConfig) -> NavigationWorld:
    world = NavigationWorld(sample_scenario(seed, cfg), cfg, goal_radius=0.2, grid_kind=None)
    while not world.tracker.done:
        world.step(planner.plan(world.planner_input()))
    return world


def test_a_lip_episode_carries_the_metrics_and_the_diagram_gives_the_same():
    from emonav_drake.diagrams.navigation import run_episode

    cfg = EmoNavConfig()
    seed = 1  # weaving at 0.2–0.4 m/s, it walks into a happy pedestrian at step 29
    commands = np.column_stack([np.random.default_rng(7).uniform(0.2, 0.4, 60), np.full(60, 0.05)])
    commands[:, 1] *= np.where(np.arange(60) % 10 < 5, 1.0, -1.0)  # weaving
    world = _world_episode(seed, ReplayPlanner(commands), cfg)
    rec = world.record
    record, log = run_episode(
        sample_scenario(seed, cfg), cfg, ReplayPlanner(commands), goal_radius=0.2, trace=True
    )
    assert record.to_json() == rec.to_json()  # the Drake monitor, command port included
    assert all(getattr(rec, f) is not None for f in SOCIAL_FIELDS if f != "intrusion_clearance")
    # recomputed here from the episode's trace, by a second route
    robot = np.array(log.robot)
    turning = np.abs(np.angle(np.exp(1j * np.diff(robot[:, 2])))).sum()
    (x0, y0, theta0, _), (gx, gy) = robot[0], world.goal_xy
    least = abs(math.remainder(math.atan2(gy - y0, gx - x0) - theta0, 2 * math.pi))
    assert rec.path_irregularity == pytest.approx((turning - least) / rec.path_length)
    u = np.array(log.commands)
    heading = np.cumsum(u[:, 1])
    v = u[:, :1] * np.column_stack([np.cos(heading), np.sin(heading)])
    jerk = np.linalg.norm(v[2:] - 2 * v[1:-1] + v[:-2], axis=1) / T**2
    assert rec.jerk_mean == pytest.approx(jerk.mean())
    gaps = [
        np.linalg.norm(p - r[:2], axis=1).min() - 2 * R
        for p, r in zip(log.pedestrians[1:], robot[1:], strict=True)
    ]
    assert rec.min_ped_clearance == pytest.approx(min(gaps))
    assert rec.min_ped_clearance == pytest.approx(rec.min_ped_distance - 2 * R)
    intrusions = [g for g in gaps if g < INTRUSION_DISTANCE]
    assert rec.intrusion_ratio == pytest.approx(len(intrusions) / rec.steps)
    assert len(intrusions) == 7 and rec.intrusion_clearance == pytest.approx(np.mean(intrusions))
    assert rec.outcome == "collision" and rec.min_ped_clearance <= 0  # touching at the end
    low = rec.low_ttc_ratio * rec.steps  # a whole number of steps
    assert low >= 1 and low == pytest.approx(round(low))
    assert check_social_fields(rec.to_json()) is None


def test_a_restored_world_keeps_measuring_and_an_old_state_does_not():
    cfg = EmoNavConfig()
    dwa = DwaPlanner(cfg)
    full = _world_episode(11, dwa, cfg)
    world = NavigationWorld(sample_scenario(11, cfg), cfg, goal_radius=0.2, grid_kind=None)
    for _ in range(10):
        world.step(dwa.plan(world.planner_input()))
    saved = world.state_dict()
    again = NavigationWorld.from_state_dict(saved, cfg)
    old = dict(saved, tracker={k: v for k, v in saved["tracker"].items() if k != "social"})
    before = NavigationWorld.from_state_dict(old, cfg)
    for w in (again, before):
        while not w.tracker.done:
            w.step(dwa.plan(w.planner_input()))
    assert again.record.to_json() == full.record.to_json()
    stale = before.record.to_json()
    assert all(stale[f] is None for f in SOCIAL_FIELDS)  # not measured, rather than wrong
    assert {k: stale[k] for k in ("outcome", "steps", "idt")} == {
        k: full.record.to_json()[k] for k in ("outcome", "steps", "idt")
    }


@pytest.mark.slow
def test_committed_lip_trials_re_run_bit_identical_in_their_old_fields():
    """The paper's setting (lip_table2): DWA seeds 0–2 and the policy's seed 0, re-run now,
    give every field the run recorded exactly, plus the new ones."""
    from emonav_drake.diagrams.trials import TrialRunner
    from emonav_drake.evaluation.run_settings import spec_from_settings

    settings, trials = load_run(LIP_RUN)
    recorded = {(t["method"], t["seed"]): t["record"] for t in trials}
    runner = TrialRunner(spec_from_settings(settings))
    for method, seed in [("dwa", 0), ("dwa", 1), ("dwa", 2), ("sac", 0)]:
        old = recorded[(method, seed)]
        assert not set(SOCIAL_FIELDS) & set(old)  # recorded before the field's metrics
        new = runner.run(method, seed)["record"]
        assert {k: new[k] for k in old} == old, (method, seed)
        assert new["path_irregularity"] is not None and new["intrusion_ratio"] is not None


# --- old records, summaries and tables ------------------------------------------------------


def _committed_lines(n: int) -> list[dict]:
    lines = (LIP_RUN / "trials.jsonl").read_text().splitlines()[:n]
    return [json.loads(line) for line in lines]


def test_old_records_read_as_not_measured_and_tables_show_n_a():
    old = _committed_lines(6)
    assert all(check_trial(t) is None for t in old)
    records = [record_from_json(t["record"]) for t in old]
    assert all(getattr(r, f) is None for r in records for f in SOCIAL_FIELDS)
    s = summarize(records)
    assert all(s[f"{f}_n"] == 0 and s[f"{f}_mean"] is None for f in SOCIAL_FIELDS)
    assert "irregularity" not in format_summary(s)  # the paper's line only
    summary = tables.summarize_methods(old)
    _, rows = tables.field_rows(summary)
    assert all(cell == "n/a" for row in rows for cell in row[2:])
    csv_rows = tables.social_csv(summary).splitlines()
    assert "path_irregularity_mean" in csv_rows[0] and csv_rows[1].endswith(",,,0")


def test_tables_show_means_with_t_intervals_and_count_a_mixed_run():
    cfg = EmoNavConfig()
    dwa = DwaPlanner(cfg)
    new = [
        {
            "method": "dwa",
            "seed": s,
            "plant": "lip",
            "record": _world_episode(s, dwa, cfg).record.to_json(),
        }
        for s in (20, 21, 22, 23, 24)
    ]
    old = [t | {"method": "dwa", "seed": 100 + i} for i, t in enumerate(_committed_lines(2))]
    for t in new:
        assert check_trial(t) is None
    s = tables.summarize_methods(new + old)["dwa"]
    values = [t["record"]["path_irregularity"] for t in new]
    from scipy.stats import t as student

    half = student.ppf(0.975, 4) * np.std(values, ddof=1) / math.sqrt(5)
    assert s["path_irregularity_n"] == 5
    assert s["path_irregularity_mean"] == pytest.approx(np.mean(values))
    assert s["path_irregularity_ci"] == pytest.approx(
        [np.mean(values) - half, np.mean(values) + half]
    )
    cell = tables.format_mean_ci(s, "path_irregularity")
    assert cell == (
        f"{np.mean(values):.3f} [{np.mean(values) - half:.3f}, {np.mean(values) + half:.3f}] (n=5)"
    )
    # below MIN_INTERVAL_N values: the mean alone, no interval from a handful of samples
    few = tables.summarize_methods(new[:3] + old)["dwa"]
    assert few["path_irregularity_ci"] is None
    assert tables.format_mean_ci(few, "path_irregularity") == f"{np.mean(values[:3]):.3f} (n=3)"
    md = tables.render_markdown(new + old, ["dwa"], "paper", "lip")
    assert "## Field metrics" in md and cell in md
    # the social section keeps its table (the docs quote it) ahead of the new one
    assert md.index("## Social metrics") < md.index("## Field metrics")
    line = format_summary(summarize([record_from_json(t["record"]) for t in new]))
    assert "irregularity" in line and f"TTC < {TTC_THRESHOLD:g} s" in line


@pytest.mark.parametrize(
    ("edit", "words"),
    [
        ({"intrusion_ratio": 1.5}, "share of the record's"),
        ({"low_ttc_ratio": 0.123}, "share of the record's"),
        ({"jerk_mean": -1.0}, "must be >= 0"),
        ({"path_irregularity": "x"}, "finite number or null"),
        ({"intrusion_ratio": 0.0, "intrusion_clearance": 0.1}, "exactly when there was one"),
    ],
)
def test_a_trial_with_impossible_field_metrics_is_refused(edit, words):
    t = _committed_lines(1)[0]
    r = t["record"] | {f: None for f in SOCIAL_FIELDS} | {"intrusion_ratio": 0.0}
    assert check_trial(t | {"record": r}) is None
    problem = check_trial(t | {"record": r | edit})
    assert problem is not None and words in problem


@pytest.mark.slow
def test_compare_joins_a_run_recorded_before_the_metrics_with_a_new_one(tmp_path):
    import shutil

    from emonav_drake.cli import main
    from emonav_drake.evaluation.combine import combine_runs

    new = tmp_path / "new"
    argv = ["benchmark", "--planners", "dwa", "--trials", "2", "--first-seed", "30"]
    assert main([*argv, "--workers", "1", "--quiet", "--out", str(new)]) == 0
    old = tmp_path / "old"
    shutil.copytree(new, old)
    lines = [json.loads(line) for line in (old / "trials.jsonl").read_text().splitlines()]
    for t in lines:  # as recorded before the field's metrics
        t["record"] = {k: v for k, v in t["record"].items() if k not in SOCIAL_FIELDS}
    (old / "trials.jsonl").write_text("".join(json.dumps(t) + "\n" for t in lines))
    for runs in ([old, new], [new, old]):
        _, trials = combine_runs(runs)
        assert len(trials) == 2 and all("jerk_mean" in t["record"] for t in trials)
    lines[0]["record"]["total_reward"] += 1.0  # an old field that differs: another trial
    (old / "trials.jsonl").write_text("".join(json.dumps(t) + "\n" for t in lines))
    with pytest.raises(ValueError, match="differs from the same trial"):
        combine_runs([new, old])


def test_a_share_s_interval_stays_within_zero_and_one():
    from emonav_drake.navigation.metrics import EpisodeRecord, summarize

    recs = [EpisodeRecord(intrusion_ratio=v, low_ttc_ratio=1.0 - v) for v in (0, 0, 0, 0, 0.1)]
    s = summarize(recs)
    assert s["intrusion_ratio_ci"][0] == 0.0 < s["intrusion_ratio_ci"][1]
    assert s["low_ttc_ratio_ci"][1] == 1.0 > s["low_ttc_ratio_ci"][0]
    assert s["intrusion_ratio_mean"] == pytest.approx(0.02)
