"""Typed planner specs: the registry's names, the experts of the training routes in YAML,
and the configurations earlier versions saved."""

import dataclasses as dc

import numpy as np
import pytest

from emonav_drake.learning.config import DaggerConfig, SarlConfig
from emonav_drake.navigation.lip_world import NavigationWorld
from emonav_drake.params import EmoNavConfig
from emonav_drake.planners import make_planner, planner_kind, planner_names
from emonav_drake.planners.specs import (
    EXPERT_SPECS,
    DwaSpec,
    MpcNearbySpec,
    MpcSpec,
    PlannerSpec,
    PolicySpec,
    SarlSpec,
    ShieldSpec,
    describe_spec,
)
from emonav_drake.scenarios.scenario import sample_scenario
from emonav_drake.typed_yaml import ConfigError, from_plain, load_typed_yaml, to_plain


def _walk(planner, config: EmoNavConfig, seed: int, steps: int) -> list[np.ndarray]:
    """The commands `planner` sends over `steps` LIP steps of scenario `seed`."""
    world = NavigationWorld(sample_scenario(seed, config), config, goal_radius=0.2)
    planner.reset()
    commands = []
    for _ in range(steps):
        u = planner.plan(world.planner_input())
        commands.append(np.asarray(u, float))
        if world.step(u)[1] is not None:
            break
    return commands


@pytest.mark.parametrize("name", ["dwa", "mpc", "mpc_digit", "policy", "sarl"])
def test_a_registered_name_builds_what_its_spec_builds(name):
    """`make_planner(name)` is the registry's spec built: the same commands step for step
    (real DWA, OSQP MPC, policy network and SARL value network)."""
    cfg = EmoNavConfig()
    by_name = make_planner(name, cfg)
    by_spec = planner_kind(name).spec.build(cfg)
    a, b = _walk(by_name, cfg, 3, 8), _walk(by_spec, cfg, 3, 8)
    assert len(a) == len(b) >= 4
    for u, v in zip(a, b, strict=True):
        np.testing.assert_array_equal(u, v)


def test_every_registered_planner_has_a_spec_that_says_what_it_is():
    for name in planner_names():
        spec = planner_kind(name).spec
        assert callable(getattr(spec, "build", None)), name
        assert describe_spec(spec).startswith("!"), name
    assert planner_kind("rgl").spec == SarlSpec(network="rgl")
    assert planner_kind("policy_shield_digit").spec == ShieldSpec(
        variant="emobipednav_digit_mpc", response="digit"
    )
    assert planner_kind("single_lgm").spec == PolicySpec(variant="single_lgm")


def test_a_checkpoint_goes_to_learned_planners_only():
    with pytest.raises(ConfigError, match="planner 'dwa' runs no checkpoint"):
        make_planner("dwa", EmoNavConfig(), checkpoint="x.pt")


@pytest.mark.parametrize(
    "text, spec",
    [
        ("", DwaSpec(margin=0.05)),
        ("expert: {margin: 0.2}", DwaSpec(margin=0.2)),
        # the route's default DWA expert keeps its 0.05 m margin where a field is left out
        ("expert: !DwaSpec {response: digit}", DwaSpec(margin=0.05, response="digit")),
        ("expert: !MpcSpec {clearance: 0.1}", MpcSpec(clearance=0.1)),
        (
            "expert: !ShieldSpec {checkpoint: shipped, response: digit}",
            ShieldSpec(checkpoint="shipped", response="digit"),
        ),
        (
            "expert: !MpcNearbySpec {checkpoint: shipped, cells: 2, shielded: true}",
            MpcNearbySpec(checkpoint="shipped", cells=2, shielded=True),
        ),
        ("expert: !PolicySpec {checkpoint: single_lgm}", PolicySpec(checkpoint="single_lgm")),
        ("expert: !PlannerSpec {name: mpc_digit}", PlannerSpec(name="mpc_digit")),
    ],
)
def test_a_routes_expert_is_one_typed_field_in_yaml(text, spec):
    """Each expert spec by its tag (untagged: DWA), and back: the saved plain form of the
    configuration restores the same object."""
    cfg = load_typed_yaml(DaggerConfig, data=text + "\nseed: 3\n").validate()
    assert cfg.expert == spec
    assert DaggerConfig.from_saved(to_plain(cfg)) == cfg
    assert from_plain(DaggerConfig, to_plain(cfg)) == cfg


