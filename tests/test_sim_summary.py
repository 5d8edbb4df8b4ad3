"""What one `emonav sim` line says (issue 51, item 6): the planner and plant that ran, and
what was hit; the default planner is the shipped default policy, as in the README's demo."""

from __future__ import annotations

from emonav_drake.cli import main
from emonav_drake.cli.sim import outcome_words
from emonav_drake.navigation.metrics import EpisodeRecord


def _line(capsys, *argv: str) -> str:
    assert main(["sim", *argv, "--quiet"]) == 0
    return capsys.readouterr().out.strip().splitlines()[-1]


def test_a_collision_with_a_static_disc_says_so_and_names_the_planner(capsys):
    # seed 72: this learned baseline walks into a disc (benchmarks/results/lip_guide)
    line = _line(capsys, "--planner", "emobipednav_digit_mpc", "--seed", "72")
    assert line.startswith("seed 72, emobipednav_digit_mpc on LIP: collision with a static disc")


def test_without_planner_sim_runs_the_default_policy(capsys):
    line = _line(capsys, "--family", "blocker", "--seed", "3")
    assert line.startswith("family blocker, seed 3, policy on LIP: ")


def test_every_outcome_in_words():
    words = {
        ("collision", "wall", ""): "collision with a wall",
        ("collision", "negative", ""): "collision with a negative pedestrian",
        ("fall", "", "pelvis below 0.6 m"): "fall (pelvis below 0.6 m)",
        ("no_route", "", ""): "no route left",
        ("success", "", ""): "success",
        ("timeout", "", ""): "timeout",
    }
    for (outcome, hit, reason), text in words.items():
        record = EpisodeRecord(outcome=outcome, collided_with=hit, fall_reason=reason)
        assert outcome_words(record) == text
