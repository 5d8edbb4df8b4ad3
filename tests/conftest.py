"""Shared fixtures of the test suite."""

import json
import signal

import pytest

from emonav_drake.cli import main

# The tests that press Ctrl-C (a real SIGINT, `signal.raise_signal`) need Python's own
# SIGINT handler, as a user's foreground run has it. A suite started as a background job
# of a script (`make test &`) inherits SIGINT ignored, and Python then installs no
# handler: those tests would wait for whole trainings to finish. Restore it.
signal.signal(signal.SIGINT, signal.default_int_handler)


@pytest.fixture(autouse=True)
def _python_sigint_handler():
    """Every test starts with Python's SIGINT handler; a test that leaves another one
    behind (ignored, or a handler of its own) is named in a warning, and the handler is
    put back so the next test's Ctrl-C still stops it."""
    signal.signal(signal.SIGINT, signal.default_int_handler)
    yield
    left = signal.getsignal(signal.SIGINT)
    if left is not signal.default_int_handler:
        import warnings

        warnings.warn(f"this test left the SIGINT handler {left!r}", stacklevel=1)
        signal.signal(signal.SIGINT, signal.default_int_handler)


@pytest.fixture
def sim_on_both_plants(tmp_path):
    """`run(planner_args, seed)` → {plant: record}: `emonav sim PLANNER_ARGS --seed SEED`
    on the LIP plant (a whole episode) and on Digit (its first 6 steps), each run twice
    and asserted to give the same record (trajectory included)."""
    short = tmp_path / "short6.yaml"
    short.write_text("episode: {max_steps: 6}\n")

    def run(planner_args: list[str], seed: int) -> dict[str, dict]:
        out = {}
        for plant, extra in (("lip", []), ("digit", ["--config", str(short)])):
            records = []
            for i in range(2):
                rec = tmp_path / f"sim_{plant}{i}.json"
                argv = ["sim", *planner_args, "--plant", plant, "--seed", str(seed)]
                assert main(argv + ["--json", str(rec)] + extra) == 0
                records.append(json.loads(rec.read_text()))
            assert records[0] == records[1], plant
            out[plant] = records[0]
        return out

    return run
