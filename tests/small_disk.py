"""A real full disk for the tests: a small tmpfs in a private mount namespace.

`run_on_small_disk(disk, size_kib, argv)` runs `argv` in a mount namespace of its own
(`unshare -rm`: no root needed where user namespaces are allowed) in which the folder
`disk` is a fresh tmpfs of `size_kib` KiB, so every write there meets a real ENOSPC; the
test is skipped on a machine that cannot make one. Nothing outside the namespace sees
the tmpfs, and it goes with the process.
"""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pytest


def run_on_small_disk(
    disk: Path, size_kib: int, argv: list[str], cwd: Path | None = None, timeout: float = 300
) -> subprocess.CompletedProcess:
    """`argv` run with `disk` (an existing folder) mounted as a `size_kib` KiB tmpfs."""
    if shutil.which("unshare") is None:
        pytest.skip("no unshare(1)")
    probe = subprocess.run(
        ["unshare", "-rm", "mount", "-t", "tmpfs", "-o", "size=4k", "tmpfs", str(disk)],
        capture_output=True,
    )
    if probe.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs in a user namespace: {probe.stderr.decode().strip()}")
    mount = f'mount -t tmpfs -o size={size_kib}k tmpfs "$1" && shift && exec "$@"'
    return subprocess.run(
        ["unshare", "-rm", "sh", "-c", mount, "sh", str(disk), *map(str, argv)],
        capture_output=True,
        text=True,
        timeout=timeout,
        cwd=cwd,
    )
