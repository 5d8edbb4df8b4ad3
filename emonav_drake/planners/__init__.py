"""Planner registry: one name → one planner object (`systems.navigation_planner.Planner`).

The same objects drive the Drake diagram (`systems.NavigationPlanner`, through the pure
`plan_with_memory(obs, memory)`, the memory living in the Context) and act as policies on
the Gymnasium environment (`planner.plan(env.unwrapped.planner_input())`, the memory kept
on the object, `reset()` between episodes).
"""

from __future__ import annotations

from emonav_drake.params import ConfigError, EmoNavConfig
from emonav_drake.planners.variants import VARIANTS, is_learned, shipped_checkpoint

# "policy" runs any trained checkpoint, by default the shipped policy (the EmoBipedNav
# variant, a DAgger student); "sac" a SAC-trained checkpoint (`emonav train --algo sac`);
# the other learned methods of the paper by their variant name (`planners/variants.py`).
# Model-based planners (no checkpoint). "dwa_digit" is the Digit/Digit route's expert: DWA
# planning with Digit's step-response model and the route's collision margin.
MODEL_PLANNERS = ("dwa", "mpc", "dwa_digit")
PLANNERS = (*MODEL_PLANNERS, "policy", "sac", *VARIANTS)


def make_planner(name: str, config: EmoNavConfig, checkpoint=None, device: str = "cpu"):
    """Create the planner called `name`: "dwa", "mpc", "dwa_digit", "policy", "sac" or a
    variant name.

    "policy" loads `checkpoint` (default: the shipped policy); "sac" needs the checkpoint
    of a SAC actor (a `ConfigError` names `--planner policy` for a DAgger student or a
    missing checkpoint); a variant defaults to the policy shipped under its name."""
    if name == "dwa":
        from emonav_drake.core.dwa import DwaPlanner

        return DwaPlanner(config)
    if name == "mpc":
        from emonav_drake.core.mpc import MpcPlanner

        return MpcPlanner(config)
    if name == "dwa_digit":
        from emonav_drake.planners.model_aware import dwa_digit

        return dwa_digit(config)
    if is_learned(name):
        from emonav_drake.planners.policy import PolicyPlanner, describe_policy, policy_kind

        if name == "sac" and checkpoint is None:
            raise ConfigError(
                "--planner sac runs a SAC-trained checkpoint (`emonav train --algo sac`): "
                "give --checkpoint PATH; the shipped policy is a DAgger student, run it "
                "with --planner policy"
            )
        if checkpoint is None and name != "policy":
            checkpoint = shipped_checkpoint(name)
        planner = PolicyPlanner(checkpoint, device=device)
        if name == "sac" and policy_kind(planner.meta) != "sac":
            raise ConfigError(
                f"--planner sac: {planner.path} is not a SAC actor but a "
                f"{describe_policy(planner.meta)}; run it with --planner policy"
            )
        return planner
    raise ValueError(f"unknown planner {name!r}: choose one of {list(PLANNERS)}")


def configure_for(planner, config: EmoNavConfig) -> str:
    """Adapt the diagram's observation settings to a learned policy; return the grid kind.

    A policy checkpoint records the observation it was trained on (grid kind, frames,
    grid size; for scans the beams of its encoder); the diagram's `LidarGridMapBuilder`
    must produce exactly that: `config.lidar.num_frames` and `grid_size` are set from
    the checkpoint. Planners without an observation (DWA, MPC) get "lgm" (they ignore it).
    Raises `ValueError` for an observation the env cannot give either: a scan policy for
    another number of beams than `lidar.num_beams`, or a DRL-VO* policy of more than one
    frame (its image has no frame stack).
    """
    kind = getattr(planner, "grid_kind", None)
    expected = getattr(planner, "expected_shape", None)
    if kind is None or expected is None:
        return "lgm"
    li = config.lidar
    if kind == "scan":
        num_frames, beams = expected
        if beams != li.num_beams:
            raise ValueError(
                f"the policy reads {beams}-beam scans, but lidar.num_beams = {li.num_beams}"
            )
        li.num_frames = num_frames
    elif kind == "drlvo":
        num_frames, _, size, _ = expected
        if num_frames != 1:
            raise ValueError(
                f"the DRL-VO* policy declares num_frames = {num_frames}: its observation is "
                "one (3, M, M) image (num_frames 1), as the environment gives it"
            )
        li.num_frames, li.grid_size = 1, size
    elif kind in ("lgm", "ogm"):
        li.num_frames, li.grid_size = expected[0], expected[1]
    else:
        raise ValueError(f"policy observation {kind!r} is unknown")
    return kind
