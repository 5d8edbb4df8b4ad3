"""Progress bars: one place decides whether they are drawn, and the simulated-time bar.

A library call draws a bar when asked to (`progress=True`, or a bar made with
`progress_bar`); the command line narrows that: `emonav` draws bars only when stderr is a
terminal and `--quiet` is not given (`allowed_while` around each command), so a log file
or a pipe never receives carriage-return bars. A bar only reads what it is given: it can
never change a result.
"""

from __future__ import annotations

import contextlib
import os
import sys
import time
from collections.abc import Iterable, Iterator
from typing import Any

from tqdm import tqdm

_allowed = True  # False inside `allowed_while(False)`: no bar anywhere


@contextlib.contextmanager
def allowed_while(allowed: bool) -> Iterator[None]:
    """Within the block, bars are drawn only if `allowed` (restored after it)."""
    global _allowed
    previous, _allowed = _allowed, bool(allowed)
    try:
        yield
    finally:
        _allowed = previous


def shown(requested: bool = True) -> bool:
    """Whether a bar that is `requested` is drawn now."""
    return bool(requested) and _allowed


def progress_bar(iterable: Iterable | None = None, *, enabled: bool = True, **kwargs: Any) -> tqdm:
    """A tqdm bar on stderr, drawn only if `shown(enabled)` (else silent and free)."""
    return tqdm(iterable, disable=not shown(enabled), **kwargs)


# what the progress bar shows: simulated seconds of the expected total, the real-time factor
_BAR_FORMAT = (
    "{desc}: {percentage:3.0f}%|{bar}| {n:.1f}/{total:.1f} s simulated "
    "[{elapsed}<{remaining}{postfix}]"
)


class SimulationProgress:
    """A tqdm progress bar over simulated time, on stderr: simulated seconds of `total`
    [s] and the real-time factor (simulated over wall seconds since the bar was made).

    The runners call `update(t)` after each `Simulator.AdvanceTo` and `close(t, note)`
    when the simulation ends; an episode that ends before `total` (goal, collision, fall)
    completes the bar at the time it reached, with `note` (e.g. the outcome) after it.
    Disabled (`enabled=False`) it writes nothing and costs nothing. It only reads the
    simulated time it is given, so it cannot change a simulation."""

    def __init__(self, total: float, desc: str, enabled: bool = True) -> None:
        self._bar = None
        self._t0 = time.perf_counter()
        if shown(enabled):
            try:  # a terminal that reports no size (0 × 0) would get an empty bar
                size = os.get_terminal_size(sys.stderr.fileno())
                sized = size.columns > 0 and size.lines > 0
            except (OSError, ValueError):
                sized = False
            self._bar = tqdm(
                total=float(total),
                desc=desc,
                file=sys.stderr,
                bar_format=_BAR_FORMAT,
                dynamic_ncols=sized,
                ncols=None if sized else 100,
                nrows=None if sized else 24,
            )

    @property
    def enabled(self) -> bool:
        """Whether a bar is shown (False after `close`)."""
        return self._bar is not None

    def _postfix(self, t: float, note: str) -> str:
        wall = time.perf_counter() - self._t0
        rtf = f"{t / wall:.2f}x real time" if wall > 0 else ""
        return ", ".join(x for x in (rtf, note) if x)

    def update(self, t: float) -> None:
        """The simulation has reached time `t` [s]."""
        if self._bar is None:
            return
        self._bar.set_postfix_str(self._postfix(t, ""), refresh=False)
        self._bar.update(min(t, self._bar.total) - self._bar.n)  # redrawn at tqdm's pace

    def close(self, t: float, note: str = "") -> None:
        """End the bar at time `t` [s] (the whole bar if the simulation ended early)."""
        if self._bar is None:
            return
        bar, self._bar = self._bar, None
        if t < bar.total:
            bar.total = t
        bar.n = min(t, bar.total)
        bar.set_postfix_str(self._postfix(t, note), refresh=False)
        bar.close()  # draws the final state and ends the line
