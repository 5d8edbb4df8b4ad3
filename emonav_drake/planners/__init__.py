"""Planners: one name → one planner object (`planners.protocol.Planner`).

The same objects drive the Drake diagram (`systems.NavigationPlanner`, through the pure
`plan_with_memory(obs, memory)`, the memory living in the Context) and act as policies on
the Gymnasium environment (`planner.plan(env.unwrapped.planner_input())`, the memory kept
on the object, `reset()` between episodes).

The registry (`planners/registry.py`) holds every planner the command line and the trial
workers can build by name, each as a typed spec (`planners/specs.py`): `make_planner(name)`
is that spec's `build(config, device)`. The built-in ones are registered below, one line
each:

* model planners (no checkpoint): `dwa` and `mpc` (`planners/dwa.py`, `planners/mpc.py`;
  their math in `planning/dwa.py` and `planning/mpc_*.py`), `dwa_digit` (DWA planning with
  Digit's step-response model, the Digit/Digit route's expert), `mpc_digit` (the MPC
  planning with that model, `planning/mpc_response.py`);
* learned planners (a policy checkpoint, `planners/policy.py`): `policy` (any trained
  checkpoint, by default the shipped policy), `sac` (a SAC-trained actor, checkpoint
  required), the LGM-shielded and MPC-steered policies, SARL and RGL (value networks),
  and every variant of `planners/variants.py` (its shipped policy by default).

Planners from outside the package register themselves the same way, from an installed
plug-in or a module named with `--planner-module` (`planners/plugins.py`).
"""

from __future__ import annotations

import copy
from pathlib import Path

from emonav_drake.navigation.observations import observation_kind
from emonav_drake.params import ConfigError, EmoNavConfig
from emonav_drake.planners.registry import (
    PlannerKind,
    is_registered,
    make_planner,
    model_planner_names,
    planner_kind,
    planner_names,
    register,
    unregister,
)
from emonav_drake.planners.specs import (
    VALUE_CHECKPOINTS,
    DwaSpec,
    MpcNearbySpec,
    MpcSpec,
    PolicySpec,
    SacSpec,
    SarlSpec,
    ShieldSpec,
)
from emonav_drake.planners.variants import VARIANTS

__all__ = [
    "VALUE_CHECKPOINTS",
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


# The learned baselines the paper compares with (Table II), as `emonav planners` groups them.
PAPER_BASELINES = frozenset(
    {"sarl", "rgl", "drlvo", "lndnl", "single_lgm", "ogm", "lidar_sac", "sac"}
)

# A policy steered by the MPC (`planners/mpc_nearby.py`, the `MpcNearbySpec` DAgger expert):
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

# The Digit/Digit route's expert (`configs/variants/emobipednav_digit.yaml`, its `expert`;
# a test keeps the two equal).
DWA_DIGIT = DwaSpec(margin=0.1, response="digit")

register(PlannerKind("dwa", DwaSpec(), "dynamic window approach (paper's baseline)"))
register(PlannerKind("mpc", MpcSpec(), "OSQP social MPC"))
register(PlannerKind("mpc_digit", MpcSpec(response="digit"), "OSQP MPC with Digit's step response"))
register(PlannerKind("dwa_digit", DWA_DIGIT, "DWA with Digit's step response"))
register(PlannerKind("policy", PolicySpec(), "a policy checkpoint (default: shipped)"))
for _name, (_default, _what) in SHIELDED.items():
    for _suffix, _response, _model in (("", "", "LIP"), ("_digit", "digit", "Digit's response")):
        register(
            PlannerKind(
                _name + _suffix,
                ShieldSpec(variant=_default, response=_response),
                f"{_what} behind the LGM shield ({_model} prediction)",
                runs_as=_name + _suffix,
            )
        )
for _name, (_shielded, _what) in MPC_STEERED.items():
    register(
        PlannerKind(
            _name,
            MpcNearbySpec(shielded=_shielded),
            f"a categorical policy (default: shipped) choosing {_what} (privileged teacher)",
            runs_as=_name,
        )
    )
register(PlannerKind("sac", SacSpec(), "a SAC-trained actor"))
register(
    PlannerKind(
        "sarl",
        SarlSpec(network="sarl"),
        "SARL (CrowdNav): value network on the crowd state, one-step look-ahead",
        runs_as="sarl",
    )
)
register(
    PlannerKind(
        "rgl",
        SarlSpec(network="rgl"),
        "RGL (relational graph value network) on the crowd state, one-step look-ahead",
        runs_as="sarl",
    )
)
for _name, _variant in VARIANTS.items():
    register(
        PlannerKind(_name, PolicySpec(variant=_name), f"{_variant.paper}: {_variant.observation}")
    )


def is_learned(name: str) -> bool:
    """True for the registered planners that run a policy checkpoint."""
    return is_registered(name) and planner_kind(name).learned


def reads_crowd_state(name: str) -> bool:
    """Whether planner `name` reads the crowd state (`PlannerInput.crowd`: the simulator's,
    or the LiDAR tracks with `perception.state_source` "lidar"): the model-based planners,
    a user's planners, SARL/RGL and the MPC-steered policies. A policy that reads only its
    map observation does not, so the state source changes nothing for it (DRL-VO*'s
    velocity image is drawn from the simulator's crowd either way)."""
    return not is_registered(name) or planner_kind(name).reads_crowd_state


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
