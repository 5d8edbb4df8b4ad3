"""Planners: one name → one planner object (`planners.protocol.Planner`).

The same objects drive the Drake diagram (`systems.NavigationPlanner`, through the pure
`plan_with_memory(obs, memory)`, the memory living in the Context) and act as policies on
the Gymnasium environment (`planner.plan(env.unwrapped.planner_input())`, the memory kept
on the object, `reset()` between episodes).

The registry (`planners/registry.py`) holds every planner the command line and the trial
workers can build by name; the built-in ones are registered below, one line each:

* model planners (no checkpoint): `dwa` and `mpc` (the math in `core/dwa.py`,
  `core/mpc.py`), `dwa_digit` (DWA planning with Digit's step-response model, the
  Digit/Digit route's expert, `planners/model_aware.py`), `mpc_digit` (the MPC planning
  with that model, `core/mpc_response.py`);
* learned planners (a policy checkpoint, `planners/policy.py`): `policy` (any trained
  checkpoint, by default the shipped policy), `sac` (a SAC-trained actor, checkpoint
  required), and every variant of `planners/variants.py` (its shipped policy by default).

Planners from outside the package register themselves the same way, from an installed
plug-in or a module named with `--planner-module` (`planners/plugins.py`).
"""

from __future__ import annotations

import copy
import functools
from pathlib import Path

from emonav_drake.core.observations import observation_kind
from emonav_drake.params import ConfigError, EmoNavConfig
from emonav_drake.planners.registry import (
    PlannerKind,
    is_registered,
    model_planner_names,
    planner_kind,
    planner_names,
    register,
    unregister,
)
from emonav_drake.planners.variants import VARIANTS, shipped_checkpoint

__all__ = [
    "PlannerKind",
    "configure_for",
    "is_default_checkpoint",
    "is_learned",
    "is_registered",
    "make_planner",
    "model_planner_names",
    "planner_kind",
    "planner_names",
    "register",
    "unregister",
]


def _dwa(config: EmoNavConfig, checkpoint: str | Path | None, device: str):
    from emonav_drake.core.dwa import DwaPlanner

    return DwaPlanner(config)


def _mpc(config: EmoNavConfig, checkpoint: str | Path | None, device: str):
    from emonav_drake.core.mpc import MpcPlanner

    return MpcPlanner(config)


def _mpc_digit(config: EmoNavConfig, checkpoint: str | Path | None, device: str):
    from emonav_drake.core.mpc import MpcPlanner
    from emonav_drake.planners.model_aware import load_response

    return MpcPlanner(config, response=load_response("digit"))


def _dwa_digit(config: EmoNavConfig, checkpoint: str | Path | None, device: str):
    from emonav_drake.planners.model_aware import dwa_digit

    return dwa_digit(config)


def _policy(config: EmoNavConfig, checkpoint: str | Path | None, device: str):
    from emonav_drake.planners.policy import PolicyPlanner

    return PolicyPlanner(checkpoint, device=device, robot_radius=config.robot.radius)


def _sac(config: EmoNavConfig, checkpoint: str | Path | None, device: str):
    from emonav_drake.planners.policy import PolicyPlanner, describe_policy, policy_kind

    planner = PolicyPlanner(checkpoint, device=device, robot_radius=config.robot.radius)
    if policy_kind(planner.meta) != "sac":
        raise ConfigError(
            f"--planner sac: {planner.path} is not a SAC actor but a "
            f"{describe_policy(planner.meta)}; run it with --planner policy"
        )
    return planner


def _shielded(response: str, config: EmoNavConfig, checkpoint, device: str):
    from emonav_drake.planners.model_aware import load_response
    from emonav_drake.planners.policy import PolicyPlanner
    from emonav_drake.planners.shield import ShieldedPolicy

    policy = PolicyPlanner(checkpoint, device=device, robot_radius=config.robot.radius)
    return ShieldedPolicy.registered(policy, config, load_response(response))


