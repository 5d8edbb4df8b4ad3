"""Generate `digit.urdf`: this project's simplified Digit (docs/facts.md, docs/walking.md).

Run `python -m emonav_drake.models.digit.make_digit_urdf` to rewrite the URDF next to
this file. The model is an open chain authored from published facts, not a copy of any
vendor file:

* floating torso (15.0 kg) with the hips at (−0.001, ±0.091, 0) and the shoulders at
  (−0.001, ±0.12, 0.40) from the torso origin;
* per leg hip roll (x), hip yaw (z), hip pitch (y), knee (y), toe pitch (y), toe roll (x).
  Digit's shin and tarsus are fused: on the robot the tarsus is tied to the knee by a rod
  (tarsus ≈ −knee), so the ankle moves on a circle about the knee while the tarsus stays
  parallel to the hip-pitch link. The equivalent open chain puts the hip-pitch link's
  0.12 m offset and the tarsus (0.408 m) into a 0.45 m "thigh" and the shin (0.435 m,
  rounded to 0.45 m) below the knee. The toe motors drive toe pitch/roll directly
  (= ankle actuation). Link masses follow Digit's (hip-pitch link 6.24 kg, leg 12.0 kg);
* per arm shoulder roll (x), shoulder pitch (y), shoulder yaw (z), elbow (y), 3.6 kg;
* Digit's joint-side effort limits and gear ratios; rotor inertia is given motor-side
  (Drake multiplies it by gear² into the reflected inertia);
* four sole contact spheres (1 cm) per foot; capsules/boxes on the other links only to
  detect falls (self-collision filtered); simple visual geometry.
"""

from __future__ import annotations

from pathlib import Path

HERE = Path(__file__).resolve().parent
URDF_PATH = HERE / "digit.urdf"

THIGH_LENGTH = 0.45  # hip pitch axis → knee axis [m]
SHIN_LENGTH = 0.45  # knee axis → toe-pitch (ankle) axis [m]
ANKLE_TO_SOLE = 0.05  # toe-pitch axis → sole plane [m]
SOLE_SPHERE_RADIUS = 0.01  # [m]
# Sole contact points in the foot frame (x forward, y left), at the sole plane.
SOLE_POINTS = [(0.11, 0.035), (0.11, -0.035), (-0.07, 0.035), (-0.07, -0.035)]
FRICTION = 1.0

# name: (axis, lower, upper, effort [N·m], gear ratio, reflected inertia [kg·m²])
# Reflected inertias 0.036–0.173 kg·m²: our choice for Digit-like actuators (docs/facts.md).
LEG_JOINTS = {
    "hip_roll": ("1 0 0", -0.5, 0.5, 126.7, 80.0, 0.173),
    "hip_yaw": ("0 0 1", -0.8, 0.8, 79.2, 50.0, 0.036),
    "hip_pitch": ("0 1 0", -1.4, 0.9, 216.9, 16.0, 0.173),
    "knee": ("0 1 0", 0.05, 2.4, 231.3, 16.0, 0.173),
    "toe_pitch": ("0 1 0", -0.9, 0.9, 42.0, 50.0, 0.036),
    "toe_roll": ("1 0 0", -0.5, 0.5, 42.0, 50.0, 0.036),
}
ARM_JOINTS = {
    "shoulder_roll": ("1 0 0", -1.3, 1.3, 126.7, 80.0, 0.173),
    "shoulder_pitch": ("0 1 0", -1.0, 1.0, 126.7, 80.0, 0.173),
    "shoulder_yaw": ("0 0 1", -1.7, 1.7, 79.2, 50.0, 0.036),
    "elbow": ("0 1 0", -1.3, 1.3, 126.7, 80.0, 0.173),
}
JOINT_DAMPING = 0.5  # [N·m·s/rad]

GREY = "0.55 0.57 0.6 1"
DARK = "0.15 0.16 0.18 1"
ORANGE = "0.95 0.55 0.15 1"


def _box_inertia(m: float, sx: float, sy: float, sz: float) -> tuple[float, float, float]:
    return (
        m * (sy**2 + sz**2) / 12,
        m * (sx**2 + sz**2) / 12,
        m * (sx**2 + sy**2) / 12,
    )


