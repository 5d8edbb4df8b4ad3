"""`NavigationMeshcatVisualizer`: the navigation world drawn in Drake's Meshcat.

Input ports:
    robot_state (4): (x, y, θ, v) of the robot CoM, world frame W [m, rad, m/s].
    crowd (abstract `CrowdSnapshot`): pedestrians (positions [m], emotion codes).
    scan (K): LiDAR ranges [m] (drawn as rays when `show_rays`; leave unconnected
        otherwise).
    footstep_targets (abstract `robot.walking_targets.WalkingTargets`): the full-order
        Digit's footstep planner output (swing-foot landing target and yaw, W); leave
        unconnected for the LIP robot.
    tracks (abstract `CrowdSnapshot`): the crowd as the robot tracks it from its LiDAR
        scan (`CrowdTrackerSystem.crowd`, with `perception.state_source` "lidar": what the
        state-based planners read): pedestrians' positions [m] and velocities [m/s],
        static discs' centres and radii [m]; leave unconnected when the state is the truth.
    route (abstract (K, 2) float array) and subgoal (2): the global route's points and
        its current sub-goal [m, world] (`GlobalRoutePlanner`); leave unconnected without
        the route layer.

What is drawn (all under `/emonav`, world frame W, z up), in the shared palette
(`palette.py`, as Drake colours in `navigation_meshcat_style.py`; the names of the
colours here are its roles):
    * every `publish_period` (default 0.1 s): the robot (blue column with a black heading
      marker; off when the full-order Digit is drawn by Drake's `MeshcatVisualizer`),
      the pedestrians and their discomfort rings, coloured by their emotion now (happy
      bluish green, neutral orange, negative vermillion). Each pedestrian has one body and
      one ring per emotion and only the current emotion's pair is visible: an emotion
      change is a change of the "visible" property, which a Meshcat recording animates (a
      recorded "color" property is not: three.js finds no `color` on the object and
      ignores it);
    * once per walking step t_k = kT: the robot's trail (blue, one segment from its
      position at t_{k−1} to t_k, bright for `TRAIL_RECENT_STEPS` steps, then pale) and,
      with `show_rays`, the LiDAR rays of t_k (light grey, every `RAY_STRIDE`-th beam, one
      line-segment object per step, visible from t_k to t_{k+1}) and every beam's return
      as a dark point (the scan as the sensor measured it: with a real sensor preset its
      noise, lost beams, spurious returns and the pedestrians' legs), drawn
      `HIT_LIFT` above the pedestrians' heads so the bodies do not hide it (seen from
      above it lies on the outlines the scan plane cuts);
    * with `tracks` connected (`navigation_meshcat_tracks.py`), every `publish_period`,
      beside the true crowd: each tracked pedestrian as a flat violet ring at waist height
      (`TRACK_HEIGHT`), just wider than a pedestrian, with a velocity arrow from its
      position along its velocity, as long as the distance it covers in
      `TRACK_ARROW_HORIZON` (1 s; none for a track slower than `TRACK_ARROW_MIN_SPEED`);
      each tracked static disc as a dark violet ring of its fitted radius on top of the
      disc (still tracks: a pedestrian that stands still gets one too). Tracks come and
      go: a fixed pool of `TRACK_SLOTS` pedestrian and `TRACK_STATIC_SLOTS` static slots
      is drawn once, hidden, and a slot is shown while a track is in it (a track keeps its
      slot while it lives); a replay thus shows a track appear once it is confirmed, coast
      on while its pedestrian is hidden from the LiDAR, and vanish when deleted;
    * with `route` connected, once per walking step: the route as a thin black line on
      the floor, a new line object from the step a replanned route is first seen (the
      previous one hidden then), and with `subgoal` the sub-goal as a small black sphere
      at `SUBGOAL_HEIGHT`;
    * with `footstep_targets` connected: a foot-sized marker at each planned footstep
      (left sky blue, right reddish purple), following the target while the planner
      re-plans it and pale once `FOOTSTEPS_RECENT` newer steps have started;
    * static: the static discs (grey) with their d_static rings, the walls (grey slabs
      with their d_static bands on the floor) and the goal (black: a
      dark pad ringed at the goal radius and a 2 m pole topped by a sphere, seen above
      the rays).

Recording. Every dynamic call passes the simulation time, so with
`Meshcat.StartRecording` the episode is recorded frame by frame and
`PublishRecording` + `StaticHtml` replay it: poses, emotions (visibility), trail, rays,
footsteps and tracks (their slots' visibility, poses and scales: an arrow's length, a
static ring's radius). Objects created during the episode are hidden at frame 0 and shown
from the frame they appear in. Meshcat objects persist in the server, so this visualizer
draws one episode: build a new one (or call `Meshcat.Delete`) for the next.
"""

