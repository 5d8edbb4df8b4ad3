"""Typed planner specifications: a planner as data, built by `spec.build(config, device)`.

One spec class per way the package builds a planner. The registry (`planners/__init__.py`)
maps each planner name to a spec instance, so `make_planner(name)` is `registry[name]`'s
spec built on the configuration; a DAgger route, the Digit rounds and SARL's imitation
take their expert as one spec field, written in YAML with the class name as its tag
(Drake's typed loader reads a union of dataclasses by tag):

    expert: !MpcSpec {clearance: 0.1}
    expert: !ShieldSpec {checkpoint: emobipednav_digit_mpc, response: digit}
    expert: !PlannerSpec {name: cautious}      # any registered planner, a plug-in's too

A learned spec has a `checkpoint` field: "" = its default policy (`checkpoint_file`),
"shipped" (the LIP-trained LGM policy), a shipped variant's name, or a file path
(`variants.resolve_policy_file`). A `response` field names the step-response model a
planner predicts with: "" = the paper's LIP, "digit" = the shipped Digit model, or the
path of a fitted model JSON (`emonav calibrate fit`).

No `from __future__ import annotations` here: Drake's typed YAML loader needs real types.
"""

import copy
import dataclasses as dc
import typing
from pathlib import Path
from typing import ClassVar

from emonav_drake.config_fields import setting
from emonav_drake.params import ConfigError, EmoNavConfig
from emonav_drake.planners.model_aware import load_response
from emonav_drake.planners.registry import make_planner


def _widened(config: EmoNavConfig, clearance: float) -> EmoNavConfig:
    """`config` with the MPC's collision and discomfort margins widened by `clearance` [m]
    (the same object when it is 0)."""
    if not clearance:
        return config
    out = copy.deepcopy(config)
    out.mpc.collision_margin += clearance
    out.mpc.discomfort_margin += clearance
    return out


def _categorical_policy(path: Path, config: EmoNavConfig, device: str):
    from emonav_drake.planners.policy import PolicyPlanner

    return PolicyPlanner(path, device=device, robot_radius=config.robot.radius)


class _Learned:
    """What every spec with a checkpoint shares: which file it runs.

    `checkpoint` given: that file ("shipped", a variant's name or a path); otherwise the
    shipped policy of the spec's `variant` ("" = the package's default policy,
    `planners.policy.DEFAULT_POLICY`)."""

    checkpoint: str
    variant: str

    def checkpoint_file(self) -> Path:
        """The checkpoint this spec runs (`ConfigError` for a variant with none shipped)."""
        from emonav_drake.planners.variants import resolve_policy_file, shipped_checkpoint

        if self.checkpoint:
            return resolve_policy_file(self.checkpoint, "checkpoint")
        if self.variant:
            return shipped_checkpoint(self.variant)
        from emonav_drake.planners.catalog import DEFAULT_POLICY

        return DEFAULT_POLICY


@dc.dataclass
class DwaSpec:
    """The dynamic window approach (`planners/dwa.py`)."""

    margin: float | None = setting(
        None,
        "its collision margin (`dwa.safety_margin`); None = the configuration's",
        "m",
        (0.0, 2.0),
    )
    response: str = setting("", 'the step model its candidates are rolled out with ("" = the LIP)')

    def build(self, config: EmoNavConfig, device: str = "cpu"):
        from emonav_drake.planners.dwa import DwaPlanner

        if self.margin is not None:
            config = copy.deepcopy(config)
            config.dwa.safety_margin = self.margin
        return DwaPlanner(config, response=load_response(self.response))


@dc.dataclass
class MpcSpec:
    """The OSQP social MPC (`planners/mpc.py`)."""

    response: str = setting("", 'the step model it plans with ("" = the LIP)')
    clearance: float = setting(
        0.0,
        "added to its collision and discomfort margins (0 = as benchmarked; a student that "
        "tracks its teacher less precisely learns to keep more room)",
        "m",
        (0.0, 1.0),
    )

    def build(self, config: EmoNavConfig, device: str = "cpu"):
        from emonav_drake.planners.mpc import MpcPlanner

        return MpcPlanner(_widened(config, self.clearance), load_response(self.response))