def _inertial(m: float, com: tuple[float, float, float], dims: tuple[float, float, float]) -> str:
    ixx, iyy, izz = _box_inertia(m, *dims)
    return (
        f'    <inertial><origin xyz="{com[0]} {com[1]} {com[2]}"/><mass value="{m}"/>\n'
        f'      <inertia ixx="{ixx:.6g}" iyy="{iyy:.6g}" izz="{izz:.6g}" ixy="0" ixz="0" '
        f'iyz="0"/></inertial>\n'
    )


def _visual(geom: str, xyz: str = "0 0 0", rpy: str = "0 0 0", color: str = GREY) -> str:
    return (
        f'    <visual><origin xyz="{xyz}" rpy="{rpy}"/><geometry>{geom}</geometry>'
        f'<material><color rgba="{color}"/></material></visual>\n'
    )


def _collision(name: str, geom: str, xyz: str = "0 0 0", rpy: str = "0 0 0") -> str:
    return (
        f'    <collision name="{name}"><origin xyz="{xyz}" rpy="{rpy}"/>'
        f"<geometry>{geom}</geometry>\n"
        f'      <drake:proximity_properties><drake:mu_dynamic value="{FRICTION}"/>'
        f'<drake:mu_static value="{FRICTION}"/></drake:proximity_properties></collision>\n'
    )


def _link(name: str, body: str) -> str:
    return f'  <link name="{name}">\n{body}  </link>\n'


def _joint(name: str, parent: str, child: str, xyz: str, spec: tuple) -> str:
    axis, lo, hi, effort, gear, reflected = spec
    rotor = reflected / gear**2
    return (
        f'  <joint name="{name}" type="revolute">\n'
        f'    <parent link="{parent}"/><child link="{child}"/>\n'
        f'    <origin xyz="{xyz}" rpy="0 0 0"/><axis xyz="{axis}"/>\n'
        f'    <limit lower="{lo}" upper="{hi}" effort="{effort}" velocity="30"/>\n'
        f'    <dynamics damping="{JOINT_DAMPING}"/>\n'
        f"  </joint>\n"
        f'  <transmission name="{name}_transmission">\n'
        f"    <type>transmission_interface/SimpleTransmission</type>\n"
        f'    <joint name="{name}"><hardwareInterface>EffortJointInterface'
        f"</hardwareInterface></joint>\n"
        f'    <actuator name="{name}_motor"><mechanicalReduction>1</mechanicalReduction>\n'
        f'      <drake:rotor_inertia value="{rotor:.6g}"/>'
        f'<drake:gear_ratio value="{gear}"/></actuator>\n'
        f"  </transmission>\n"
    )


def _capsule(r: float, length: float) -> str:
    return f'<drake:capsule radius="{r}" length="{length}"/>'


def _leg(side: str, sign: float) -> tuple[str, list[str]]:
    """One leg's links and joints, from the torso down (`sign` +1 left, −1 right), and its
    link names (for the self-collision filter)."""
    s = side
    out = _hip(s, sign) + _thigh_and_shin(s) + _ankle_and_foot(s)
    links = [
        f"{s}_hip_roll_link",
        f"{s}_hip_yaw_link",
        f"{s}_hip_pitch_link",
        f"{s}_shin",
        f"{s}_toe_pitch_link",
        f"{s}_foot",
    ]
    return "".join(out), links


def _hip(s: str, sign: float) -> list[str]:
    """The hip roll and hip yaw links (motor housings beside the pelvis) and their joints."""
    out = []
    # hip roll link: motor housing beside the pelvis
    out.append(
        _link(
            f"{s}_hip_roll_link",
            _inertial(0.915, (0.0, 0.0, -0.03), (0.1, 0.08, 0.1))
            + _visual('<cylinder radius="0.045" length="0.1"/>', "0 0 -0.03", "0 1.5708 0", DARK),
        )
    )
    out.append(
        _joint(
            f"{s}_hip_roll",
            "torso",
            f"{s}_hip_roll_link",
            f"-0.001 {sign * 0.091} 0",
            LEG_JOINTS["hip_roll"],
        )
    )
    out.append(
        _link(
            f"{s}_hip_yaw_link",
            _inertial(0.818, (0.0, 0.0, -0.03), (0.08, 0.08, 0.08))
            + _visual('<cylinder radius="0.04" length="0.07"/>', "0 0 -0.035", "0 0 0", GREY),
        )
    )
    out.append(
        _joint(
            f"{s}_hip_yaw",
            f"{s}_hip_roll_link",
            f"{s}_hip_yaw_link",
            "0 0 -0.067",
            LEG_JOINTS["hip_yaw"],
        )
    )
    return out


