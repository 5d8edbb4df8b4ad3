"""Run inside `unshare -rnpf --mount-proc` by tests/test_ray_cluster.py: raise the
namespace's loopback interface, start a Ray head (127.0.0.1) and a second node (127.0.0.2)
with `ray start`, run `emonav benchmark --ray-address` on them, SIGKILL the second node's
processes once a quarter of the trials are written, and print one `RESULT {json}` line.

argv: OUT TOKEN_FILE TEMP_DIR TRIALS FIRST_SEED PLANNERS KILL_AFTER
"""

import fcntl
import json
import os
import signal
import socket
import struct
import subprocess
import sys
import time
from pathlib import Path

out, token, temp, trials, first_seed, planners, kill_after = sys.argv[1:8]
kill_after = int(kill_after)
bin_dir = Path(sys.executable).parent
ray, emonav = str(bin_dir / "ray"), str(bin_dir / "emonav")

# the namespace's loopback interface is down until someone raises it (SIOCSIFFLAGS)
s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
flags = struct.unpack("16sH", fcntl.ioctl(s, 0x8913, struct.pack("16sH", b"lo", 0))[:18])[1]
fcntl.ioctl(s, 0x8914, struct.pack("16sH", b"lo", flags | 1))

env = dict(
    os.environ, RAY_AUTH_MODE="token", RAY_AUTH_TOKEN_PATH=token, RAY_USAGE_STATS_ENABLED="0"
)
env.pop("RAY_ADDRESS", None)


def raylets():
    pids = set()
    for p in Path("/proc").iterdir():
        if p.name.isdigit():
            try:
                cmd = (p / "cmdline").read_bytes().split(b"\0")[0]
            except OSError:
                continue
            if cmd.endswith(b"/raylet"):
                pids.add(int(p.name))
    return pids


def tree(pids):
    # `pids` and every process below them
    parent = {}
    for p in Path("/proc").iterdir():
        if p.name.isdigit():
            try:
                parent[int(p.name)] = int((p / "stat").read_text().rsplit(")", 1)[1].split()[1])
            except (OSError, IndexError, ValueError):
                continue
    found, grew = set(pids), True
    while grew:
        more = {c for c, pp in parent.items() if pp in found} - found
        found |= more
        grew = bool(more)
    return found


def lines():
    path = Path(out) / "trials.jsonl"
    return path.read_bytes().count(b"\n") if path.exists() else 0


def start(*args):
    p = subprocess.run(
        [ray, "start", *args, "--num-cpus", "1", "--disable-usage-stats", "--temp-dir", temp],
        env=env,
        capture_output=True,
        text=True,
    )
    if p.returncode != 0:
        print(MARK + json.dumps({"error": p.stderr[-3000:]}))
        sys.exit(0)


MARK = "RESULT "
t0 = time.monotonic()
start("--head", "--node-ip-address", "127.0.0.1", "--port", "6391", "--include-dashboard", "false")
head = raylets()
# a second machine: a node of its own address (the driver attaches to the head's node)
start("--address", "127.0.0.1:6391", "--node-ip-address", "127.0.0.2")
second = raylets() - head
# this namespace's network interfaces (/proc/net is per network namespace)
interfaces = sorted(line.split(":")[0].strip() for line in open("/proc/net/dev").readlines()[2:])
started = time.monotonic() - t0
bench = subprocess.Popen(
    [
        emonav,
        "benchmark",
        "--planners",
        planners,
        "--trials",
        trials,
        "--first-seed",
        first_seed,
        "--ray-address",
        "127.0.0.1:6391",
        "--out",
        out,
        "--quiet",
    ],
    env=env,
    stdout=subprocess.PIPE,
    stderr=subprocess.PIPE,
    text=True,
)
t1 = time.monotonic()
while lines() < kill_after and bench.poll() is None and time.monotonic() - t1 < 600:
    time.sleep(0.05)
at_kill = lines()
victims = tree(second)  # the second machine fails: its raylet and its workers
for pid in victims:
    try:
        os.kill(pid, signal.SIGKILL)
    except ProcessLookupError:
        pass
t_kill = time.monotonic()
try:
    stdout, stderr = bench.communicate(timeout=900)
except subprocess.TimeoutExpired:
    bench.kill()
    stdout, stderr = bench.communicate()
print(
    MARK
    + json.dumps(
        {
            "rc": bench.returncode,
            "stdout": stdout[-3000:],
            "stderr": stderr[-3000:],
            "head_raylets": len(head),
            "second_raylets": len(second),
            "at_kill": at_kill,
            "killed_processes": len(victims),
            "start_seconds": started,
            "run_seconds": time.monotonic() - t1,
            "after_kill_seconds": time.monotonic() - t_kill,
            "interfaces": interfaces,
        }
    )
)
subprocess.run([ray, "stop", "--force"], env=env, capture_output=True)