@pytest.mark.parametrize(
    "text, message",
    [
        ("expert: !OrcaSpec {}", "expert: unknown tag '!OrcaSpec'; choose one of !DwaSpec"),
        ("expert: !MpcSpec {margin: 0.1}", "expert.margin: unknown field; MpcSpec has"),
        ("expert: !MpcSpec {clearance: 3}", "expert.clearance = 3.0 is out of range"),
        ("expert: !DwaSpec {margin: -1}", "expert.margin = -1.0 is out of range"),
        ("expert: !MpcNearbySpec {cells: 11}", "expert.cells = 11 is out of range"),
        ("expert: !ShieldSpec {}", "needs the policy it wraps"),
        ("expert: !PlannerSpec {name: nobody}", "no planner 'nobody' is registered"),
        ("expert: !SarlSpec {network: gcn}", "expert.network = 'gcn' is invalid: must be one"),
        ("expert: !PlannerSpec {name: dwa, checkpoint: x.pt}", "'dwa' runs no checkpoint"),
        ("expert: !MpcSpec {}\nsoft_labels: true", "soft_labels needs a ShieldSpec or"),
        (
            "expert: mpc",
            r"expert = 'mpc' is invalid: expected a mapping tagged with one of !DwaSpec, .*"
            r"`expert: !PlannerSpec \{name: mpc\}`",
        ),
        ("expert_margin: 0.1", "expert_margin: no longer a field: .*!DwaSpec"),
        ("expert_shield: true", "expert_shield: no longer a field"),
    ],
)
def test_a_wrong_expert_is_refused_naming_the_field(text, message):
    with pytest.raises(ConfigError, match=message):
        load_typed_yaml(DaggerConfig, data=text).validate()


def test_a_soft_expert_without_a_checkpoint_wraps_the_routes_start_policy():
    route = DaggerConfig(expert=MpcNearbySpec(cells=2), init_policy="emobipednav_digit_mpc")
    assert route.validate().teacher() == MpcNearbySpec(checkpoint="emobipednav_digit_mpc", cells=2)
    assert route.expert == MpcNearbySpec(cells=2)


@pytest.mark.parametrize(
    "flat, spec",
    [
        ({}, DwaSpec(margin=0.05)),
        ({"expert": "dwa", "expert_margin": 0.1, "response": "digit"}, None),
        ({"expert": "mpc", "expert_clearance": 0.1, "response": "digit"}, MpcSpec(clearance=0.1)),
        (
            {"expert": "shield", "expert_policy": "shipped", "response": "digit"},
            ShieldSpec(checkpoint="shipped", response="digit"),
        ),
        (
            {
                "expert": "mpc_nearby",
                "expert_policy": "shipped",
                "expert_cells": 2,
                "expert_shield": True,
                "expert_clearance": 0.05,
                "response": "digit",
            },
            MpcNearbySpec(
                checkpoint="shipped", response="digit", clearance=0.05, cells=2, shielded=True
            ),
        ),
        ({"expert": "mpc_digit"}, PlannerSpec(name="mpc_digit")),
    ],
)
def test_a_configuration_an_earlier_version_saved_still_reads(flat, spec):
    """A run state of an earlier version named its expert and flattened its settings
    (`expert_margin`, …): read now, it is the spec those settings meant (the Digit route's
    DWA expert is the registered `dwa_digit`)."""
    from emonav_drake.planners import DWA_DIGIT

    old = {k: v for k, v in dc.asdict(DaggerConfig()).items() if k != "expert"}
    old |= {"expert": "dwa", "expert_margin": 0.05, "expert_clearance": 0.0}
    old |= {"expert_policy": "", "expert_cells": 1, "expert_shield": False} | flat
    saved = DaggerConfig.from_saved(old)
    assert saved.expert == (spec or DWA_DIGIT)
    assert saved.response == flat.get("response", "")


def test_sarls_expert_is_a_spec_and_its_old_runs_read():
    cfg = load_typed_yaml(SarlConfig, data="expert: !DwaSpec {}\nil_episodes: 3\n").validate()
    assert cfg.expert == DwaSpec() and SarlConfig().expert == MpcSpec()
    assert SarlConfig.from_saved(to_plain(cfg)) == cfg
    old = dc.asdict(SarlConfig()) | {"expert": "dwa"}
    assert SarlConfig.from_saved(old).expert == DwaSpec()  # the registered "dwa"


def test_every_expert_spec_is_a_tagged_dataclass_with_build():
    for spec in EXPERT_SPECS:
        assert dc.is_dataclass(spec) and callable(spec.build)