from __future__ import annotations

import math

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.geometry import Box, Cylinder, Meshcat, Rgba, Sphere
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.perception import PointCloud
from pydrake.systems.framework import Context, EventStatus, LeafSystem

from emonav_drake.params import EMOTION_NAMES, EmoNavConfig
from emonav_drake.scenarios.scenario import Scenario
from emonav_drake.systems.navigation_meshcat_style import (
    EMOTION_RGBA,
    FOOT_RGBA,
    GOAL_RADIUS_RGBA,
    GOAL_RGBA,
    HEADING_RGBA,
    HIT_RGBA,
    PREFIX,
    RAY_RGBA,
    ROBOT_RGBA,
    START_RGBA,
    STATIC_HEIGHT,
    STATIC_RGBA,
    TRAIL_RGBA,
)
from emonav_drake.systems.navigation_meshcat_tracks import TrackDrawing

ROUTE_HEIGHT = 0.03  # [m] the global route's line, just above the floor and the bands
SUBGOAL_HEIGHT = 0.3  # [m] the sub-goal's sphere

TRAIL_RECENT_STEPS = 10  # trail segments drawn bright for this many walking steps
FOOTSTEPS_RECENT = 6  # footstep markers drawn bright until this many newer steps
RAY_STRIDE = 15  # draw every RAY_STRIDE-th LiDAR beam
HIT_POINT_SIZE = 0.05  # [m] of a drawn LiDAR return
HIT_LIFT = 0.05  # [m] the returns are drawn above the pedestrians' heads
OVERVIEW_FOV = 45.0  # vertical field of view of the overview camera [deg]
# the arena fits a horizontal field of view of this much [deg]; a replay widens the
# vertical one in windows narrower than that (`meshcat_viewing.replay_html`)
OVERVIEW_MIN_HFOV = 55.0
_GOAL_POLE = 2.0  # [m]
_START_PAD = 0.5  # [m] side of the start's square pad
_WALL_THICKNESS = 0.06  # [m] a wall as drawn (it has none in the simulation)


def _faded(rgba: Rgba, alpha: float) -> Rgba:
    return Rgba(rgba.r(), rgba.g(), rgba.b(), alpha)


