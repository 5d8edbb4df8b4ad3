"""The expert of a training route as one planner spec, and its earlier flat form.

A DAgger route, the Digit rounds and SARL's imitation take their expert as one field, a
typed planner spec (`planners/specs.py`). `expert_for_route` checks it where the route is
configured and fills in what the route supplies (a shield or MPC-nearby expert without a
checkpoint wraps the route's `init_policy`). Runs saved by earlier versions kept the
expert as a name plus flat `expert_*` fields; `expert_from_legacy` turns such a saved
configuration into the spec it meant, so those runs still resume and their Digit rounds
still run.
"""

import dataclasses as dc

from emonav_drake.params import ConfigError
from emonav_drake.planners.registry import runs_checkpoint
from emonav_drake.planners.specs import (
    EXPERT_SPECS,
    DwaSpec,
    MpcNearbySpec,
    MpcSpec,
    PlannerSpec,
    ShieldSpec,
    describe_spec,
    is_soft,
)

# The flat expert fields of earlier versions (a name in `expert` and these).
LEGACY_EXPERT_FIELDS = (
    "expert_margin",
    "expert_clearance",
    "expert_policy",
    "expert_cells",
    "expert_shield",
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


def named_expert_from_legacy(saved: dict) -> dict:
    """A saved SARL configuration of an earlier version (the expert a registered name,
    "mpc" or "dwa") with that planner's spec instead; any other unchanged."""
    name = saved.get("expert")
    if not isinstance(name, str):
        return saved
    from emonav_drake.planners import planner_kind

    spec = planner_kind(name).spec
    return saved | {"expert": _tagged(spec)}


def expert_from_legacy(saved: dict) -> dict:
    """A saved configuration with an earlier version's flat expert (a name in `expert`,
    `expert_margin`, …) turned into one with the spec it meant (tagged plain data, as
    `typed_yaml.to_plain` writes it); any other configuration unchanged.

    The names meant: "dwa" = DWA with `expert_margin` planning with the route's
    `response`; "mpc" = the MPC on the LIP widened by `expert_clearance`; "shield" =
    `expert_policy` behind the LGM shield predicting with `response`; "mpc_nearby" =
    `expert_policy` within `expert_cells` of the MPC planning with `response`, widened by
    `expert_clearance`, shielded with `expert_shield`; another name = that registered
    planner."""
    name = saved.get("expert")
    if not isinstance(name, str):
        return saved
    out = {k: v for k, v in saved.items() if k not in LEGACY_EXPERT_FIELDS}
    response = str(saved.get("response", ""))
    policy = str(saved.get("expert_policy", ""))
    clearance = float(saved.get("expert_clearance", 0.0))
    if name == "dwa":
        spec = DwaSpec(margin=float(saved.get("expert_margin", 0.05)), response=response)
    elif name == "mpc":
        spec = MpcSpec(clearance=clearance)
    elif name == "shield":
        spec = ShieldSpec(checkpoint=policy, response=response)
    elif name == "mpc_nearby":
        spec = MpcNearbySpec(
            checkpoint=policy,
            response=response,
            clearance=clearance,
            cells=int(saved.get("expert_cells", 1)),
            shielded=bool(saved.get("expert_shield", False)),
        )
    else:
        spec = PlannerSpec(name=name)
    out["expert"] = _tagged(spec)
    return out


def _tagged(spec: object) -> dict:
    """A spec as tagged plain data, as `typed_yaml.to_plain` writes a union's value."""
    return dc.asdict(spec) | {"_tag": f"!{type(spec).__name__}"}
