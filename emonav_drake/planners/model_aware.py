"""Planners that plan with a robot's measured step response instead of the LIP's.

A step-response model (`core.step_response`, fitted on traced Digit episodes by `emonav
calibrate fit`) predicts each walking step's displacement, turn and speed from the
commands; `DwaPlanner(config, response=model)` rolls its candidates out with it. The
shipped model of the full-order Digit is `emonav_drake/data/digit_response.json`.

`dwa_digit` is the expert of the Digit/Digit learning route (`configs/variants/
emobipednav_digit.yaml`): DWA with that route's collision margin, planning with the model
the route names. Its two settings are read from the route's file, so the planner and the
route cannot drift apart.
"""

from __future__ import annotations

import copy
from pathlib import Path

from emonav_drake.core.step_response import StepResponseModel
from emonav_drake.json_input import JsonInputError, read_json
from emonav_drake.params import ConfigError, EmoNavConfig

# The DAgger routes' experts (`DaggerConfig.expert`, `route_expert`); the last two label
# with a distribution over the student's grid (`last_distribution`: soft labels).
EXPERTS = ("dwa", "mpc", "shield", "mpc_nearby")
SOFT_EXPERTS = ("shield", "mpc_nearby")

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


def model_aware_expert(config: EmoNavConfig, margin: float, response: str = "digit"):
    """The expert of the routes that learn a robot's dynamics: DWA with collision margin
    `margin` [m] planning with the step-response model `response` (`load_response`)."""
    from emonav_drake.core.dwa import DwaPlanner

    expert_cfg = copy.deepcopy(config)
    expert_cfg.dwa.safety_margin = margin
    return DwaPlanner(expert_cfg, response=load_response(response))


def route_expert(
    config: EmoNavConfig,
    kind: str,
    margin: float,
    response: str = "",
    clearance: float = 0.0,
    policy: str = "",
    cells: int = 1,
    shielded: bool = False,
):
    """The expert of a DAgger route (`DaggerConfig.expert`): "dwa" = `model_aware_expert`
    (collision margin `margin` [m], planning with `response`); "mpc" = the OSQP MPC of
    `core.mpc` on the LIP model, its collision and discomfort margins widened by `clearance` [m]
    (`DaggerConfig.expert_clearance`; 0 = the MPC as benchmarked; `margin` and `response`
    unused); "shield" = the categorical `policy` ("shipped", a shipped variant's name or a
    path) behind the LGM shield, predicting with `response` (the registered shielded
    planners' settings, `planners.shield.default_shield_params`); "mpc_nearby" = that
    `policy` choosing within `cells` grid steps of the MPC's command (the MPC planning with
    `response`, its margins widened by `clearance`; with `shielded`, only among the
    commands the policy's LGM shield admits; `planners/mpc_nearby.py`)."""
    if kind == "mpc_nearby":
        if not policy:
            raise ConfigError("expert = 'mpc_nearby' needs the policy it steers (expert_policy)")
        wrapped = _expert_policy(policy, config)
        return mpc_nearby_expert(config, wrapped, response, clearance, cells, shielded)
    if kind == "shield":
        from emonav_drake.planners.shield import ShieldedPolicy

        if not policy:
            raise ConfigError("expert = 'shield' needs the policy it shields (expert_policy)")
        return ShieldedPolicy.registered(
            _expert_policy(policy, config), config, load_response(response)
        )
    if kind == "mpc":
        from emonav_drake.core.mpc import MpcPlanner

        return MpcPlanner(_widened(config, clearance))
    if kind != "dwa":
        raise ConfigError(f"expert = {kind!r} is invalid: must be one of {list(EXPERTS)}")
    return model_aware_expert(config, margin, response)


def mpc_nearby_expert(
    config: EmoNavConfig,
    policy,
    response: str = "digit",
    clearance: float = 0.0,
    cells: int = 1,
    shielded: bool = False,
):
    """The categorical `policy` (a `PolicyPlanner`) choosing within `cells` grid steps of the
    OSQP MPC's command, the MPC planning with `response` ("" = the LIP) and its margins
    widened by `clearance` [m]; with `shielded`, only among the commands the policy's LGM
    shield admits (the registered shields' settings for `response`). `planners/mpc_nearby.py`."""
    from emonav_drake.core.mpc import MpcPlanner
    from emonav_drake.planners.mpc_nearby import MpcNearbyPolicy
    from emonav_drake.planners.shield import ShieldedPolicy

    model = load_response(response)
    mpc = MpcPlanner(_widened(config, clearance), model)
    guard = ShieldedPolicy.registered(policy, config, model) if shielded else None
    return MpcNearbyPolicy(policy, mpc, cells, guard)


def _expert_policy(spec: str, config: EmoNavConfig):
    """The categorical policy an expert wraps: "shipped", a shipped variant's name or a path
    (`variants.resolve_policy_file`), on the configuration's robot radius."""
    from emonav_drake.planners.policy import PolicyPlanner
    from emonav_drake.planners.variants import resolve_policy_file

    return PolicyPlanner(
        resolve_policy_file(spec, "expert_policy"), robot_radius=config.robot.radius
    )


def _widened(config: EmoNavConfig, clearance: float) -> EmoNavConfig:
    """`config` with the MPC's collision and discomfort margins widened by `clearance` [m]
    (the same object when it is 0)."""
    if not clearance:
        return config
    expert_cfg = copy.deepcopy(config)
    expert_cfg.mpc.collision_margin += clearance
    expert_cfg.mpc.discomfort_margin += clearance
    return expert_cfg


def dwa_digit(config: EmoNavConfig):
    """The Digit/Digit route's expert: `model_aware_expert` with the `expert_margin` [m]
    and `response` of `configs/variants/emobipednav_digit.yaml`."""
    from pydrake.common.yaml import yaml_load_data

    from emonav_drake.planners.variants import variant

    path = variant("emobipednav_digit").config
    route = yaml_load_data(Path(path).read_text()) or {}
    missing = [k for k in ("expert_margin", "response") if k not in route]
    if missing:
        raise ConfigError(f"{path}: dwa_digit needs {' and '.join(missing)} in the route file")
    return model_aware_expert(config, float(route["expert_margin"]), str(route["response"]))
