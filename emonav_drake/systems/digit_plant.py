"""The full-order Digit as a discrete Drake `MultibodyPlant` (1 ms, SAP, point contact).

`AddDigitPlant(builder, params)` parses this project's `models/digit/digit.urdf` with
Drake's `Parser`, adds a ground half-space (z = 0, friction `params.friction`), welds or
keeps the arms (`params.arms`), finalises the plant and returns a `DigitModel` with the
index maps the planner and the controller share.

Frames: world W (z up, ground at z = 0); torso T (x forward, y left, z up) is the floating
base, its generalized velocities are [ω_WT (world), v_WTo (world)] at `base_v`; each foot
frame F sits on the ankle (toe-roll) axis, the sole plane 0.05 m below it.
Plant ports used here: `actuation` input (one entry per actuator, joint torques [N·m],
clamped by Drake to the joint-side effort limits) and `state` output (q, v).
"""

from __future__ import annotations

import dataclasses as dc
import logging
import math
from pathlib import Path

import numpy as np
from pydrake.common.eigen_geometry import AngleAxis
from pydrake.geometry import Box, HalfSpace, SceneGraph
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import (
    AddMultibodyPlant,
    CoulombFriction,
    MultibodyPlant,
    MultibodyPlantConfig,
)
from pydrake.multibody.tree import ModelInstanceIndex, PdControllerGains
from pydrake.systems.framework import DiagramBuilder

from emonav_drake.params import WalkingParams
from emonav_drake.params_robot import LEG_JOINT_NAMES

DIGIT_URDF = Path(__file__).resolve().parent.parent / "models" / "digit" / "digit.urdf"
SIDES = ("left", "right")
LEG_JOINTS = LEG_JOINT_NAMES
ARM_JOINTS = ("shoulder_roll", "shoulder_pitch", "shoulder_yaw", "elbow")
# The held arm pose [rad] (shoulder roll, pitch, yaw, elbow; the right arm mirrors roll/yaw).
ARM_POSE = (0.15, 0.0, 0.0, -0.5)
THIGH_LENGTH = 0.45
SHIN_LENGTH = 0.45
ANKLE_TO_SOLE = 0.05  # foot frame origin (ankle) above the sole plane [m]
HIP_PITCH_BELOW_TORSO = 0.135  # hip-pitch axis below the torso origin [m]
HIP_Y = 0.091
# The ground as drawn (its collision geometry is a half-space): a slab this wide [m] and
# thick [m], its top at z = 0.
GROUND_VISUAL_SIZE = 100.0
GROUND_VISUAL_THICKNESS = 0.02


def _drop_deformable_half_space_warning(record: logging.LogRecord) -> bool:
    # Drake warns, once per context, that half spaces take no part in deformable contact;
    # this model has no deformable body, so the warning is noise.
    return "half spaces are not currently supported for deformable" not in record.getMessage()


logging.getLogger("drake").addFilter(_drop_deformable_half_space_warning)


@dc.dataclass
class DigitModel:
    """The finalised plant and the indices the walking systems use.

    `leg_v[i]`, `leg_q[i]`, `leg_u[i]` are the six velocity, position and actuation-input
    indices of leg i (0 left, 1 right) in `LEG_JOINTS` order; `arm_*` the same for the
    arms (empty when welded). `base_v` = slice(0, 6) style index array of the torso's
    floating velocities [ω_WT; v_WTo], `base_q` its quaternion + position.
    `implicit_legs` (6 booleans, `LEG_JOINTS` order): the joints damped by the contact
    solver (`walking.implicit_damping`); `actuated_q`, `actuated_v`: the position and
    velocity index of each actuator's joint, in actuation-input order (the layout of the
    plant's desired-state port: [q_d; v_d]).
    """

    plant: MultibodyPlant
    scene_graph: SceneGraph
    instance: ModelInstanceIndex
    params: WalkingParams
    total_mass: float
    base_q: np.ndarray
    base_v: np.ndarray
    leg_q: list[np.ndarray]
    leg_v: list[np.ndarray]
    leg_u: list[np.ndarray]
    arm_q: np.ndarray
    arm_v: np.ndarray
    arm_u: np.ndarray
    arm_q_target: np.ndarray
    foot_bodies: list
    torso_body: object
    non_foot_bodies: set
    implicit_legs: np.ndarray
    actuated_q: np.ndarray
    actuated_v: np.ndarray

    @property
    def num_positions(self) -> int:
        return self.plant.num_positions()

    @property
    def num_velocities(self) -> int:
        return self.plant.num_velocities()

    @property
    def num_actuators(self) -> int:
        return self.plant.num_actuators()


