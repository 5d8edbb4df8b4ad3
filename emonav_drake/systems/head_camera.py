"""The robot's head camera: a colour `RgbdSensor` carried by the robot.

The camera renders the perception geometry of a `SceneGraph` (the crowd's bodies and
faces, `systems/pedestrian_bodies.py`) with Drake's VTK renderer. Its pose follows a
*mount*: a body pose X_WB [m, rad] in the world frame — the LIP robot's pose
(`RobotMountPose`: (x, y, 0) turned by the heading θ) or Digit's torso (`BodyPoseSelector`
on the plant's body poses, so the camera sways with the torso) — and a fixed offset p_BC
[m] in the mount frame B (x forward, y left, z up). The optical axis is B's x axis; the
image's right is B's −y and its down is B's −z (Drake's camera frame: +z forward,
+x right, +y down).

Its intrinsics are `HeadCameraParams` (`camera_info`): by default the paper's ZED stereo
camera in its HD720 mode (ZED 2 HD720: 1280 × 720 px, 70° vertical field of view, ≈ 102°
horizontal as a pinhole), or the earlier 640 × 480, 45° camera (`HeadCameraParams.vga()`).

The sensor renders only when its `color_image` output is evaluated: wired to the
`EmotionClassifier`, whose periodic update reads it, it renders once per classification
(0.5 Hz).
"""

from __future__ import annotations

import dataclasses as dc

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.geometry import (
    ClippingRange,
    ColorRenderCamera,
    DepthRange,
    DepthRenderCamera,
    FramePoseVector,
    GeometryFrame,
    GeometryInstance,
    HalfSpace,
    LightParameter,
    MakeRenderEngineVtk,
    PerceptionProperties,
    RenderCameraCore,
    RenderEngineVtkParams,
    Rgba,
    SceneGraph,
)
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.systems.framework import Context, DiagramBuilder, LeafSystem, OutputPort
from pydrake.systems.sensors import CameraInfo, RgbdSensor

from emonav_drake.palette import CAMERA_GROUND_RGB, CAMERA_SKY_RGB
from emonav_drake.perception.noisy_emotions import HeadCameraParams
from emonav_drake.systems.lip_robot_plant import lip_state_from_vector

RENDERER = "emonav_vtk"
GROUND_RGBA = Rgba(*CAMERA_GROUND_RGB)
SKY_RGB = CAMERA_SKY_RGB
# camera frame C (Drake: z forward, x right, y down) in the mount frame B (x fwd, z up)
R_BC = RotationMatrix(np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]]))


def camera_info(params: HeadCameraParams) -> CameraInfo:
    """The intrinsics: `width` × `height` px, vertical field of view `fov_y_deg`."""
    return CameraInfo(params.width, params.height, np.deg2rad(params.fov_y_deg))


class RobotMountPose(LeafSystem):
    """X_WB of the LIP robot: (x, y, 0) turned by its heading.

    Input port: robot_state (4): (x [m], y [m], θ [rad], v [m/s]), world frame.
    Output port: X_WB (abstract `RigidTransform`).
    """

    def __init__(self) -> None:
        super().__init__()
        self._state_in = self.DeclareVectorInputPort("robot_state", 4)
        self.DeclareAbstractOutputPort(
            "X_WB", lambda: AbstractValue.Make(RigidTransform()), self._calc
        )

    def _calc(self, context: Context, output: AbstractValue) -> None:
        s = lip_state_from_vector(self._state_in.Eval(context))
        output.set_value(RigidTransform(RotationMatrix.MakeZRotation(s.heading), [s.x, s.y, 0.0]))


class BodyPoseSelector(LeafSystem):
    """X_WB of one body from a `MultibodyPlant`'s body poses.

    Input port: body_poses (abstract list of `RigidTransform`, the plant's
        `get_body_poses_output_port`, indexed by `BodyIndex`).
    Output port: X_WB (abstract `RigidTransform`).
    """

    def __init__(self, body_index: int) -> None:
        super().__init__()
        self.body_index = int(body_index)
        self._poses_in = self.DeclareAbstractInputPort(
            "body_poses", AbstractValue.Make([RigidTransform()])
        )
        self.DeclareAbstractOutputPort(
            "X_WB", lambda: AbstractValue.Make(RigidTransform()), self._calc
        )

    def _calc(self, context: Context, output: AbstractValue) -> None:
        output.set_value(self._poses_in.Eval(context)[self.body_index])


