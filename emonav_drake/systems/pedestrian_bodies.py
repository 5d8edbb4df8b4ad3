"""`PedestrianBodies`: the crowd as geometry a camera can see — bodies, heads and faces.

Each pedestrian of the scenario is registered with a `SceneGraph` as a body (cylinder),
a head (box) and three face quads, one per emotion, textured with that emotion's face
(`emonav_drake/data/faces/`, their sources and licences in its README). Only the face of
the pedestrian's current (true) emotion is on its head; the other two are parked far
below the ground, so a pedestrian whose emotion changes changes its face at once. Every
pedestrian faces its walking direction (`crowd.pedestrian_pose.facing_headings`; when it
stands, the direction from its start to its goal). The static discs of the scenario are
anchored cylinders, its walls anchored boxes 2.2 m high. All geometry has the
perception role (what `RgbdSensor` renders); heads and faces also the illustration role
(what Meshcat draws: the navigation visualiser already draws the bodies, coloured by
emotion, the discs and the walls).

Input port:
    crowd (abstract `CrowdSnapshot`): the simulated crowd — positions [m] and velocities
        [m/s] in the world frame, true emotion codes (HAPPY 0, NEUTRAL 1, NEGATIVE 2).
Output port:
    geometry_pose (abstract `FramePoseVector`): X_WP of every pedestrian frame and X_WF
        of every face frame, for the scene graph's source pose input.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.geometry import (
    Box,
    Cylinder,
    FramePoseVector,
    GeometryFrame,
    GeometryInstance,
    IllustrationProperties,
    Mesh,
    PerceptionProperties,
    Rgba,
    SceneGraph,
)
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.systems.framework import Context, DiagramBuilder, LeafSystem, OutputPort

from emonav_drake.crowd.pedestrian_pose import (
    HIDDEN_DEPTH,
    PedestrianBody,
    facing_headings,
    start_to_goal_headings,
)
from emonav_drake.palette import (
    CAMERA_DISC_RGB,
    PEDESTRIAN_CLOTHES_RGB,
    PEDESTRIAN_HAIR_RGB,
)
from emonav_drake.params import EMOTION_NAMES
from emonav_drake.scenarios.scenario import Scenario

FACES_DIR = Path(__file__).resolve().parent.parent / "data" / "faces"
BODY_RGBA = Rgba(*PEDESTRIAN_CLOTHES_RGB)
HEAD_RGBA = Rgba(*PEDESTRIAN_HAIR_RGB)  # also the back of the head
DISC_RGBA = Rgba(*CAMERA_DISC_RGB)  # the static discs' and the walls' colour
WALL_HEIGHT = 2.2  # [m]: taller than anyone, so a camera never sees over a wall
WALL_THICKNESS = 0.06  # [m] as rendered (the simulation's walls have none)
DISC_HEIGHT = 1.0  # height of a static disc's cylinder [m]


def face_mesh_path(emotion: str) -> Path:
    """The unit face quad (OBJ with its material and texture) of an emotion name."""
    path = FACES_DIR / f"face_{emotion}.obj"
    if not path.is_file():
        raise FileNotFoundError(f"face mesh {path} is missing: the package is incomplete")
    return path


def _roles(
    scene_graph: SceneGraph, source, geometry, rgba: Rgba | None, illustrate: bool = True
) -> None:
    """The perception role (and the illustration role when `illustrate`); a textured mesh
    gets no diffuse colour."""
    perception, illustration = PerceptionProperties(), IllustrationProperties()
    if rgba is not None:
        perception.AddProperty("phong", "diffuse", rgba)
        illustration.AddProperty("phong", "diffuse", rgba)
    scene_graph.AssignRole(source, geometry, perception)
    if illustrate:
        scene_graph.AssignRole(source, geometry, illustration)


class PedestrianBodies(LeafSystem):
    """Registers the scenario's pedestrians and discs with `scene_graph`; poses them.

    Args:
        scene_graph: the scene graph the camera renders (not yet in a built diagram).
        scenario: the pedestrians (their number, start → goal) and the static discs.
        body: the rendered sizes.
    """

    def __init__(
        self,
        scene_graph: SceneGraph,
        scenario: Scenario,
        body: PedestrianBody | None = None,
    ) -> None:
        super().__init__()
        self.body = body or PedestrianBody()
        b = self.body
        self.source_id = scene_graph.RegisterSource("pedestrians")
        src = self.source_id
        peds = scenario.pedestrians
        self._fallback = start_to_goal_headings(
            np.array([p.start for p in peds]).reshape(-1, 2),
            np.array([p.goal for p in peds]).reshape(-1, 2),
        )
        self.pedestrian_frames, self.face_frames = [], []
        scale = np.array([1.0, b.face_width, b.face_height])
        for i in range(len(peds)):
            frame = scene_graph.RegisterFrame(src, GeometryFrame(f"pedestrian_{i}"))
            self.pedestrian_frames.append(frame)
            for name, shape, z, rgba in (
                ("body", Cylinder(b.body_radius, b.body_height), b.body_height / 2, BODY_RGBA),
                (
                    "head",
                    Box(b.head_depth, b.head_width, b.head_height),
                    b.head_center_height,
                    HEAD_RGBA,
                ),
            ):
                g = scene_graph.RegisterGeometry(
                    src, frame, GeometryInstance(RigidTransform([0, 0, z]), shape, f"{name}_{i}")
                )
                _roles(scene_graph, src, g, rgba, illustrate=name == "head")
            faces = []
            for emotion in EMOTION_NAMES:
                f = scene_graph.RegisterFrame(src, GeometryFrame(f"face_{emotion}_{i}"))
                g = scene_graph.RegisterGeometry(
                    src,
                    f,
                    GeometryInstance(
                        RigidTransform(),
                        Mesh(face_mesh_path(emotion), scale),
                        f"face_{emotion}_{i}",
                    ),
                )
                _roles(scene_graph, src, g, None)
                faces.append(f)
            self.face_frames.append(faces)
        for j, disc in enumerate(scenario.obstacles):
            g = scene_graph.RegisterAnchoredGeometry(
                src,
                GeometryInstance(
                    RigidTransform([*disc.center, DISC_HEIGHT / 2]),
                    Cylinder(disc.radius, DISC_HEIGHT),
                    f"disc_{j}",
                ),
            )
            _roles(scene_graph, src, g, DISC_RGBA, illustrate=False)
        for j, wall in enumerate(scenario.walls):  # a wall hides what is behind it
            (ax, ay), (bx, by) = wall.start, wall.end
            yaw = float(np.arctan2(by - ay, bx - ax))
            g = scene_graph.RegisterAnchoredGeometry(
                src,
                GeometryInstance(
                    RigidTransform(
                        RotationMatrix.MakeZRotation(yaw),
                        [(ax + bx) / 2, (ay + by) / 2, WALL_HEIGHT / 2],
                    ),
                    Box(float(np.hypot(bx - ax, by - ay)), WALL_THICKNESS, WALL_HEIGHT),
                    f"wall_{j}",
                ),
            )
            _roles(scene_graph, src, g, DISC_RGBA, illustrate=False)
        self._crowd_in = self.DeclareAbstractInputPort("crowd", AbstractValue.Make(object()))
        self.DeclareAbstractOutputPort(
            "geometry_pose", lambda: AbstractValue.Make(FramePoseVector()), self._calc_poses
        )

    def pedestrian_poses(self, context: Context) -> list[RigidTransform]:
        """X_WP of each pedestrian now: at its position, facing its walking direction."""
        crowd = self._crowd_in.Eval(context)
        heading = facing_headings(crowd.velocities, self._fallback)
        return [
            RigidTransform(RotationMatrix.MakeZRotation(float(h)), [float(x), float(y), 0.0])
            for (x, y), h in zip(np.asarray(crowd.positions).reshape(-1, 2), heading, strict=True)
        ]

    def _calc_poses(self, context: Context, output: AbstractValue) -> None:
        crowd = self._crowd_in.Eval(context)
        poses = FramePoseVector()
        X_PF = RigidTransform(self.body.face_offset)
        hidden = RigidTransform([0.0, 0.0, -HIDDEN_DEPTH])
        for i, X_WP in enumerate(self.pedestrian_poses(context)):
            poses.set_value(self.pedestrian_frames[i], X_WP)
            shown = int(crowd.emotions[i])
            for code, frame in enumerate(self.face_frames[i]):
                poses.set_value(frame, X_WP @ X_PF if code == shown else hidden)
        output.set_value(poses)


def AddPedestrianBodies(
    builder: DiagramBuilder,
    scene_graph: SceneGraph,
    scenario: Scenario,
    crowd: OutputPort,
    body: PedestrianBody | None = None,
) -> PedestrianBodies:
    """Add `PedestrianBodies` fed by `crowd` (the true crowd) and wire its poses."""
    system = builder.AddNamedSystem(
        "pedestrian_bodies", PedestrianBodies(scene_graph, scenario, body)
    )
    builder.Connect(crowd, system.GetInputPort("crowd"))
    builder.Connect(
        system.GetOutputPort("geometry_pose"), scene_graph.get_source_pose_port(system.source_id)
    )
    return system
