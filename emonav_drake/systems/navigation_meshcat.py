"""`NavigationMeshcatVisualizer`: the navigation world drawn in Drake's Meshcat.

Input ports:
    robot_state (4): (x, y, θ, v) of the robot CoM, world frame [m, rad, m/s].
    crowd (abstract `CrowdSnapshot`).
    scan (K): LiDAR ranges [m] (drawn as rays when `show_rays`; leave unconnected
        otherwise).

Draws, at `publish_period` (default 0.1 s): the robot (blue column with a heading
marker), pedestrians coloured by emotion (happy green, neutral amber, negative red) with
their discomfort rings, static discs (grey) with their d_static rings, the goal (green
pad) and optionally every 10th LiDAR ray. When the Meshcat is recording
(`Meshcat.StartRecording`), poses and emotion changes are recorded at the simulation
time, so `PublishRecording` + `StaticHtml` replay the run (rays are live only).
"""

from __future__ import annotations

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.geometry import Cylinder, Meshcat, Rgba, Sphere
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.systems.framework import Context, EventStatus, LeafSystem

from emonav_drake.core.scenario import Scenario
from emonav_drake.params import EMOTION_NAMES, EmoNavConfig

EMOTION_RGBA = (
    Rgba(0.20, 0.75, 0.30, 1.0),
    Rgba(0.95, 0.70, 0.15, 1.0),
    Rgba(0.85, 0.15, 0.15, 1.0),
)
_PREFIX = "/emonav"


