"""A loaded machine on demand, for tests that a result does not depend on wall-clock time.

* `cpu_hogs(n)`: n processes that spin on the CPU (bounded to `max_seconds`).
* `stalls(pid)`: the process `pid` is stopped (SIGSTOP) for `stop` seconds, let run for
  `run` seconds, again and again — what a process sees on a badly overloaded machine,
  made sharp: any computation that spans a stop takes longer than `stop` of wall time.

Both stop what they started when the `with` block ends, whatever happens in it.
"""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import sys
import threading
from collections.abc import Iterator

_SPIN = "import time\nend = time.monotonic() + {s}\nwhile time.monotonic() < end:\n    pass\n"


@contextlib.contextmanager
def cpu_hogs(n: int = 2, max_seconds: float = 600.0) -> Iterator[list[subprocess.Popen]]:
    """`n` busy-looping processes (each ends by itself after `max_seconds`)."""
    procs = [
        subprocess.Popen([sys.executable, "-c", _SPIN.format(s=max_seconds)]) for _ in range(n)
    ]
    try:
        yield procs
    finally:
        for p in procs:
            p.kill()
            p.wait()


@contextlib.contextmanager
def stalls(pid: int, stop: float = 0.12, run: float = 0.02) -> Iterator[threading.Event]:
    """Stop `pid` for `stop` s every `stop + run` s until the block ends or `pid` exits.

    Yields an event that is set once the first stop has happened."""
    done = threading.Event()
    first = threading.Event()

    def loop() -> None:
        try:
            while not done.is_set():
                os.kill(pid, signal.SIGSTOP)
                first.set()
                done.wait(stop)
                os.kill(pid, signal.SIGCONT)
                done.wait(run)
        except ProcessLookupError:
            pass  # the process ended

    thread = threading.Thread(target=loop, daemon=True)
    thread.start()
    try:
        yield first
    finally:
        done.set()
        thread.join()
        with contextlib.suppress(ProcessLookupError):
            os.kill(pid, signal.SIGCONT)
