"""Privileged or deployable, in every table the tool writes (issue 51, item 2): what each
method reads and whether a robot could run it."""

from __future__ import annotations

import pytest

from emonav_drake.cli import main
from emonav_drake.evaluation.tables import READS_HEADER, method_reads


def test_what_each_kind_of_method_reads():
    assert method_reads("state") == "the simulator's crowd — privileged"
    assert method_reads("state", "lidar") == "tracks in the exact scan — upper bound (exact scan)"
    assert method_reads("state", "lidar", "vlp16") == "tracks in the vlp16 scan — deployable"
    assert method_reads("LGM", "truth", "vlp16") == "LiDAR grid maps of the vlp16 scan — deployable"
    assert method_reads("DRLVO", "lidar", "vlp16").endswith("velocities — privileged")
    # a policy steered by the MPC is as deployable as the crowd the MPC reads
    assert method_reads("LGM", "truth", "vlp16", steered=True).endswith(
        "the MPC on the simulator's crowd — privileged"
    )
    assert method_reads("LGM", "lidar", "vlp16", steered=True).endswith("— deployable")


@pytest.mark.slow
def test_a_benchmark_table_says_what_each_row_reads(tmp_path, capsys):
    out = tmp_path / "run"
    argv = ["benchmark", "--planners", "dwa,policy", "--plant", "lip", "--trials", "1"]
    argv += ["--deployable", "--emotion-source", "truth", "--workers", "1", "--out", str(out)]
    assert main([*argv, "-q"]) == 0
    capsys.readouterr()
    md = (out / "tables.md").read_text()
    assert READS_HEADER in md
    table2 = md.split("## Table II")[1].split("\n## ")[0]
    rows = {
        line.split(" | ")[0].strip("| "): line for line in table2.splitlines() if "(n=1)" in line
    }
    assert rows["dwa"].endswith("tracks in the vlp16 scan — deployable |")
    assert rows["policy"].endswith("LiDAR grid maps of the vlp16 scan — deployable |")
    table3 = md.split("## Table III")[1].split("\n## ")[0]
    assert READS_HEADER in table3
    rows3 = {
        line.split(" | ")[0].strip("| "): line for line in table3.splitlines() if "(n=1)" in line
    }
    assert rows3["dwa"].endswith("tracks in the vlp16 scan — deployable |")
    assert rows3["policy"].endswith("LiDAR grid maps of the vlp16 scan — deployable |")