class NavigationMeshcatVisualizer(LeafSystem):
    """Draws robot, crowd, obstacles, goal and LiDAR rays in Meshcat.

    Args:
        meshcat: the Meshcat instance to draw in.
        scenario: the episode (static discs, goal, number of pedestrians).
        config: radii and discomfort distances.
        show_rays: draw the LiDAR rays (needs the `scan` input connected).
        publish_period: drawing period [s].
        draw_robot: draw the LIP robot's column (off when the full-order Digit is drawn).
    """

    def __init__(
        self,
        meshcat: Meshcat,
        scenario: Scenario,
        config: EmoNavConfig,
        show_rays: bool = False,
        publish_period: float = 0.1,
        draw_robot: bool = True,
    ) -> None:
        super().__init__()
        self._meshcat = meshcat
        self._config = config
        self._show_rays = show_rays
        self._draw_robot = draw_robot
        self._num_peds = len(scenario.pedestrians)
        self._robot = self.DeclareVectorInputPort("robot_state", 4)
        self._crowd = self.DeclareAbstractInputPort("crowd", AbstractValue.Make(object()))
        self._scan = self.DeclareVectorInputPort("scan", config.lidar.num_beams)
        self._draw_static_scene(scenario)
        self.DeclarePeriodicPublishEvent(publish_period, 0.0, self._publish)
        self.DeclareForcedPublishEvent(self._publish)

    def _draw_static_scene(self, scenario: Scenario) -> None:
        m, c = self._meshcat, self._config
        m.Delete(_PREFIX)
        if self._draw_robot:
            m.SetObject(
                f"{_PREFIX}/robot/body", Cylinder(c.robot.radius, 1.0), Rgba(0.25, 0.45, 0.85, 1.0)
            )
            m.SetTransform(f"{_PREFIX}/robot/body", RigidTransform([0, 0, 0.5]))
            m.SetObject(f"{_PREFIX}/robot/nose", Sphere(0.08), Rgba(0.1, 0.1, 0.1, 1.0))
            m.SetTransform(f"{_PREFIX}/robot/nose", RigidTransform([c.robot.radius, 0, 0.9]))
            x0, y0 = scenario.robot_start
            m.SetTransform(
                f"{_PREFIX}/robot",
                RigidTransform(RotationMatrix.MakeZRotation(scenario.robot_heading), [x0, y0, 0.0]),
            )
        goal = scenario.robot_goal
        m.SetObject(f"{_PREFIX}/goal", Cylinder(0.2, 0.01), Rgba(0.1, 0.8, 0.2, 0.6))
        m.SetTransform(f"{_PREFIX}/goal", RigidTransform([goal[0], goal[1], 0.005]))
        for i, o in enumerate(scenario.obstacles):
            path = f"{_PREFIX}/static/{i}"
            m.SetObject(f"{path}/disc", Cylinder(o.radius, 0.8), Rgba(0.5, 0.5, 0.5, 1.0))
            m.SetTransform(f"{path}/disc", RigidTransform([0, 0, 0.4]))
            m.SetObject(
                f"{path}/ring",
                Cylinder(o.radius + c.reward.static_discomfort, 0.01),
                Rgba(0.5, 0.5, 0.5, 0.25),
            )
            m.SetTransform(path, RigidTransform([o.center[0], o.center[1], 0.0]))
        dist = c.reward.emotion_distances()
        for i, ped in enumerate(scenario.pedestrians):
            path = f"{_PREFIX}/pedestrians/{i}"
            # The scene as it starts (what a replay shows before it plays): the initial
            # emotion's colour and only its discomfort ring; `_publish` animates changes.
            first = EMOTION_NAMES.index(ped.emotion)
            m.SetObject(
                f"{path}/body", Cylinder(c.crowd.pedestrian_radius, 1.7), EMOTION_RGBA[first]
            )
            m.SetTransform(f"{path}/body", RigidTransform([0, 0, 0.85]))
            m.SetTransform(path, RigidTransform([ped.start[0], ped.start[1], 0.0]))
            for e in range(3):
                rgba = EMOTION_RGBA[e]
                m.SetObject(
                    f"{path}/ring{e}",
                    Cylinder(c.crowd.pedestrian_radius + dist[e], 0.01),
                    Rgba(rgba.r(), rgba.g(), rgba.b(), 0.3),
                )
                m.SetProperty(f"{path}/ring{e}", "visible", e == first)

    def _publish(self, context: Context) -> EventStatus:
        m, t = self._meshcat, context.get_time()
        x, y, th, _ = self._robot.Eval(context)
        if self._draw_robot:
            m.SetTransform(
                f"{_PREFIX}/robot", RigidTransform(RotationMatrix.MakeZRotation(th), [x, y, 0.0]), t
            )
        crowd = self._crowd.Eval(context)
        for i in range(self._num_peds):
            path = f"{_PREFIX}/pedestrians/{i}"
            px, py = crowd.positions[i]
            m.SetTransform(path, RigidTransform([px, py, 0.0]), t)
            e = int(crowd.emotions[i])
            m.SetProperty(f"{path}/body", "color", list(EMOTION_RGBA[e].rgba), t)
            for k in range(3):
                m.SetProperty(f"{path}/ring{k}", "visible", k == e, t)
        if self._show_rays and self._scan.HasValue(context):
            ranges = self._scan.Eval(context)[::10]
            k = len(self._scan.Eval(context))
            ang = th + (np.arange(0, k, 10) - (k - 1) / 2) * (2 * np.pi / k)
            start = np.tile(np.array([[x], [y], [0.3]]), (1, len(ranges)))
            end = np.vstack(
                [x + ranges * np.cos(ang), y + ranges * np.sin(ang), np.full(len(ranges), 0.3)]
            )
            m.SetLineSegments(f"{_PREFIX}/rays", start, end, 1.0, Rgba(0.9, 0.2, 0.2, 0.5))
        return EventStatus.Succeeded()


def set_overview_camera(meshcat: Meshcat, config: EmoNavConfig) -> None:
    """Frame the whole arena from above at an angle (start, goal and the crowd's circle),
    instead of Meshcat's default camera that sits inside the arena. Set before a
    recording, a replay's HTML opens with this view."""
    start = np.asarray(config.robot.start, dtype=float)
    goal = np.asarray(config.robot.goal, dtype=float)
    centre = 0.5 * (start + goal)
    span = max(float(np.linalg.norm(goal - start)), 2.0 * config.crowd.circle_radius_max)
    meshcat.SetCameraPose(
        [centre[0] - 0.05 * span, centre[1] - 0.85 * span, 0.6 * span],
        [centre[0], centre[1], 0.0],
    )
