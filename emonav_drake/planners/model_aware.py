"""Step-response models by name: what a planner predicts a robot's walking steps with.

A step-response model (`robot.step_response`, fitted on traced Digit episodes by `emonav
calibrate fit`) predicts each walking step's displacement, turn and speed from the
commands; `DwaPlanner(config, response=model)` rolls its candidates out with it, the MPC
and the LGM shield plan with it. A spec's `response` field (`planners/specs.py`) names
one: "" = the paper's LIP, "digit" = the shipped model of the full-order Digit
(`emonav_drake/data/digit_response.json`), or the path of a fitted model JSON.
"""

from __future__ import annotations

from pathlib import Path

from emonav_drake.json_input import JsonInputError, read_json
from emonav_drake.params import ConfigError
from emonav_drake.robot.step_response import StepResponseModel

DIGIT_RESPONSE = Path(__file__).resolve().parent.parent / "data" / "digit_response.json"


def read_response(path: str | Path) -> StepResponseModel:
    """A step-response model JSON (`ConfigError` naming the file and what is wrong)."""
    path = Path(path)
    if not path.is_file():
        raise ConfigError(f"step-response model {path}: no such file")
    try:
        data = read_json(path)
    except JsonInputError as e:
        raise ConfigError(f"step-response model {e}") from None
    try:
        return StepResponseModel.from_plain(data.get("model", data))
    except (ValueError, KeyError, TypeError, AttributeError) as e:
        raise ConfigError(f"step-response model {path}: {e}") from None


def load_response(spec: str) -> StepResponseModel | None:
    """ "" → None (the LIP); "digit" → the shipped Digit model; else a model file."""
    if not spec:
        return None
    return read_response(DIGIT_RESPONSE if spec == "digit" else spec)
