"""The expert of a training route as one planner spec.

A DAgger route, the Digit rounds and SARL's imitation take their expert as one field, a
typed planner spec (`planners/specs.py`). `expert_for_route` checks it where the route is
configured and fills in what the route supplies (a shield or MPC-nearby expert without a
checkpoint wraps the route's `init_policy`). The expert's flat form of earlier versions
is read by `planners/legacy.py`.
"""

import dataclasses as dc

from emonav_drake.params import ConfigError
from emonav_drake.planners.registry import runs_checkpoint
from emonav_drake.planners.specs import (
    EXPERT_SPECS,
    PlannerSpec,
    describe_spec,
    is_soft,
)


def expert_for_route(spec: object, init_policy: str, planner_modules: list[str]):
    """`spec` as the route builds it: a soft expert (`ShieldSpec`, `MpcNearbySpec`)
    without a checkpoint gets `init_policy`. `ConfigError` for a spec that is not an
    expert spec, a soft one with nothing to wrap, or a `PlannerSpec` whose name is not
    registered once `planner_modules` are imported."""
    if not isinstance(spec, EXPERT_SPECS):
        raise ConfigError(
            f"expert = {spec!r} is invalid: must be one of "
            f"{', '.join('!' + c.__name__ for c in EXPERT_SPECS)}"
        )
    check = getattr(spec, "check", None)  # a spec's own rules (`SarlSpec.network`)
    if check is not None:
        try:
            check()
        except ConfigError as e:
            raise ConfigError(f"expert.{e}") from None
    if is_soft(spec) and not spec.checkpoint:
        if not init_policy:
            raise ConfigError(
                f"expert = {describe_spec(spec)} needs the policy it wraps: its checkpoint "
                "(or the route's init_policy)"
            )
        spec = dc.replace(spec, checkpoint=init_policy)
    if isinstance(spec, PlannerSpec):
        from emonav_drake.planners import is_registered, planner_kind, planner_names
        from emonav_drake.planners.plugins import import_planner_modules

        import_planner_modules(planner_modules)
        if not is_registered(spec.name):
            raise ConfigError(
                f"expert = {describe_spec(spec)}: no planner {spec.name!r} is registered "
                f"({', '.join(planner_names())}; a module of your own in planner_modules)"
            )
        if spec.checkpoint and not runs_checkpoint(planner_kind(spec.name).spec):
            raise ConfigError(
                f"expert = {describe_spec(spec)}: planner {spec.name!r} runs no checkpoint"
            )
    return spec