class HeadCameraPose(LeafSystem):
    """Poses the camera's frame in a scene graph: X_WM = X_WB · [I, p_BC].

    Input port: X_WB (abstract `RigidTransform`): the mount body's pose, world frame.
    Output port: geometry_pose (abstract `FramePoseVector`): the camera mount frame M.

    Attributes: source_id, frame_id (M: B's orientation at the camera's origin).
    """

    def __init__(self, scene_graph: SceneGraph, offset: np.ndarray) -> None:
        super().__init__()
        self.source_id = scene_graph.RegisterSource("head_camera")
        self.frame_id = scene_graph.RegisterFrame(self.source_id, GeometryFrame("head_camera"))
        self._X_BM = RigidTransform(np.asarray(offset, dtype=float).reshape(3))
        self._mount_in = self.DeclareAbstractInputPort("X_WB", AbstractValue.Make(RigidTransform()))
        self.DeclareAbstractOutputPort(
            "geometry_pose", lambda: AbstractValue.Make(FramePoseVector()), self._calc
        )

    def _calc(self, context: Context, output: AbstractValue) -> None:
        poses = FramePoseVector()
        poses.set_value(self.frame_id, self._mount_in.Eval(context) @ self._X_BM)
        output.set_value(poses)


@dc.dataclass
class CameraMount:
    """Where the robot carries its camera: `pose` outputs X_WB of the mount body B
    (abstract `RigidTransform`), `offset` is the camera's origin p_BC in B [m]."""

    pose: OutputPort
    offset: np.ndarray


def lip_camera_mount(
    builder: DiagramBuilder, robot_state: OutputPort, params: HeadCameraParams
) -> CameraMount:
    """The LIP robot's camera: on its pose, `params.lip_height` above the ground."""
    mount = builder.AddNamedSystem("camera_mount", RobotMountPose())
    builder.Connect(robot_state, mount.GetInputPort("robot_state"))
    return CameraMount(mount.GetOutputPort("X_WB"), np.array([0.0, 0.0, params.lip_height]))


def body_camera_mount(
    builder: DiagramBuilder, body_poses: OutputPort, body_index: int, params: HeadCameraParams
) -> CameraMount:
    """A camera on a plant body (Digit: the torso), at `params.digit_offset` in it."""
    mount = builder.AddNamedSystem("camera_mount", BodyPoseSelector(body_index))
    builder.Connect(body_poses, mount.GetInputPort("body_poses"))
    return CameraMount(mount.GetOutputPort("X_WB"), np.asarray(params.digit_offset, dtype=float))


@dc.dataclass
class HeadCamera:
    """The systems `AddHeadCamera` added."""

    pose: HeadCameraPose
    sensor: RgbdSensor
    info: CameraInfo

    @property
    def color_image(self) -> OutputPort:
        """The rendered colour image (`ImageRgba8U`)."""
        return self.sensor.color_image_output_port()


def AddCameraScene(builder: DiagramBuilder, name: str = "perception_scene") -> SceneGraph:
    """A scene graph for the camera: the VTK renderer and a ground plane (perception)."""
    scene_graph = builder.AddNamedSystem(name, SceneGraph())
    lights = [  # a head light (faces seen from the front are lit) and light from above
        LightParameter(type="directional", frame="camera", direction=[0, 0, 1], intensity=0.8),
        LightParameter(type="directional", frame="world", direction=[0, 0, -1], intensity=0.6),
    ]
    scene_graph.AddRenderer(
        RENDERER,
        MakeRenderEngineVtk(RenderEngineVtkParams(default_clear_color=SKY_RGB, lights=lights)),
    )
    source = scene_graph.RegisterSource("ground")
    ground = scene_graph.RegisterAnchoredGeometry(
        source, GeometryInstance(RigidTransform(), HalfSpace(), "ground")
    )
    props = PerceptionProperties()
    props.AddProperty("phong", "diffuse", GROUND_RGBA)
    scene_graph.AssignRole(source, ground, props)
    return scene_graph


def AddHeadCamera(
    builder: DiagramBuilder,
    scene_graph: SceneGraph,
    mount: OutputPort,
    offset: np.ndarray,
    params: HeadCameraParams,
) -> HeadCamera:
    """Add the camera frame (posed from `mount`, X_WB, at `offset` p_BC [m]) and a colour
    `RgbdSensor` on it that renders `scene_graph` (which needs `AddCameraScene`'s
    renderer)."""
    pose = builder.AddNamedSystem("head_camera_pose", HeadCameraPose(scene_graph, offset))
    builder.Connect(mount, pose.GetInputPort("X_WB"))
    builder.Connect(
        pose.GetOutputPort("geometry_pose"), scene_graph.get_source_pose_port(pose.source_id)
    )
    info = camera_info(params)
    core = RenderCameraCore(
        RENDERER, info, ClippingRange(params.near, params.far), RigidTransform()
    )
    depth = DepthRenderCamera(core, DepthRange(params.near * 1.01, params.far * 0.99))
    sensor = builder.AddNamedSystem(
        "head_camera",
        RgbdSensor(pose.frame_id, RigidTransform(R_BC), ColorRenderCamera(core, False), depth),
    )
    builder.Connect(scene_graph.get_query_output_port(), sensor.query_object_input_port())
    return HeadCamera(pose, sensor, info)