def _thigh_and_shin(s: str) -> list[str]:
    """The hip pitch link ("thigh") with the hip pitch joint, the fused shin and tarsus
    with the knee."""
    out = []
    # hip pitch link ("thigh"): the heavy link with the knee motor near the hip
    out.append(
        _link(
            f"{s}_hip_pitch_link",
            _inertial(6.244, (0.02, 0.0, -0.1), (0.12, 0.1, 0.3))
            + _visual('<box size="0.12 0.1 0.2"/>', "0.02 0 -0.08", "0 0 0", ORANGE)
            + _visual(
                f'<cylinder radius="0.035" length="{THIGH_LENGTH - 0.1}"/>',
                f"0 0 {-THIGH_LENGTH / 2}",
                "0 0 0",
                GREY,
            )
            + _collision(f"{s}_thigh_collision", _capsule(0.04, 0.25), f"0 0 {-THIGH_LENGTH / 2}"),
        )
    )
    out.append(
        _joint(
            f"{s}_hip_pitch",
            f"{s}_hip_yaw_link",
            f"{s}_hip_pitch_link",
            "0 0 -0.068",
            LEG_JOINTS["hip_pitch"],
        )
    )
    # shin + tarsus fused
    out.append(
        _link(
            f"{s}_shin",
            _inertial(3.444, (0.0, 0.0, -0.17), (0.06, 0.06, 0.4))
            + _visual(
                f'<cylinder radius="0.03" length="{SHIN_LENGTH}"/>',
                f"0 0 {-SHIN_LENGTH / 2}",
                "0 0 0",
                DARK,
            )
            + _visual('<sphere radius="0.045"/>', "0 0 0", "0 0 0", ORANGE)
            + _collision(f"{s}_shin_collision", _capsule(0.035, 0.3), f"0 0 {-SHIN_LENGTH / 2}"),
        )
    )
    out.append(
        _joint(
            f"{s}_knee",
            f"{s}_hip_pitch_link",
            f"{s}_shin",
            f"0 0 {-THIGH_LENGTH}",
            LEG_JOINTS["knee"],
        )
    )
    return out


def _ankle_and_foot(s: str) -> list[str]:
    """The toe pitch link (ankle) with its joint, the foot with its sole contact spheres
    and the toe roll joint."""
    out = []
    out.append(
        _link(
            f"{s}_toe_pitch_link",
            _inertial(0.043, (0, 0, 0), (0.03, 0.03, 0.03))
            + _visual('<sphere radius="0.025"/>', color=GREY),
        )
    )
    out.append(
        _joint(
            f"{s}_toe_pitch",
            f"{s}_shin",
            f"{s}_toe_pitch_link",
            f"0 0 {-SHIN_LENGTH}",
            LEG_JOINTS["toe_pitch"],
        )
    )
    foot = _inertial(0.531, (0.02, 0.0, -0.035), (0.2, 0.08, 0.03))
    foot += _visual('<box size="0.22 0.08 0.02"/>', f"0.02 0 {-ANKLE_TO_SOLE + 0.02}", color=DARK)
    foot += _visual('<box size="0.04 0.03 0.04"/>', f"0 0 {-ANKLE_TO_SOLE / 2 + 0.005}", color=GREY)
    z = -ANKLE_TO_SOLE + SOLE_SPHERE_RADIUS
    for i, (px, py) in enumerate(SOLE_POINTS):
        foot += _collision(
            f"{s}_sole_{i}", f'<sphere radius="{SOLE_SPHERE_RADIUS}"/>', f"{px} {py} {z}"
        )
    out.append(_link(f"{s}_foot", foot))
    out.append(
        _joint(
            f"{s}_toe_roll",
            f"{s}_toe_pitch_link",
            f"{s}_foot",
            "0 0 0",
            LEG_JOINTS["toe_roll"],
        )
    )
    return out