class NavigationMeshcatVisualizer(LeafSystem):
    """Draws robot, crowd, obstacles, goal, trail, LiDAR rays, footsteps and LiDAR tracks in
    Meshcat (see the module docstring).

    Args:
        meshcat: the Meshcat instance to draw in.
        scenario: the episode (static discs, goal, robot start, number of pedestrians).
        config: radii, discomfort distances, step time T and goal radius.
        show_rays: draw the LiDAR rays (needs the `scan` input connected).
        publish_period: period of the pose and emotion updates [s].
        draw_robot: draw the LIP robot's column (off when the full-order Digit is drawn).
        goal_radius: radius of the goal pad [m]; default `config.episode.eval_goal_radius`.
        draw_trail: draw the robot's trail, one segment per walking step.
        pedestrian_height: height of a pedestrian's column [m] (with the camera's
            rendered heads and faces on top: their body height).
    """

    def __init__(
        self,
        meshcat: Meshcat,
        scenario: Scenario,
        config: EmoNavConfig,
        show_rays: bool = False,
        publish_period: float = 0.1,
        draw_robot: bool = True,
        goal_radius: float | None = None,
        draw_trail: bool = True,
        pedestrian_height: float = 1.7,
    ) -> None:
        super().__init__()
        self._pedestrian_height = float(pedestrian_height)
        self._meshcat = meshcat
        self._config = config
        self._show_rays = show_rays
        self._draw_robot = draw_robot
        self._draw_trail = draw_trail
        self._goal_radius = (
            config.episode.eval_goal_radius if goal_radius is None else float(goal_radius)
        )
        self._num_peds = len(scenario.pedestrians)
        self._start = np.asarray(scenario.robot_start, dtype=float)
        self._robot = self.DeclareVectorInputPort("robot_state", 4)
        self._crowd = self.DeclareAbstractInputPort("crowd", AbstractValue.Make(object()))
        self._scan = self.DeclareVectorInputPort("scan", config.lidar.num_beams)
        self._footsteps = self.DeclareAbstractInputPort(
            "footstep_targets", AbstractValue.Make(object())
        )
        self._tracks = self.DeclareAbstractInputPort("tracks", AbstractValue.Make(object()))
        self._route = self.DeclareAbstractInputPort("route", AbstractValue.Make(np.zeros((0, 2))))
        self._subgoal = self.DeclareVectorInputPort("subgoal", 2)
        self._track_drawing = TrackDrawing(meshcat)  # the `tracks` input's slots
        self._step_time = config.robot.step_time
        self._reset_drawing()
        self._draw_static_scene(scenario)
        self.DeclareInitializationPublishEvent(self._initialize)
        self.DeclarePeriodicPublishEvent(publish_period, 0.0, self._publish)
        self.DeclarePeriodicPublishEvent(self._step_time, 0.0, self._publish_step)
        self.DeclareForcedPublishEvent(self._publish)

    # What has been sent to Meshcat (the server's scene, not simulation state: nothing
    # the diagram computes depends on it). Reset when a simulation is initialized.
    def _reset_drawing(self) -> None:
        self._emotions: list[int] | None = None
        self._last_step = -1
        self._trail_point: np.ndarray | None = None
        self._trail_count = 0
        self._last_rays: tuple[str, str] | None = None  # the rays and hits shown now
        self._step_start: float | None = None
        self._footstep_count = 0
        self._track_drawing.reset()
        self._shown_route: np.ndarray | None = None
        self._route_count = 0

    def _draw_static_scene(self, scenario: Scenario) -> None:
        m, c = self._meshcat, self._config
        m.Delete(PREFIX)
        if self._draw_robot:
            m.SetObject(f"{PREFIX}/robot/body", Cylinder(c.robot.radius, 1.0), ROBOT_RGBA)
            m.SetTransform(f"{PREFIX}/robot/body", RigidTransform([0, 0, 0.5]))
            m.SetObject(f"{PREFIX}/robot/nose", Sphere(0.08), HEADING_RGBA)
            m.SetTransform(f"{PREFIX}/robot/nose", RigidTransform([c.robot.radius, 0, 0.9]))
            x0, y0 = scenario.robot_start
            m.SetTransform(
                f"{PREFIX}/robot",
                RigidTransform(RotationMatrix.MakeZRotation(scenario.robot_heading), [x0, y0, 0.0]),
            )
        x0, y0 = scenario.robot_start  # the start: a square pad in the robot's colour
        m.SetObject(f"{PREFIX}/start", Box(_START_PAD, _START_PAD, 0.02), START_RGBA)
        m.SetTransform(f"{PREFIX}/start", RigidTransform([x0, y0, 0.01]))
        goal = scenario.robot_goal
        m.SetObject(
            f"{PREFIX}/goal/pad", Cylinder(self._goal_radius, 0.02), _faded(GOAL_RGBA, 0.35)
        )
        m.SetTransform(f"{PREFIX}/goal/pad", RigidTransform([0, 0, 0.01]))
        ang = np.linspace(0.0, 2.0 * np.pi, 49)
        ring = np.vstack([np.cos(ang), np.sin(ang), np.zeros_like(ang)]) * self._goal_radius
        ring[2] = 0.025  # just above the pad
        m.SetLine(f"{PREFIX}/goal/radius", ring, 2.0, GOAL_RADIUS_RGBA)
        m.SetObject(f"{PREFIX}/goal/pole", Cylinder(0.03, _GOAL_POLE), GOAL_RGBA)
        m.SetTransform(f"{PREFIX}/goal/pole", RigidTransform([0, 0, _GOAL_POLE / 2]))
        m.SetObject(f"{PREFIX}/goal/top", Sphere(0.15), GOAL_RGBA)
        m.SetTransform(f"{PREFIX}/goal/top", RigidTransform([0, 0, _GOAL_POLE]))
        m.SetTransform(f"{PREFIX}/goal", RigidTransform([goal[0], goal[1], 0.0]))
        for i, o in enumerate(scenario.obstacles):
            path = f"{PREFIX}/static/{i}"
            m.SetObject(f"{path}/disc", Cylinder(o.radius, STATIC_HEIGHT), STATIC_RGBA)
            m.SetTransform(f"{path}/disc", RigidTransform([0, 0, STATIC_HEIGHT / 2]))
            m.SetObject(
                f"{path}/ring",
                Cylinder(o.radius + c.reward.static_discomfort, 0.01),
                _faded(STATIC_RGBA, 0.25),
            )
            m.SetTransform(f"{path}/ring", RigidTransform([0, 0, 0.005]))
            m.SetTransform(path, RigidTransform([o.center[0], o.center[1], 0.0]))
            if o.appears_at > 0:  # put in place during the episode
                self._appear(path, o.appears_at)
        for i, w in enumerate(scenario.walls):
            self._draw_wall(f"{PREFIX}/walls/{i}", w.start, w.end, c.reward.static_discomfort)
        dist = c.reward.emotion_distances()
        radius = c.crowd.pedestrian_radius
        for i, ped in enumerate(scenario.pedestrians):
            path = f"{PREFIX}/pedestrians/{i}"
            # The scene as it starts (what a replay shows before it plays): only the
            # initial emotion's body and ring are visible; `_publish` animates changes.
            first = EMOTION_NAMES.index(ped.emotion)
            for e in range(3):
                h = self._pedestrian_height
                m.SetObject(f"{path}/body{e}", Cylinder(radius, h), EMOTION_RGBA[e])
                m.SetTransform(f"{path}/body{e}", RigidTransform([0, 0, h / 2]))
                m.SetObject(
                    f"{path}/ring{e}",
                    Cylinder(radius + dist[e], 0.01),
                    _faded(EMOTION_RGBA[e], 0.3),
                )
                m.SetTransform(f"{path}/ring{e}", RigidTransform([0, 0, 0.005]))
                m.SetProperty(f"{path}/body{e}", "visible", e == first)
                m.SetProperty(f"{path}/ring{e}", "visible", e == first)
            m.SetTransform(path, RigidTransform([ped.start[0], ped.start[1], 0.0]))

    def _draw_wall(self, path: str, a: list[float], b: list[float], discomfort: float) -> None:
        """A wall a → b (world [m]) as a grey slab `_WALL_THICKNESS` thick, with its
        discomfort band (`discomfort` m each side) on the floor."""
        m = self._meshcat
        length = float(np.hypot(b[0] - a[0], b[1] - a[1]))
        m.SetObject(f"{path}/slab", Box(length, _WALL_THICKNESS, STATIC_HEIGHT), STATIC_RGBA)
        m.SetTransform(f"{path}/slab", RigidTransform([0, 0, STATIC_HEIGHT / 2]))
        band = Box(length + 2 * discomfort, 2 * discomfort, 0.01)
        m.SetObject(f"{path}/band", band, _faded(STATIC_RGBA, 0.25))
        m.SetTransform(f"{path}/band", RigidTransform([0, 0, 0.005]))
        yaw = float(np.arctan2(b[1] - a[1], b[0] - a[0]))
        middle = [(a[0] + b[0]) / 2, (a[1] + b[1]) / 2, 0.0]
        m.SetTransform(path, RigidTransform(RotationMatrix.MakeZRotation(yaw), middle))

    def _initialize(self, context: Context) -> EventStatus:
        self._reset_drawing()
        return EventStatus.Succeeded()

    def _appear(self, path: str, t: float) -> None:
        """`path` (just created) hidden until t in a recording, shown from t."""
        self._meshcat.SetProperty(path, "visible", False, 0.0)
        self._meshcat.SetProperty(path, "visible", True, t)

    def _add_fading(self, path: str, shape, rgba: Rgba, pale_alpha: float, t: float) -> None:
        """A bright `path`/new and a pale `path`/old version of one item; `_fade` swaps."""
        m = self._meshcat
        m.SetObject(f"{path}/new", shape, rgba)
        m.SetObject(f"{path}/old", shape, _faded(rgba, pale_alpha))
        m.SetProperty(f"{path}/new", "visible", True, 0.0)
        m.SetProperty(f"{path}/old", "visible", False, 0.0)
        self._appear(path, t)

    def _fade(self, path: str, t: float) -> None:
        self._meshcat.SetProperty(f"{path}/new", "visible", False, t)
        self._meshcat.SetProperty(f"{path}/old", "visible", True, t)

    def _publish(self, context: Context) -> EventStatus:
        m, t = self._meshcat, context.get_time()
        x, y, th, _ = self._robot.Eval(context)
        if self._draw_robot:
            m.SetTransform(
                f"{PREFIX}/robot", RigidTransform(RotationMatrix.MakeZRotation(th), [x, y, 0.0]), t
            )
        crowd = self._crowd.Eval(context)
        emotions = [int(e) for e in crowd.emotions[: self._num_peds]]
        for i in range(self._num_peds):
            path = f"{PREFIX}/pedestrians/{i}"
            px, py = crowd.positions[i]
            m.SetTransform(path, RigidTransform([px, py, 0.0]), t)
            if self._emotions is None or self._emotions[i] != emotions[i]:
                for e in range(3):
                    m.SetProperty(f"{path}/body{e}", "visible", e == emotions[i], t)
                    m.SetProperty(f"{path}/ring{e}", "visible", e == emotions[i], t)
        self._emotions = emotions
        if self._footsteps.HasValue(context):
            self._draw_footstep(self._footsteps.Eval(context), t)
        if self._tracks.HasValue(context):
            self._track_drawing.draw(self._tracks.Eval(context), t)
        return EventStatus.Succeeded()

    def _draw_footstep(self, targets, t: float) -> None:
        """The marker of the step being planned; a new step gets a new marker."""
        if targets.standing:
            return
        m = self._meshcat
        if targets.start_time != self._step_start:
            self._step_start = targets.start_time
            n = self._footstep_count
            self._footstep_count += 1
            self._add_fading(
                f"{PREFIX}/footsteps/{n}",
                Box(0.26, 0.11, 0.006),
                FOOT_RGBA[targets.swing_leg],
                0.3,
                t,
            )
            if n >= FOOTSTEPS_RECENT:
                self._fade(f"{PREFIX}/footsteps/{n - FOOTSTEPS_RECENT}", t)
        yaw = float(targets.swing_yaw_target)
        sx, sy = targets.swing_target[0], targets.swing_target[1]
        # the sole's centre is 2 cm ahead of the ankle (the model's foot box)
        centre = [sx + 0.02 * math.cos(yaw), sy + 0.02 * math.sin(yaw), 0.004]
        m.SetTransform(
            f"{PREFIX}/footsteps/{self._footstep_count - 1}",
            RigidTransform(RotationMatrix.MakeZRotation(yaw), centre),
            t,
        )

    def _publish_step(self, context: Context) -> EventStatus:
        t = context.get_time()
        k = round(t / self._step_time)
        if k <= self._last_step:
            return EventStatus.Succeeded()
        self._last_step = k
        x, y, th, _ = self._robot.Eval(context)
        point = np.array([x, y])
        if self._draw_trail:
            self._draw_trail_segment(point, t)
        if self._show_rays and self._scan.HasValue(context):
            self._draw_rays(k, self._scan.Eval(context), x, y, th, t)
        if self._route.HasValue(context):
            self._draw_route(np.asarray(self._route.Eval(context), dtype=float), t)
        if self._subgoal.HasValue(context):
            gx, gy = self._subgoal.Eval(context)
            if not self._meshcat.HasPath(f"{PREFIX}/subgoal"):
                self._meshcat.SetObject(f"{PREFIX}/subgoal", Sphere(0.1), GOAL_RGBA)
            self._meshcat.SetTransform(
                f"{PREFIX}/subgoal", RigidTransform([gx, gy, SUBGOAL_HEIGHT]), t
            )
        return EventStatus.Succeeded()

    def _draw_route(self, route: np.ndarray, t: float) -> None:
        """A new line for a route not drawn yet (world [m]); the previous one hidden."""
        if len(route) < 2 or (
            self._shown_route is not None
            and self._shown_route.shape == route.shape
            and np.array_equal(self._shown_route, route)
        ):
            return
        m, n = self._meshcat, self._route_count
        points = np.vstack([route.T, np.full(len(route), ROUTE_HEIGHT)])
        m.SetLine(f"{PREFIX}/route/{n}", points, 3.0, GOAL_RGBA)
        self._appear(f"{PREFIX}/route/{n}", t)
        if n > 0:
            m.SetProperty(f"{PREFIX}/route/{n - 1}", "visible", False, t)
        self._shown_route, self._route_count = route.copy(), n + 1

    def _draw_trail_segment(self, point: np.ndarray, t: float) -> None:
        start = self._start if self._trail_point is None else self._trail_point
        self._trail_point = point
        d = point - start
        length = float(np.hypot(*d))
        if length < 1e-3:
            return
        n = self._trail_count
        self._trail_count += 1
        path = f"{PREFIX}/trail/{n}"
        self._add_fading(path, Box(length, 0.08, 0.004), TRAIL_RGBA, 0.35, t)
        mid = 0.5 * (start + point)
        self._meshcat.SetTransform(
            path,
            RigidTransform(
                RotationMatrix.MakeZRotation(math.atan2(d[1], d[0])), [mid[0], mid[1], 0.015]
            ),
        )
        if n >= TRAIL_RECENT_STEPS:
            self._fade(f"{PREFIX}/trail/{n - TRAIL_RECENT_STEPS}", t)

    def _draw_rays(self, k: int, scan: np.ndarray, x: float, y: float, th: float, t: float) -> None:
        num = len(scan)
        beams = np.arange(0, num, RAY_STRIDE)
        ranges = scan[beams]
        ang = th + (beams - (num - 1) / 2) * (2 * np.pi / num)
        start = np.tile(np.array([[x], [y], [0.3]]), (1, len(beams)))
        end = np.vstack(
            [x + ranges * np.cos(ang), y + ranges * np.sin(ang), np.full(len(beams), 0.3)]
        )
        path = f"{PREFIX}/rays/{k}"
        self._meshcat.SetLineSegments(path, start, end, 1.0, RAY_RGBA)
        self._appear(path, t)
        hits = self._draw_hits(k, scan, x, y, th, t)
        if self._last_rays is not None:
            for old in self._last_rays:
                self._meshcat.SetProperty(old, "visible", False, t)
        self._last_rays = (path, hits)

    def _draw_hits(self, k: int, scan: np.ndarray, x: float, y: float, th: float, t: float) -> str:
        """Every beam's return (range below the maximum) as a point just above the heads:
        the scan as the sensor measured it (noise, lost beams, spurious returns, legs)."""
        num = len(scan)
        beams = np.flatnonzero(scan < self._config.lidar.max_range - 1e-6)
        ang = th + (beams - (num - 1) / 2) * (2 * np.pi / num)
        cloud = PointCloud(len(beams))
        cloud.mutable_xyzs()[:] = np.vstack(
            [
                x + scan[beams] * np.cos(ang),
                y + scan[beams] * np.sin(ang),
                np.full(len(beams), self._pedestrian_height + HIT_LIFT),
            ]
        )
        path = f"{PREFIX}/hits/{k}"
        self._meshcat.SetObject(path, cloud, HIT_POINT_SIZE, HIT_RGBA)
        self._appear(path, t)
        return path


