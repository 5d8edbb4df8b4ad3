"""The planner registry: one name → how to build that planner.

A planner is anything that satisfies `planners.protocol.Planner` (the pure pair
`initial_memory()` / `plan_with_memory(obs, memory)`, the stateful `plan(obs)` /
`reset()`). Each name is registered as a `PlannerKind` — the name and its spec (an object
with `build(config, device)`, `planners/specs.py`; a spec with a `checkpoint` field runs
a learned checkpoint) — with one `register(...)` line in `planners/__init__.py`.
Everything that chooses a planner by name (`emonav sim|eval --planner`, `emonav
benchmark --planners`, the trial workers, a route's `!PlannerSpec` expert) asks this
registry, so a new planner is one module plus one registry line (`docs/architecture.md`).
"""

from __future__ import annotations

import dataclasses as dc
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any, Protocol

from emonav_drake.params import ConfigError, EmoNavConfig
from emonav_drake.registry import Registry


class Spec(Protocol):
    """What the registry holds for a name: `build(config, device)` → a new planner, which
    must not modify `config` (the planner may keep it). A spec that runs a checkpoint is
    a dataclass with a `checkpoint` field (str; "" = its default, `checkpoint_file()`)."""

    def build(self, config: EmoNavConfig, device: str = "cpu") -> Any: ...


@dc.dataclass(frozen=True)
class PlannerKind:
    """One registered planner.

    Attributes:
        name: the name on the command line.
        spec: how to build it (`Spec`; `planners/specs.py` has the package's).
        summary: one line for `--help` and error messages.
        runs_as: the planner kind a benchmark records for this kind's checkpoints and
            builds them with: "policy" (every policy file, whatever its variant name) or
            the kind itself when its checkpoints are not policies (SARL's value network).
    """

    name: str
    spec: Spec
    summary: str = ""
    runs_as: str = "policy"

    @property
    def learned(self) -> bool:
        """Runs a checkpoint (`--checkpoint`); model planners take none."""
        return runs_checkpoint(self.spec)

    @property
    def default_checkpoint(self) -> Callable[[], Path] | None:
        """What gives the checkpoint a learned planner runs without `--checkpoint` (called
        when needed: it may raise `ConfigError` saying how to train it); None for a model
        planner or a spec that has none (`has_default_checkpoint` False: SAC's actor)."""
        if not self.learned or not getattr(self.spec, "has_default_checkpoint", True):
            return None
        return getattr(self.spec, "checkpoint_file", None)

    @property
    def reads_crowd_state(self) -> bool:
        """Reads `PlannerInput.crowd` (a model planner, a user's, or a learned spec that says
        so: SARL/RGL, the MPC-steered policies); a policy on its own map does not."""
        return not self.learned or getattr(self.spec, "reads_crowd_state", False)


_KINDS: Registry[PlannerKind] = Registry("planner")
# The module names `planners.plugins.import_planner_module` gives `.py` files.
USER_MODULE_PREFIX = "emonav_user_planner_"


def runs_checkpoint(spec: object) -> bool:
    """Whether a spec runs a checkpoint (a dataclass with a `checkpoint` field)."""
    return dc.is_dataclass(spec) and any(f.name == "checkpoint" for f in dc.fields(spec))


def make_planner(
    name: str, config: EmoNavConfig, checkpoint: str | Path | None = None, device: str = "cpu"
):
    """Create the planner called `name` (any registered name): its spec built.

    A learned planner runs `checkpoint` if given (the spec's `checkpoint` replaced), else
    its spec's default ("policy": the shipped policy; a variant: the policy shipped under
    its name; "sac": none — a `ConfigError` says how to get one); a model planner takes no
    checkpoint (`ConfigError` if one is given). A spec from outside the package whose
    `build` raises is a `PlannerBuildError` naming the planner and its module."""
    spec = planner_kind(name).spec
    if checkpoint is not None:
        if not runs_checkpoint(spec):
            raise ConfigError(f"--checkpoint: planner {name!r} runs no checkpoint")
        spec = dc.replace(spec, checkpoint=str(checkpoint))
    try:
        planner = spec.build(config, device)
        planner.name = name  # what captions and logs call it: the name it was asked for
    except Exception as e:
        module = outside_module(spec)
        if module is None:  # the package's own spec: its errors are its own
            raise
        raise PlannerBuildError(
            f"planner {name!r} (module {module}) failed to build: {type(e).__name__}: {e}"
        ) from e
    return planner


class PlannerBuildError(ConfigError):
    """A planner of the user's own (its spec in a module outside the package) whose
    `build` raised: the message names the planner, its module and the error. A
    `ConfigError` (the CLI's exit 2): the fault is in that module, not in the package."""


def outside_module(obj: object) -> str | None:
    """Where a spec or planner from outside the package comes from, for messages: the file
    of a module named by its path (`--planner-module x.py`), else the module's dotted name;
    None for the package's own specs and planners."""
    module = type(obj).__module__
    if module == "emonav_drake" or module.startswith("emonav_drake."):
        return None
    file = getattr(sys.modules.get(module), "__file__", None)
    if module.startswith(USER_MODULE_PREFIX) and file:
        return file
    return module


def register(kind: PlannerKind, replace: bool = False) -> PlannerKind:
    """Add `kind` to the registry (`ValueError` if its name is taken and not `replace`)."""
    if not kind.name or not kind.name.replace("_", "").isalnum():
        raise ValueError(f"planner name {kind.name!r}: letters, digits and '_' only")
    return _KINDS.add(kind.name, kind, replace)


def unregister(name: str) -> None:
    """Remove a planner (tests that register a throw-away one)."""
    _KINDS.remove(name)


def planner_names() -> tuple[str, ...]:
    """Every registered name, in registration order."""
    return tuple(_KINDS)


def model_planner_names() -> tuple[str, ...]:
    """The registered planners that take no checkpoint."""
    return tuple(n for n, k in _KINDS.items() if not k.learned)


def is_registered(name: str) -> bool:
    return name in _KINDS


def planner_kind(name: str) -> PlannerKind:
    """The kind called `name`; `ConfigError` listing the names otherwise."""
    if name not in _KINDS:
        raise ConfigError(f"unknown planner {name!r}: choose one of {', '.join(_KINDS)}")
    return _KINDS[name]