def _weld_arms(plant: MultibodyPlant, instance: ModelInstanceIndex) -> None:
    """Replace each arm joint by a weld at the held pose (`ARM_POSE`)."""
    for side, sign in zip(SIDES, (1.0, -1.0), strict=True):
        for name, angle in zip(ARM_JOINTS, ARM_POSE, strict=True):
            joint = plant.GetJointByName(f"{side}_{name}", instance)
            if name in ("shoulder_roll", "shoulder_yaw"):
                angle *= sign
            plant.RemoveJointActuator(plant.GetJointActuatorByName(f"{side}_{name}_motor"))
            parent, child = joint.frame_on_parent(), joint.frame_on_child()
            axis = joint.revolute_axis()
            plant.RemoveJoint(joint)
            X_PC = RigidTransform(_axis_rotation(axis, angle))
            plant.WeldFrames(parent, child, X_PC)  # the joint's frames coincide at angle 0


def _damp_implicitly(
    plant: MultibodyPlant, instance: ModelInstanceIndex, params: WalkingParams
) -> None:
    """Give the actuators of the joints in `params.implicit_damping` (both legs) a PD
    controller of proportional gain 0 and derivative gain K_D (`params.kd_leg`): SAP then
    applies −K_D (v − v_d) with the velocity at the end of its step, inside its solve (the
    controller supplies v_d on the plant's desired-state port and the rest of the torque
    as feed-forward on its actuation port)."""
    for name in params.implicit_damping:
        kd = params.kd_leg[LEG_JOINTS.index(name)]
        for side in SIDES:
            actuator = plant.GetJointActuatorByName(f"{side}_{name}_motor", instance)
            actuator.set_controller_gains(PdControllerGains(p=0.0, d=kd))


def _axis_rotation(axis: np.ndarray, angle: float) -> RotationMatrix:
    return RotationMatrix(AngleAxis(angle, np.asarray(axis, dtype=float)))


def AddDigitPlant(
    builder: DiagramBuilder,
    params: WalkingParams,
    gravity: float = 9.81,
    pose: tuple[float, float, float] = (0.0, 0.0, 0.0),
) -> DigitModel:
    """Add the Digit plant, its scene graph and the ground to `builder`.

    The plant's default state is standing still (`standing_state`) with the torso at
    `pose`, so a default context starts standing.

    Args:
        builder: the diagram builder.
        params: time step, friction and arm option (`WalkingParams`).
        gravity: g [m/s²] (`RobotParams.gravity`), along −z of the world.
        pose: (x [m], y [m], yaw [rad]) of the torso in the world at the start.
    """
    config = MultibodyPlantConfig(
        time_step=params.time_step,
        discrete_contact_approximation="sap",
        contact_model="point",
        penetration_allowance=1e-3,
    )
    plant, scene_graph = AddMultibodyPlant(config, builder)
    instance = Parser(plant, "digit").AddModels(str(DIGIT_URDF))[0]
    if params.arms == "welded":
        _weld_arms(plant, instance)
    friction = CoulombFriction(params.friction, params.friction)
    X_WG = RigidTransform()
    plant.RegisterCollisionGeometry(
        plant.world_body(), X_WG, HalfSpace(), "ground_collision", friction
    )
    # drawn as a thin slab, its top at z = 0 (Meshcat cannot draw a half-space)
    plant.RegisterVisualGeometry(
        plant.world_body(),
        RigidTransform([0.0, 0.0, -GROUND_VISUAL_THICKNESS / 2]),
        Box(GROUND_VISUAL_SIZE, GROUND_VISUAL_SIZE, GROUND_VISUAL_THICKNESS),
        "ground_visual",
        np.array([0.8, 0.8, 0.78, 1.0]),
    )
    plant.mutable_gravity_field().set_gravity_vector([0.0, 0.0, -gravity])
    _damp_implicitly(plant, instance, params)
    plant.Finalize()
    model = describe_digit(plant, scene_graph, instance, params)
    x0 = standing_state(model, pose=pose)
    plant.SetDefaultPositions(x0[: plant.num_positions()])
    return model