def _arm(side: str, sign: float) -> tuple[str, list[str]]:
    s = side
    out = []
    out.append(
        _link(
            f"{s}_shoulder_roll_link",
            _inertial(0.535, (0, sign * 0.03, 0), (0.07, 0.07, 0.07))
            + _visual('<sphere radius="0.045"/>', color=DARK),
        )
    )
    out.append(
        _joint(
            f"{s}_shoulder_roll",
            "torso",
            f"{s}_shoulder_roll_link",
            f"-0.001 {sign * 0.12} 0.40",
            ARM_JOINTS["shoulder_roll"],
        )
    )
    out.append(
        _link(
            f"{s}_shoulder_pitch_link",
            _inertial(1.44, (0, 0, -0.08), (0.07, 0.07, 0.16))
            + _visual('<cylinder radius="0.035" length="0.16"/>', "0 0 -0.08", color=GREY),
        )
    )
    out.append(
        _joint(
            f"{s}_shoulder_pitch",
            f"{s}_shoulder_roll_link",
            f"{s}_shoulder_pitch_link",
            f"0 {sign * 0.06} 0",
            ARM_JOINTS["shoulder_pitch"],
        )
    )
    out.append(
        _link(
            f"{s}_shoulder_yaw_link",
            _inertial(1.065, (0, 0, -0.1), (0.06, 0.06, 0.2))
            + _visual('<cylinder radius="0.03" length="0.14"/>', "0 0 -0.09", color=ORANGE),
        )
    )
    out.append(
        _joint(
            f"{s}_shoulder_yaw",
            f"{s}_shoulder_pitch_link",
            f"{s}_shoulder_yaw_link",
            "0 0 -0.16",
            ARM_JOINTS["shoulder_yaw"],
        )
    )
    out.append(
        _link(
            f"{s}_elbow_link",
            _inertial(0.55, (0, 0, -0.12), (0.05, 0.05, 0.24))
            + _visual('<cylinder radius="0.025" length="0.24"/>', "0 0 -0.12", color=DARK)
            + _collision(f"{s}_forearm_collision", _capsule(0.03, 0.2), "0 0 -0.12"),
        )
    )
    out.append(
        _joint(
            f"{s}_elbow",
            f"{s}_shoulder_yaw_link",
            f"{s}_elbow_link",
            "0 0 -0.16",
            ARM_JOINTS["elbow"],
        )
    )
    links = [
        f"{s}_shoulder_roll_link",
        f"{s}_shoulder_pitch_link",
        f"{s}_shoulder_yaw_link",
        f"{s}_elbow_link",
    ]
    return "".join(out), links


def make_urdf() -> str:
    """The URDF text of the simplified Digit."""
    torso = _inertial(15.028, (0.0, 0.0, 0.14), (0.2, 0.32, 0.45))
    torso += _visual('<box size="0.2 0.3 0.42"/>', "-0.01 0 0.2", color=GREY)
    torso += _visual('<box size="0.16 0.26 0.1"/>', "-0.01 0 0.02", color=DARK)
    torso += _visual('<cylinder radius="0.07" length="0.08"/>', "0.0 0 0.46", color=DARK)
    torso += _visual('<box size="0.02 0.22 0.06"/>', "0.095 0 0.36", color=ORANGE)
    torso += _collision("torso_collision", '<box size="0.2 0.3 0.5"/>', "-0.01 0 0.2")
    parts = [_link("torso", torso)]
    members = ["torso"]
    for side, sign in (("left", 1.0), ("right", -1.0)):
        text, links = _leg(side, sign)
        parts.append(text)
        members += links
        text, links = _arm(side, sign)
        parts.append(text)
        members += links
    # Robot-robot contact is never wanted: only the ground touches the robot.
    group = '  <drake:collision_filter_group name="digit_self">\n'
    group += "".join(f'    <drake:member link="{m}"/>\n' for m in members)
    group += '    <drake:ignored_collision_filter_group name="digit_self"/>\n'
    group += "  </drake:collision_filter_group>\n"
    return (
        '<?xml version="1.0"?>\n'
        "<!-- Generated by make_digit_urdf.py: a simplified Digit authored by emonav_drake "
        "from published facts (docs/facts.md). Do not edit by hand. -->\n"
        '<robot name="digit" xmlns:drake="http://drake.mit.edu">\n'
        + "".join(parts)
        + group
        + "</robot>\n"
    )


def main() -> None:
    URDF_PATH.write_text(make_urdf())
    print(f"wrote {URDF_PATH}")


if __name__ == "__main__":
    main()
