"""A wall-clock watchdog for one call that might never return (a planner's decision).

`wall_clock_limit(seconds, error)` runs its body; if the body is still running after
`seconds` of wall time, `error()` is raised in it — and raised again every second after
that, should the body catch it and go on. It only ever turns a hang into an error: a body
that returns in time is untouched, so no result depends on the wall clock.

How: a POSIX interval timer (`signal.setitimer(ITIMER_REAL)`) whose SIGALRM handler raises.
Python runs signal handlers in the main thread, between bytecodes (a blocking call such as
`time.sleep` is interrupted), so the watchdog works in the main thread of a process — the
`emonav` command, and a Ray worker, which runs its actor's tasks in its main thread. It
cannot interrupt native code that never returns to the interpreter (a C extension's loop);
the error is raised when it does. Where it cannot be installed it does nothing (the body
runs without a limit): off the main thread, on a platform without `setitimer` (Windows),
or when SIGALRM already belongs to someone else (a handler other than the default, or a
timer running) — it never takes over another's alarm.
"""

from __future__ import annotations

import contextlib
import signal
import threading
from collections.abc import Callable, Iterator
from types import FrameType

REPEAT = 1.0  # [s] after the first expiry, the error is raised again this often


def available() -> bool:
    """Whether `wall_clock_limit` can watch a call made here and now (see the module)."""
    if not hasattr(signal, "setitimer") or not hasattr(signal, "SIGALRM"):
        return False
    if threading.current_thread() is not threading.main_thread():
        return False
    if signal.getsignal(signal.SIGALRM) not in (signal.SIG_DFL, signal.SIG_IGN):
        return False  # someone else's handler (or an enclosing watchdog)
    return signal.getitimer(signal.ITIMER_REAL)[0] == 0.0  # no timer running


@contextlib.contextmanager
def wall_clock_limit(seconds: float, error: Callable[[], BaseException]) -> Iterator[bool]:
    """Raise `error()` in the body if it runs longer than `seconds` of wall time.

    Args:
        seconds: the limit [s]; <= 0 (or not finite): no limit.
        error: makes the exception to raise (called at the expiry).
    Yields:
        Whether the watchdog is on (False: no limit, or not `available()`).
    """
    if not (0.0 < seconds < float("inf")) or not available():
        yield False
        return
    armed = [True]

    def expired(signum: int, frame: FrameType | None) -> None:
        if armed[0]:
            raise error()

    previous = signal.signal(signal.SIGALRM, expired)
    try:
        signal.setitimer(signal.ITIMER_REAL, seconds, REPEAT)
        yield True
    finally:
        try:
            armed[0] = False  # from here on an alarm raises nothing
        finally:
            signal.setitimer(signal.ITIMER_REAL, 0.0)
            signal.signal(signal.SIGALRM, previous)
