"""The MPC gives the same result on a loaded machine: `emonav eval --planner mpc` beside
a CPU hog and under repeated stalls of its process is byte-identical to a quiet run, and
`emonav benchmark` on Ray beside a CPU hog equals the serial run record for record.

The stalls (the process stopped 0.12 s, then run 0.02 s, again and again) cut any QP that
spans a stop past a 0.1 s wall-clock limit — what made the MPC irreproducible when OSQP's
`time_limit` decided where a solve ended.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from emonav_drake.diagrams.trials import method_specs
from emonav_drake.evaluation.benchmark import run_benchmark
from emonav_drake.evaluation.run_directory import comparable, read_trials
from emonav_drake.params import load_config
from tests.machine_load import cpu_hogs, stalls

SEED = 77  # the seed of the report: its path length moved in the 4th digit under load

# `emonav eval` with its imports done first, so that the load starts on the episodes
_DRIVER = """
import sys
import emonav_drake.cli as cli
import emonav_drake.planners.mpc, emonav_drake.diagrams.evaluation_episode, emonav_drake.planners
print("READY", flush=True)
sys.stdin.readline()
sys.exit(cli.main(sys.argv[1:]))
"""


def _eval(out: Path, load: str | None) -> bytes:
    argv = ["eval", "--planner", "mpc", "--episodes", "1", "--first-seed", str(SEED)]
    proc = subprocess.Popen(
        [sys.executable, "-c", _DRIVER, *argv, "--json", str(out)],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        text=True,
    )
    try:
        assert proc.stdout.readline().strip() == "READY"
        if load == "stalls":
            with stalls(proc.pid) as first:
                proc.stdin.write("go\n")
                proc.stdin.flush()
                assert proc.wait(timeout=300) == 0
            assert first.is_set()
        elif load == "hogs":
            with cpu_hogs(1):
                proc.stdin.write("go\n")
                proc.stdin.flush()
                assert proc.wait(timeout=300) == 0
        else:
            proc.stdin.write("go\n")
            proc.stdin.flush()
            assert proc.wait(timeout=300) == 0
    finally:
        proc.kill()
        proc.wait()
    return out.read_bytes()


@pytest.mark.slow
def test_mpc_eval_is_byte_identical_beside_a_cpu_hog_and_under_stalls(tmp_path):
    quiet = _eval(tmp_path / "quiet.json", None)
    assert json.loads(quiet)["episodes"][0]["seed"] == SEED
    assert _eval(tmp_path / "hogs.json", "hogs") == quiet
    assert _eval(tmp_path / "stalls.json", "stalls") == quiet


def _records(run: Path) -> set[str]:
    return {json.dumps(comparable(t), sort_keys=True) for t in read_trials(run / "trials.jsonl")}


@pytest.mark.slow
def test_benchmark_mpc_on_ray_beside_a_cpu_hog_equals_serial(tmp_path):
    kwargs = dict(methods=method_specs("mpc"), plant="lip", trials=3, first_seed=SEED)
    run_benchmark(
        out=tmp_path / "serial", config=load_config(), workers=1, progress=False, **kwargs
    )
    with cpu_hogs(1):
        run_benchmark(
            out=tmp_path / "ray", config=load_config(), workers=2, progress=False, **kwargs
        )
    assert _records(tmp_path / "ray") == _records(tmp_path / "serial")
    assert len(_records(tmp_path / "serial")) == 3