def _mpc_nearby(shielded: bool, config: EmoNavConfig, checkpoint, device: str):
    from emonav_drake.planners.model_aware import mpc_nearby_expert
    from emonav_drake.planners.policy import PolicyPlanner

    policy = PolicyPlanner(checkpoint, device=device, robot_radius=config.robot.radius)
    return mpc_nearby_expert(config, policy, "digit", shielded=shielded)


# A policy steered by the MPC (`planners/mpc_nearby.py`, the "mpc_nearby" DAgger expert):
# NAME: (behind its LGM shield too, what it says).
MPC_STEERED = {
    "policy_mpc_digit": (False, "within one grid step of the Digit MPC's command"),
    "policy_mpc_shield_digit": (
        True,
        "within one grid step of the Digit MPC's command, among its shield's admissible ones",
    ),
}

# The LGM shield (`planners/shield.py`) in front of a policy: NAME predicts with the LIP,
# NAME_digit with Digit's fitted step response (as dwa / dwa_digit).
SHIELDED = {
    # measured and tuned on the MPC route's student (the default policy then)
    "policy_shield": ("emobipednav_digit_mpc", "a categorical policy (default: the MPC route's)"),
    "guide_shield": ("emobipednav_guide", "the guide-sub-goal policy"),
    "emobipednav_shield": ("emobipednav", "the LIP-trained policy"),
}


def _default_policy() -> Path:
    from emonav_drake.planners.policy import DEFAULT_POLICY

    return DEFAULT_POLICY


def _sarl(config: EmoNavConfig, checkpoint: str | Path | None, device: str):
    from emonav_drake.planners.sarl import SarlPlanner

    return SarlPlanner(checkpoint, config, device=device)


# The shipped value networks of the crowd-state planners, by planner name.
VALUE_CHECKPOINTS = {
    name: Path(__file__).resolve().parent.parent / "data" / "policies" / f"{name}.pt"
    for name in ("sarl", "rgl")
}


def _value_checkpoint(name: str, train_flags: str) -> Path:
    """The shipped checkpoint of value-network planner `name` (`VALUE_CHECKPOINTS`), or a
    `ConfigError` with the command that trains it."""
    path = VALUE_CHECKPOINTS[name]
    if not path.is_file():
        raise ConfigError(
            f"{name} has no shipped checkpoint in this version: train it with `emonav train "
            f"--algo sarl {train_flags}--out runs/{name}` and pass --checkpoint "
            f"runs/{name}/policy.pt"
        )
    return path


def _no_sac_checkpoint() -> Path:
    raise ConfigError(
        "--planner sac runs a SAC-trained checkpoint (`emonav train --algo sac`): "
        "give --checkpoint PATH; the shipped policy is a DAgger student, run it "
        "with --planner policy"
    )


register(PlannerKind("dwa", _dwa, summary="dynamic window approach (paper's baseline)"))
register(PlannerKind("mpc", _mpc, summary="OSQP social MPC"))
register(PlannerKind("mpc_digit", _mpc_digit, summary="OSQP MPC with Digit's step response"))
register(PlannerKind("dwa_digit", _dwa_digit, summary="DWA with Digit's step response"))
register(
    PlannerKind("policy", _policy, True, _default_policy, "a policy checkpoint (default: shipped)")
)
for _name, (_default, _what) in SHIELDED.items():
    for _suffix, _response, _model in (("", "", "LIP"), ("_digit", "digit", "Digit's response")):
        register(
            PlannerKind(
                _name + _suffix,
                functools.partial(_shielded, _response),
                True,
                _default_policy
                if _default == "policy"
                else functools.partial(shipped_checkpoint, _default),
                f"{_what} behind the LGM shield ({_model} prediction)",
                runs_as=_name + _suffix,
            )
        )
