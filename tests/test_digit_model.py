"""The Digit model this project authors: mass, joints, limits, contact points."""

import numpy as np
import pytest
from pydrake.systems.framework import DiagramBuilder

from emonav_drake.models.digit.make_digit_urdf import URDF_PATH, make_urdf
from emonav_drake.params import WalkingParams
from emonav_drake.systems.digit_plant import (
    ARM_JOINTS,
    LEG_JOINTS,
    SIDES,
    AddDigitPlant,
    standing_state,
)

# joint-side effort limit [N·m] and gear ratio (docs/facts.md, "Digit, and the model …")
EXPECTED = {
    "hip_roll": (126.7, 80),
    "hip_yaw": (79.2, 50),
    "hip_pitch": (216.9, 16),
    "knee": (231.3, 16),
    "toe_pitch": (42.0, 50),
    "toe_roll": (42.0, 50),
    "shoulder_roll": (126.7, 80),
    "shoulder_pitch": (126.7, 80),
    "shoulder_yaw": (79.2, 50),
    "elbow": (126.7, 80),
}


def _model(arms: str):
    return AddDigitPlant(DiagramBuilder(), WalkingParams(arms=arms))


def test_the_checked_in_urdf_is_the_generated_one():
    assert URDF_PATH.read_text() == make_urdf()


@pytest.mark.parametrize("arms", ["held", "welded"])
def test_mass_joints_and_limits(arms):
    m = _model(arms)
    plant = m.plant
    assert 44.0 <= m.total_mass <= 50.0
    assert plant.time_step() == pytest.approx(WalkingParams().time_step)
    n_arm = 8 if arms == "held" else 0
    assert plant.num_actuators() == 12 + n_arm
    assert plant.num_velocities() == 6 + 12 + n_arm
    assert plant.num_positions() == 7 + 12 + n_arm
    names = [j for j in LEG_JOINTS] + ([j for j in ARM_JOINTS] if arms == "held" else [])
    for side in SIDES:
        for j in names:
            act = plant.GetJointActuatorByName(f"{side}_{j}_motor")
            limit, gear = EXPECTED[j]
            assert act.effort_limit() == pytest.approx(limit)
            assert act.default_gear_ratio() == pytest.approx(gear)
            # rotor inertia is motor-side: reflected = rotor · gear² ∈ [0.03, 0.2] kg·m²
            assert act.default_rotor_inertia() < 1e-3
            assert 0.03 <= act.default_reflected_inertia() <= 0.2
    # a floating torso
    assert m.torso_body.is_floating_base_body()


def test_the_urdf_declares_the_arm_joints_even_when_welded():
    text = URDF_PATH.read_text()
    for side in SIDES:
        for j in ARM_JOINTS:
            assert f'<joint name="{side}_{j}" type="revolute">' in text


def test_four_sole_spheres_per_foot_and_standing_pose():
    m = _model("welded")
    plant, sg = m.plant, m.scene_graph
    inspector = sg.model_inspector()
    for foot in m.foot_bodies:
        geoms = plant.GetCollisionGeometriesForBody(foot)
        assert len(geoms) == 4
        assert all(inspector.GetShape(g).__class__.__name__ == "Sphere" for g in geoms)
    ctx = plant.CreateDefaultContext()
    plant.SetPositionsAndVelocities(ctx, standing_state(m))
    com = plant.CalcCenterOfMassPositionInWorld(ctx)
    assert 0.85 <= com[2] <= 1.0  # published for Digit 0.9–1.0 m; this model 0.891 m
    for foot in m.foot_bodies:  # flat feet, soles on the ground (ankle 5 cm above)
        X = plant.EvalBodyPoseInWorld(ctx, foot)
        assert X.translation()[2] == pytest.approx(0.05)
        np.testing.assert_allclose(X.rotation().matrix(), np.eye(3), atol=1e-9)
