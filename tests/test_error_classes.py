"""Which errors are the user's (issue 46, item 3): a `UserError`, raised where an input is
checked, is exit code 2 with one line naming the culprit; a numpy `LinAlgError` or a
plain `ValueError` from deep inside a simulation is a bug — exit code 1, "internal
error … a bug", never "error" as if the user had typed something wrong (before: both were
"emonav: error: Singular matrix", exit 2, because the whole `ValueError` family counted
as the user's)."""

from __future__ import annotations

import numpy as np
import pytest

import emonav_drake.sensing.crowd_perception as crowd_perception
from emonav_drake.errors import UsageError, UserError
from emonav_drake.typed_yaml import ConfigError
from tests.cli_errors import run

SIM = ("sim", "--plant", "lip", "--planner", "dwa", "--seed", "1", "--state-source", "lidar")


@pytest.mark.parametrize(
    "error",
    [np.linalg.LinAlgError("Singular matrix"), ValueError("operands could not be broadcast")],
)
def test_an_exception_deep_inside_a_simulation_is_an_internal_error(capsys, monkeypatch, error):
    """The LiDAR detector raising inside the diagram's tracker (what a singular circle fit
    did on a wall piece; the detector runs in `sensing/crowd_perception.py`) ends `sim` with
    exit 1 and the bug message."""

    def broken(*args, **kwargs):
        raise error

    monkeypatch.setattr(crowd_perception, "detect_scan", broken)
    code, err = run(capsys, *SIM)
    assert code == 1, err
    assert err.startswith(f"emonav: internal error: {type(error).__name__}: ")
    assert "a bug: rerun with --debug" in err
    assert "emonav: error:" not in err


def test_user_errors_derive_from_user_error_and_value_error():
    """Every error the package raises for a bad input is a `UserError` (the CLI's exit 2)
    and still a `ValueError` for library users who catch that."""
    from emonav_drake.atomic_io import OutputPathError
    from emonav_drake.learning.run_state import RunStateError
    from emonav_drake.perception.image_io import ImageReadError
    from emonav_drake.planners.policy import PolicyError
    from emonav_drake.torch_device import DeviceError
    from emonav_drake.torch_load import CheckpointReadError

    for cls in (ConfigError, UsageError, OutputPathError, RunStateError, ImageReadError):
        assert issubclass(cls, UserError) and issubclass(cls, ValueError), cls
    for cls in (PolicyError, DeviceError, CheckpointReadError):
        assert issubclass(cls, UserError) and issubclass(cls, ValueError), cls


def test_a_refused_flag_is_still_a_user_error(capsys):
    code, err = run(capsys, "emotion", "missing.png", "--every", "0")
    assert code == 2
    assert err.startswith("emonav: error: ")
