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


def test_the_catalog_matches_every_shipped_checkpoint():
    """`data/policies/catalog.json` is what the checkpoints say, hash for hash and fact for
    fact (`python scripts/write_policy_catalog.py` rewrites it)."""
    from emonav_drake.planners.catalog import (
        DATA_DIR,
        catalog_key,
        describe_checkpoint,
        load_catalog,
    )
    from emonav_drake.provenance import sha256_file
    from emonav_drake.torch_load import load_checked

    catalog = load_catalog()
    files = sorted(DATA_DIR.rglob("*.pt"))
    assert set(catalog) == {catalog_key(p) for p in files}
    for path in files:
        expected = describe_checkpoint(load_checked(path), sha256_file(path), path.stat().st_size)
        assert catalog[catalog_key(path)] == expected, path.name


@pytest.mark.slow
def test_the_listing_reads_no_checkpoint_and_groups_the_planners():
    import subprocess
    import sys

    code = (
        "import sys\n"
        "from emonav_drake.cli import main\n"
        "assert main(['planners']) == 0\n"
        "assert 'torch' not in sys.modules, 'the listing imported torch'\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    ).stdout
    groups = [line for line in out.splitlines() if line and not line.startswith(" ")]
    assert groups[0] == "the default:" and groups[1].startswith("policy  [default")
    for header in ("model-based:", "learned baselines of the paper:"):
        assert header in groups
    assert "made by: teacher the OSQP MPC; imitation" in out  # SARL's route, from the catalog
    assert "route stages, ablations and shields (16; " in out
    assert (
        "emobipednav_mixed" in out
        and "    spec: !PolicySpec {variant: 'emobipednav_mixed'}" not in out
    )


def test_all_lists_every_planner_with_how_it_was_made(capsys):
    assert main(["planners", "--all"]) == 0
    out = capsys.readouterr().out
    for name in planner_names():
        assert f"\n{name}\n" in out or f"\n{name}  [" in out or out.startswith(name), name
    assert "    spec: !PolicySpec {variant: 'emobipednav_mixed'}" in out
    assert "teacher the OSQP MPC; starts from the LIP-trained policy" in out