@dc.dataclass
class PolicySpec(_Learned):
    """A trained policy checkpoint (`planners/policy.py`): a DAgger student or SAC actor."""

    checkpoint: str = setting("", 'the file it runs ("" = `variant`\'s shipped policy)')
    variant: str = setting(
        "", 'the shipped variant whose policy runs by default ("" = the default policy)'
    )

    def build(self, config: EmoNavConfig, device: str = "cpu"):
        return _categorical_policy(self.checkpoint_file(), config, device)


@dc.dataclass
class SacSpec:
    """A SAC-trained actor (`emonav train --algo sac`); the checkpoint must be given."""

    # No default checkpoint: what to give instead, and a check that the file given is one.
    # ({planners}, {checkpoint}, {n}: the method flags and name, filled in by the caller.)
    has_default_checkpoint: ClassVar[bool] = False
    checkpoint_hint: ClassVar[str] = (
        "a SAC-trained checkpoint is needed ({checkpoint} {n}=PATH, from `emonav train --algo "
        "sac`); the shipped policy is a DAgger student: use {planners} policy"
    )

    checkpoint: str = setting("", "the SAC-trained actor it runs (required)")

    def checkpoint_file(self) -> Path:
        if not self.checkpoint:
            raise ConfigError(
                "--planner sac runs a SAC-trained checkpoint (`emonav train --algo sac`): "
                "give --checkpoint PATH; the shipped policy is a DAgger student, run it "
                "with --planner policy"
            )
        from emonav_drake.planners.variants import resolve_policy_file

        return resolve_policy_file(self.checkpoint, "checkpoint")

    @staticmethod
    def checkpoint_problem(meta: dict) -> str:
        """Why a checkpoint (its metadata) cannot run as this spec ("" = it can): not a SAC
        actor. A template like `checkpoint_hint`."""
        from emonav_drake.planners.policy import describe_policy, policy_kind

        if policy_kind(meta) == "sac":
            return ""
        return f"not a SAC actor but a {describe_policy(meta)}; use {{planners}} policy"

    def build(self, config: EmoNavConfig, device: str = "cpu"):
        planner = _categorical_policy(self.checkpoint_file(), config, device)
        problem = self.checkpoint_problem(planner.meta)
        if problem:
            raise ConfigError(
                f"--planner sac: {planner.path} is " + problem.format(planners="--planner")
            )
        return planner


@dc.dataclass
class ShieldSpec(_Learned):
    """A categorical LGM policy behind the LGM shield (`planners/shield.py`), with the
    registered shields' settings for its response model. As a DAgger expert it labels
    with a distribution over the grid (`soft`).
    """

    soft: ClassVar[bool] = True

    checkpoint: str = setting(
        "",
        "the policy it shields (\"\" = `variant`'s; in a DAgger route, the route's `init_policy`)",
    )
    variant: str = setting("", "the shipped variant shielded by default")
    response: str = setting("", 'the step model the shield predicts with ("" = the LIP)')

    def build(self, config: EmoNavConfig, device: str = "cpu"):
        from emonav_drake.planners.shield import ShieldedPolicy

        policy = _categorical_policy(self.checkpoint_file(), config, device)
        return ShieldedPolicy.registered(policy, config, load_response(self.response))


@dc.dataclass
class MpcNearbySpec(_Learned):
    """A categorical policy choosing within `cells` grid steps of the MPC's command
    (`planners/mpc_nearby.py`); with `shielded`, only among the commands its LGM shield
    admits. As a DAgger expert it labels with a distribution over the grid (`soft`).
    """

    soft: ClassVar[bool] = True
    reads_crowd_state: ClassVar[bool] = True  # the MPC it steers by does

    checkpoint: str = setting(
        "",
        "the policy it steers (\"\" = `variant`'s; in a DAgger route, the route's `init_policy`)",
    )
    variant: str = setting("", "the shipped variant steered by default")
    response: str = setting("digit", 'the step model of the MPC and the shield ("" = the LIP)')
    clearance: float = setting(
        0.0, "added to the MPC's collision and discomfort margins", "m", (0.0, 1.0)
    )
    cells: int = setting(
        1, "the reach, in grid steps of u_v and u_Δθ around the MPC's command", "", (0, 10)
    )
    shielded: bool = setting(False, "only commands the policy's LGM shield admits")

    def build(self, config: EmoNavConfig, device: str = "cpu"):
        from emonav_drake.planners.mpc import MpcPlanner
        from emonav_drake.planners.mpc_nearby import MpcNearbyPolicy
        from emonav_drake.planners.shield import ShieldedPolicy

        policy = _categorical_policy(self.checkpoint_file(), config, device)
        model = load_response(self.response)
        mpc = MpcPlanner(_widened(config, self.clearance), model)
        guard = ShieldedPolicy.registered(policy, config, model) if self.shielded else None
        return MpcNearbyPolicy(policy, mpc, self.cells, guard)


