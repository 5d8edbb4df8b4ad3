"""Old names and old forms, in one place: what earlier versions wrote that today's code
still reads.

* Benchmark methods: two names changed meaning over the project's history. "policy" ran
  whatever file was the default then, and "sac" was the shipped policy before the planner
  rename (a DAgger student, run by the policy planner). `planner_of` gives the planner
  kind that builds a recorded method; `method_label` the name a figure gives it, judged by
  the checkpoint file the run recorded (today's default keeps "policy").
* Training experts: runs saved by earlier versions kept a route's expert as a name plus
  flat `expert_*` fields; `expert_from_legacy` (DAgger, the Digit rounds) and
  `named_expert_from_legacy` (SARL) turn such a saved configuration into the typed planner
  spec it meant (`planners/specs.py`), so those runs still resume.

Nothing else in the package dispatches on a planner's name outside the registry.
"""

from __future__ import annotations

import dataclasses as dc
from pathlib import PurePath

from emonav_drake.planners.specs import DwaSpec, MpcNearbySpec, MpcSpec, PlannerSpec, ShieldSpec

# The LIP-trained EmoBipedNav (`--planner emobipednav`) was the default policy until the
# Digit route's student replaced it: runs made before call it "policy", and runs made
# before the planner rename "sac" (it is a DAgger student). Figures name it by its file.
SHIPPED_POLICY_FILE = "policy_lgm.pt"
LIP_TRAINED_LABEL = "emobipednav"
# The files earlier defaults were run from as "policy", and the variant each is: the MPC
# route's student was the default until the distilled route's Digit round replaced it.
FORMER_DEFAULTS = {
    SHIPPED_POLICY_FILE: LIP_TRAINED_LABEL,
    "emobipednav_digit_mpc.pt": "emobipednav_digit_mpc",
}


def method_label(name: str, checkpoint: str | None = None) -> str:
    """The name a figure gives a benchmark method: a "policy" or "sac" that ran the file of
    an earlier default is that policy's variant name (`FORMER_DEFAULTS`: the LIP-trained
    "emobipednav", the MPC route's "emobipednav_digit_mpc"; an old run's "sac" without a
    recorded checkpoint is the LIP-trained policy too); today's default `policy` and a
    SAC-trained actor of `--planner sac` keep their names."""
    if name not in ("sac", "policy"):
        return name
    if checkpoint is None:
        return LIP_TRAINED_LABEL if name == "sac" else name
    return FORMER_DEFAULTS.get(PurePath(checkpoint).name, name)


def planner_of(recorded: str) -> str:
    """The planner kind that builds a method recorded as `recorded` (`MethodSpec.planner`):
    itself, except "sac", which runs before the planner rename wrote for the shipped policy
    (a policy file)."""
    return "policy" if recorded == "sac" else recorded


# The flat expert fields of earlier versions (a name in `expert` and these).
LEGACY_EXPERT_FIELDS = (
    "expert_margin",
    "expert_clearance",
    "expert_policy",
    "expert_cells",
    "expert_shield",
)


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
