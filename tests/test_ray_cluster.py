"""`emonav benchmark --ray-address` on a real two-node Ray cluster (issue 36;
docs/reliability.md, "A benchmark on a Ray cluster").

The cluster is what a user starts by hand: `ray start --head` and `ray start --address` on
a second node, with token authentication. Both nodes run on this machine, inside a
private network and process namespace (`unshare -rnpf`) whose only interface is the
loopback one: the head on 127.0.0.1, the second node on 127.0.0.2 (an address of its own,
as a second machine has), nothing of either reachable from another host, and every
process they start ends with the namespace.

The benchmark's trials must equal a serial run's record for record, also when the second
node is killed in the middle of the run (SIGKILL of its raylet, as a machine that fails):
the trials it held are run again on the head, nothing is lost and nothing is counted twice.
"""

from __future__ import annotations

import json
import os
import secrets
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest

from emonav_drake.cli import main
from emonav_drake.evaluation.run_directory import comparable, read_trials

TRIALS = 60  # per method: long enough to lose a node mid-run
FIRST_SEED = 1000
PLANNERS = "dwa"
MARK = "RESULT "


def _namespaces_work() -> str | None:
    """Why a private network + process namespace cannot be made here, or None."""
    if shutil.which("unshare") is None:
        return "no unshare(1)"
    p = subprocess.run(["unshare", "-rnpf", "--mount-proc", "true"], capture_output=True)
    return None if p.returncode == 0 else p.stderr.decode().strip() or "unshare failed"


@pytest.mark.slow
def test_a_benchmark_on_a_two_node_cluster_equals_the_serial_run_and_survives_a_lost_node(
    tmp_path,
):
    why = _namespaces_work()
    if why is not None:
        pytest.skip(f"cannot make a private network namespace: {why}")
    serial = tmp_path / "serial"
    argv = ["benchmark", "--planners", PLANNERS, "--trials", str(TRIALS)]
    argv += ["--first-seed", str(FIRST_SEED), "--workers", "1", "--quiet"]
    assert main([*argv, "--out", str(serial)]) == 0

    token = tmp_path / "ray_token"
    token.write_text(secrets.token_hex(32))
    token.chmod(0o600)
    temp = tempfile.mkdtemp(prefix="rc", dir="/tmp")  # short: Ray's socket paths
    script = Path(__file__).with_name("ray_cluster_run.py")
    out = tmp_path / "cluster"
    try:
        p = subprocess.run(
            ["unshare", "-rnpf", "--mount-proc", sys.executable, str(script), str(out)]
            + [str(token), temp, str(TRIALS), str(FIRST_SEED), PLANNERS, str(TRIALS // 4)],
            capture_output=True,
            text=True,
            timeout=1200,
            env={k: v for k, v in os.environ.items() if not k.startswith("RAY_")},
        )
    finally:
        shutil.rmtree(temp, ignore_errors=True)
    lines = [line for line in p.stdout.splitlines() if line.startswith(MARK)]
    assert lines, (p.returncode, p.stdout[-2000:], p.stderr[-3000:])
    result = json.loads(lines[-1][len(MARK) :])
    print(json.dumps(result, indent=1))  # what the run measured (shown with -s)
    assert "error" not in result, result
    assert result["head_raylets"] == 1 and result["second_raylets"] == 1, result
    # the cluster's only network was the loopback interface: nothing reachable from outside
    assert result["interfaces"] == ["lo"], result["interfaces"]
    assert result["killed_processes"] >= 2, result  # the raylet and at least its worker
    assert result["rc"] == 0, result
    assert 0 < result["at_kill"] < TRIALS, result  # the node was lost mid-run ...
    assert "a Ray worker was lost" in result["stderr"], result  # ... with trials on it
    cluster = read_trials(out / "trials.jsonl")
    reference = read_trials(serial / "trials.jsonl")
    key = lambda t: (t["method"], t["seed"])  # noqa: E731
    assert len(cluster) == len(reference) == TRIALS  # nothing lost, nothing twice
    assert sorted(map(comparable, cluster), key=key) == sorted(map(comparable, reference), key=key)
    assert (out / "table2.csv").read_text() == (serial / "table2.csv").read_text()
