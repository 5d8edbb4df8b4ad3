"""`emonav planners`: every planner with what it reads and runs."""

import json

import pytest

from emonav_drake.cli import main
from emonav_drake.cli.planners_cmd import planner_rows
from emonav_drake.planners import planner_names
from emonav_drake.planners.policy import DEFAULT_POLICY


def test_every_planner_is_listed_with_what_it_reads():
    rows = {r.name: r for r in planner_rows()}
    assert list(rows) == list(planner_names())
    for name in ("dwa", "mpc", "sarl", "rgl", "mpc_digit"):
        assert rows[name].privileged.startswith("privileged")
        assert "--state-source lidar" in rows[name].privileged
    assert rows["policy"].privileged.startswith("deployable")
    assert rows["policy"].checkpoint.endswith(DEFAULT_POLICY.name)
    assert rows["policy"].default and not rows["dwa"].default
    assert rows["drlvo"].privileged.startswith("privileged")  # velocities from the simulator
    assert rows["ogm"].reads.endswith("occupancy grid maps")
    assert "LGM shield" in rows["policy_shield"].reads
    assert rows["sac"].checkpoint.startswith("- ")
    assert all(r.summary for r in rows.values())


def test_the_command_prints_text_and_json(capsys):
    assert main(["planners"]) == 0
    text = capsys.readouterr().out
    assert "policy  [default learned policy; sim/eval default]" in text
    assert main(["planners", "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)
    assert {r["name"] for r in rows} == set(planner_names())


@pytest.mark.parametrize("name", ["mpc_digit", "dwa_digit", "policy_shield_digit", "rgl"])
def test_a_planners_spec_as_listed_is_a_routes_expert_as_written(name):
    """The spec `emonav planners` prints is the YAML a route writes for that expert: read
    back, it is the registered spec."""
    from emonav_drake.learning.config import DaggerConfig
    from emonav_drake.planners import planner_kind
    from emonav_drake.typed_yaml import load_typed_yaml

    (row,) = [r for r in planner_rows() if r.name == name]
    route = load_typed_yaml(DaggerConfig, data=f"expert: {row.spec}\n")
    assert route.expert == planner_kind(name).spec