for _name, (_shielded_too, _what) in MPC_STEERED.items():
    register(
        PlannerKind(
            _name,
            functools.partial(_mpc_nearby, _shielded_too),
            True,
            _default_policy,
            f"a categorical policy (default: shipped) choosing {_what} (privileged teacher)",
            runs_as=_name,
        )
    )
register(PlannerKind("sac", _sac, True, _no_sac_checkpoint, "a SAC-trained actor"))
register(
    PlannerKind(
        "sarl",
        _sarl,
        True,
        functools.partial(_value_checkpoint, "sarl", ""),
        "SARL (CrowdNav): value network on the crowd state, one-step look-ahead",
        runs_as="sarl",
    )
)
register(
    PlannerKind(
        "rgl",
        _sarl,
        True,
        functools.partial(_value_checkpoint, "rgl", "--config emonav_drake/configs/rgl.yaml "),
        "RGL (relational graph value network) on the crowd state, one-step look-ahead",
        runs_as="sarl",
    )
)
for _name, _variant in VARIANTS.items():
    register(
        PlannerKind(
            _name,
            _policy,
            True,
            functools.partial(shipped_checkpoint, _name),
            f"{_variant.paper}: {_variant.observation}",
        )
    )


def is_learned(name: str) -> bool:
    """True for the registered planners that run a policy checkpoint."""
    return is_registered(name) and planner_kind(name).learned


def make_planner(
    name: str, config: EmoNavConfig, checkpoint: str | Path | None = None, device: str = "cpu"
):
    """Create the planner called `name` (any registered name).

    A learned planner loads `checkpoint`, by default its kind's default checkpoint ("policy":
    the shipped policy; a variant: the policy shipped under its name; "sac": none — a
    `ConfigError` says how to get one); a model planner takes no checkpoint."""
    kind = planner_kind(name)
    if kind.learned and checkpoint is None:
        checkpoint = kind.default_checkpoint() if kind.default_checkpoint else None
    planner = kind.build(config, checkpoint, device)
    planner.name = name  # what captions and logs call it: the name it was asked for
    return planner


def is_default_checkpoint(name: str, path: str | Path) -> bool:
    """Whether `path` is the checkpoint planner `name` runs without `--checkpoint`."""
    if not is_registered(name):
        return False
    kind = planner_kind(name)
    if not kind.learned or kind.default_checkpoint is None:
        return False
    try:
        return Path(kind.default_checkpoint()).resolve() == Path(path).resolve()
    except ConfigError:  # no shipped checkpoint: any file is one the user chose
        return False


def configure_for(planner, config: EmoNavConfig) -> tuple[EmoNavConfig, str]:
    """The configuration whose observation a planner reads, and its grid kind.

    A policy checkpoint records the observation it was trained on (grid kind, frames,
    grid size; for scans the beams of its encoder); the diagram's `LidarGridMapBuilder`
    must produce exactly that: the returned configuration is a copy of `config` with
    `lidar.num_frames` and `grid_size` set from the checkpoint (`config` is not
    modified). Planners without an observation (DWA, MPC) get `config` itself and "lgm"
    (they ignore it). Raises `ValueError` for an observation the env cannot give either:
    a scan policy for another number of beams than `lidar.num_beams`, or a DRL-VO*
    policy of more than one frame (its image has no frame stack).
    """
    kind = getattr(planner, "grid_kind", None)
    expected = getattr(planner, "expected_shape", None)
    if kind is None or expected is None:
        return config, "lgm"
    try:
        spec = observation_kind(kind)
    except ValueError:
        raise ValueError(f"policy observation {kind!r} is unknown") from None
    lidar = spec.lidar_for(tuple(expected), config.lidar)
    out = copy.deepcopy(config)
    for field, value in lidar.items():
        setattr(out.lidar, field, value)
    return out, kind


# Last: the installed plug-ins' planners (`planners/plugins.py`), after every built-in one
# (a plug-in cannot take a built-in planner's name: `register` refuses it).
from emonav_drake.planners.plugins import load_entry_points  # noqa: E402

load_entry_points()