def set_overview_camera(meshcat: Meshcat, config: EmoNavConfig) -> None:
    """Frame the whole arena from above at an angle: start, goal and the crowd's circle,
    seen from the −y side at about 50° elevation through an `OVERVIEW_FOV` (vertical)
    field of view, instead of Meshcat's default camera that sits inside the arena. The
    arena needs `OVERVIEW_MIN_HFOV` horizontally: any landscape or square window. Set
    before a recording, a replay's HTML opens with this view; a browser that connects
    later gets it too."""
    start = np.asarray(config.robot.start, dtype=float)
    goal = np.asarray(config.robot.goal, dtype=float)
    centre = 0.5 * (start + goal)
    span = max(float(np.linalg.norm(goal - start)), 2.0 * config.crowd.circle_radius_max)
    meshcat.SetCamera(Meshcat.PerspectiveCamera(fov=OVERVIEW_FOV, near=0.05, far=200.0))
    # close enough that the crowd's circle, heads included, fills ~95 % of the height of
    # a landscape window (a narrower window widens the view: `OVERVIEW_MIN_HFOV`)
    meshcat.SetCameraPose(
        [centre[0], centre[1] - 0.8 * span, 0.95 * span],
        [centre[0], centre[1] - 0.03 * span, 0.0],
    )