# The shipped value networks of the crowd-state planners, by network.
VALUE_CHECKPOINTS = {
    name: Path(__file__).resolve().parent.parent / "data" / "policies" / f"{name}.pt"
    for name in ("sarl", "rgl")
}
_VALUE_TRAIN_FLAGS = {"sarl": "", "rgl": "--config emonav_drake/configs/rgl.yaml "}


@dc.dataclass
class SarlSpec:
    """A value network on the crowd state with one-step look-ahead (`planners/sarl.py`):
    CrowdNav's SARL or its relational graph network (RGL).
    """

    reads_crowd_state: ClassVar[bool] = True
    value_network: ClassVar[bool] = True

    checkpoint: str = setting("", 'the value network\'s file ("" = the shipped one of `network`)')
    network: str = setting("sarl", '"sarl" or "rgl": whose shipped checkpoint runs by default')

    def check(self) -> None:
        """`ConfigError` for a network without a shipped checkpoint of that kind."""
        if self.network not in VALUE_CHECKPOINTS:
            raise ConfigError(
                f"network = {self.network!r} is invalid: must be one of {list(VALUE_CHECKPOINTS)}"
            )

    def checkpoint_file(self) -> Path:
        if self.checkpoint:
            return Path(self.checkpoint)
        self.check()
        path = VALUE_CHECKPOINTS[self.network]
        if not path.is_file():
            raise ConfigError(
                f"{self.network} has no shipped checkpoint in this version: train it with "
                f"`emonav train --algo sarl {_VALUE_TRAIN_FLAGS[self.network]}--out "
                f"runs/{self.network}` and pass --checkpoint runs/{self.network}/policy.pt"
            )
        return path

    def build(self, config: EmoNavConfig, device: str = "cpu"):
        from emonav_drake.planners.sarl import SarlPlanner

        return SarlPlanner(self.checkpoint_file(), config, device=device)


@dc.dataclass
class PlannerSpec:
    """Any registered planner by name (`emonav planners`; a plug-in's or one from
    `--planner-module` too), with its default checkpoint unless `checkpoint` is given."""

    name: str = setting("dwa", "a registered planner's name (`emonav planners`)")
    checkpoint: str = setting("", 'the checkpoint it runs ("" = its default)')

    def build(self, config: EmoNavConfig, device: str = "cpu"):
        return make_planner(self.name, config, self.checkpoint or None, device)


# What a route's expert may be (DAgger, the Digit rounds, SARL's imitation), in YAML by tag;
# an untagged mapping is the first (`DwaSpec`).
ExpertSpec = DwaSpec | MpcSpec | ShieldSpec | MpcNearbySpec | PolicySpec | SarlSpec | PlannerSpec
EXPERT_SPECS = typing.get_args(ExpertSpec)


def is_soft(spec: object) -> bool:
    """Whether an expert spec labels with a distribution over the student's grid."""
    return bool(getattr(spec, "soft", False))


def describe_spec(spec: object) -> str:
    """A spec as it is written in YAML, e.g. `!MpcSpec {clearance: 0.1}` (defaults left
    out)."""
    if not dc.is_dataclass(spec):
        return type(spec).__name__
    given = [
        f"{f.name}: {getattr(spec, f.name)!r}"
        for f in dc.fields(spec)
        if getattr(spec, f.name) != f.default
    ]
    return f"!{type(spec).__name__} {{{', '.join(given)}}}"