def describe_digit(
    plant: MultibodyPlant,
    scene_graph: SceneGraph,
    instance: ModelInstanceIndex,
    params: WalkingParams,
) -> DigitModel:
    """Index maps of a finalised Digit plant."""
    torso = plant.GetBodyByName("torso", instance)
    qs, vs = torso.floating_positions_start(), torso.floating_velocities_start_in_v()

    def joint_indices(names: list[str]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        q, v, u = [], [], []
        for n in names:
            j = plant.GetJointByName(n, instance)
            q.append(j.position_start())
            v.append(j.velocity_start())
            u.append(plant.GetJointActuatorByName(f"{n}_motor", instance).input_start())
        return np.array(q), np.array(v), np.array(u)

    legs = [joint_indices([f"{s}_{j}" for j in LEG_JOINTS]) for s in SIDES]
    arm_names = [f"{s}_{j}" for s in SIDES for j in ARM_JOINTS]
    if params.arms == "held":
        arm_q, arm_v, arm_u = joint_indices(arm_names)
        arm_target = np.array(
            [
                a * (sg if j in ("shoulder_roll", "shoulder_yaw") else 1.0)
                for sg in (1.0, -1.0)
                for j, a in zip(ARM_JOINTS, ARM_POSE, strict=True)
            ]
        )
    else:
        arm_q = arm_v = arm_u = np.zeros(0, dtype=int)
        arm_target = np.zeros(0)
    feet = [plant.GetBodyByName(f"{s}_foot", instance) for s in SIDES]
    foot_indices = {int(b.index()) for b in feet}
    non_foot = {int(i) for i in plant.GetBodyIndices(instance) if int(i) not in foot_indices}
    mass = float(sum(plant.get_body(i).default_mass() for i in plant.GetBodyIndices(instance)))
    actuators = [plant.get_joint_actuator(i) for i in plant.GetJointActuatorIndices(instance)]
    actuators.sort(key=lambda a: a.input_start())
    return DigitModel(
        plant=plant,
        scene_graph=scene_graph,
        instance=instance,
        params=params,
        total_mass=mass,
        base_q=np.arange(qs, qs + 7),
        base_v=np.arange(vs, vs + 6),
        leg_q=[lg[0] for lg in legs],
        leg_v=[lg[1] for lg in legs],
        leg_u=[lg[2] for lg in legs],
        arm_q=arm_q,
        arm_v=arm_v,
        arm_u=arm_u,
        arm_q_target=arm_target,
        foot_bodies=feet,
        torso_body=torso,
        non_foot_bodies=non_foot,
        implicit_legs=np.array([j in params.implicit_damping for j in LEG_JOINTS]),
        actuated_q=np.array([a.joint().position_start() for a in actuators], dtype=int),
        actuated_v=np.array([a.joint().velocity_start() for a in actuators], dtype=int),
    )


def standing_leg_angles(torso_height: float) -> np.ndarray:
    """Leg joint angles [rad] that put a flat foot under the hip with the torso origin
    at `torso_height` [m] (hip roll/yaw/toe roll zero; planar two-link IK)."""
    d = torso_height - HIP_PITCH_BELOW_TORSO - ANKLE_TO_SOLE
    reach = THIGH_LENGTH + SHIN_LENGTH
    if not 0.3 * reach < d < reach:
        raise ValueError(f"torso height {torso_height} m is out of the legs' reach")
    # equal links: knee = 2 acos(d / reach), thigh forward by half of it
    knee = 2.0 * math.acos(d / reach)
    return np.array([0.0, 0.0, -0.5 * knee, knee, -0.5 * knee, 0.0])


def standing_state(
    model: DigitModel,
    torso_height: float | None = None,
    pose: tuple[float, float, float] = (0.0, 0.0, 0.0),
) -> np.ndarray:
    """(q, v) standing still: feet flat under the hips, torso upright at `pose`
    (x [m], y [m], yaw [rad]) and `torso_height` [m] (default `params.torso_height`)."""
    h = model.params.torso_height if torso_height is None else torso_height
    plant = model.plant
    x, y, yaw = (float(v) for v in pose)
    q = np.zeros(plant.num_positions())
    q[model.base_q[:4]] = [math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)]
    q[model.base_q[4:]] = [x, y, h]
    legs = standing_leg_angles(h)
    for i in range(2):
        q[model.leg_q[i]] = legs
    if len(model.arm_q):
        q[model.arm_q] = model.arm_q_target
    return np.concatenate([q, np.zeros(plant.num_velocities())])
