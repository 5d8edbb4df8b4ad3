"""`NavigationMeshcatVisualizer`: the navigation world drawn in Drake's Meshcat.

Input ports:
    robot_state (4): (x, y, θ, v) of the robot CoM, world frame W [m, rad, m/s].
    crowd (abstract `CrowdSnapshot`): pedestrians (positions [m], emotion codes).
    scan (K): LiDAR ranges [m] (drawn as rays when `show_rays`; leave unconnected
        otherwise).
    footstep_targets (abstract `core.walking_targets.WalkingTargets`): the full-order
        Digit's footstep planner output (swing-foot landing target and yaw, W); leave
        unconnected for the LIP robot.
    tracks (abstract `CrowdSnapshot`): the crowd as the robot tracks it from its LiDAR
        scan (`CrowdTrackerSystem.crowd`, with `perception.state_source` "lidar": what the
        state-based planners read): pedestrians' positions [m] and velocities [m/s],
        static discs' centres and radii [m]; leave unconnected when the state is the truth.

What is drawn (all under `/emonav`, world frame W, z up), in the shared palette
(`core/palette.py`; the names of the colours here are its roles):
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
      line-segment object per step, visible from t_k to t_{k+1});
    * with `tracks` connected, every `publish_period`, beside the true crowd: each
      tracked pedestrian as a flat violet ring at waist height (`TRACK_HEIGHT`), just
      wider than a pedestrian, with a velocity arrow from its position along its velocity,
      as long as the distance it covers in `TRACK_ARROW_HORIZON` (1 s; none for a track
      slower than `TRACK_ARROW_MIN_SPEED`); each tracked static disc as a dark violet ring
      of its fitted radius on top of the disc (still tracks: a pedestrian that stands still
      gets one too). Tracks come and go: a fixed pool of `TRACK_SLOTS` pedestrian and
      `TRACK_STATIC_SLOTS` static slots is drawn once, hidden, and a slot is shown while a
      track is in it (a track keeps its slot while it lives); a replay thus shows a track
      appear once it is confirmed, coast on while its pedestrian is hidden from the LiDAR,
      and vanish when deleted;
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
from pydrake.systems.framework import Context, EventStatus, LeafSystem

from emonav_drake.core import palette
from emonav_drake.core.scenario import Scenario
from emonav_drake.params import EMOTION_NAMES, EmoNavConfig


def _rgba(rgb: palette.RGB, alpha: float = 1.0) -> Rgba:
    """A palette colour as a Drake `Rgba`."""
    return Rgba(*rgb, alpha)


# The palette's roles as Drake colours (the replay's legend reads them too)
EMOTION_RGBA = tuple(_rgba(rgb) for rgb in palette.EMOTION_RGB)
STATIC_RGBA = _rgba(palette.STATIC_RGB)
ROBOT_RGBA = _rgba(palette.ROBOT_RGB)
HEADING_RGBA = _rgba(palette.INK_RGB)  # the robot's heading marker
TRAIL_RGBA = _rgba(palette.TRAIL_RGB)
GOAL_RGBA = _rgba(palette.GOAL_RGB)
GOAL_RADIUS_RGBA = _rgba(palette.GOAL_RADIUS_RGB)
RAY_RGBA = _rgba(palette.LIDAR_RAY_RGB, 0.8)
START_RGBA = _rgba(palette.ROBOT_RGB, 0.45)  # the start pad: the robot's colour, see-through
FOOT_RGBA = tuple(_rgba(rgb, 0.9) for rgb in palette.FOOTSTEP_RGB)  # left, right
TRACK_RGBA = _rgba(palette.TRACK_RGB)  # a tracked pedestrian: ring and velocity arrow
TRACK_STATIC_RGBA = _rgba(palette.TRACK_STATIC_RGB)  # a tracked static disc: ring
PREFIX = "/emonav"
TRAIL_RECENT_STEPS = 10  # trail segments drawn bright for this many walking steps
FOOTSTEPS_RECENT = 6  # footstep markers drawn bright until this many newer steps
RAY_STRIDE = 15  # draw every RAY_STRIDE-th LiDAR beam
OVERVIEW_FOV = 45.0  # vertical field of view of the overview camera [deg]
# the arena fits a horizontal field of view of this much [deg]; a replay widens the
# vertical one in windows narrower than that (`meshcat_viewing.replay_html`)
OVERVIEW_MIN_HFOV = 55.0
_GOAL_POLE = 2.0  # [m]
_START_PAD = 0.5  # [m] side of the start's square pad
TRACK_SLOTS = 24  # tracked pedestrians drawn at most (a pool of slots, shown or hidden)
TRACK_STATIC_SLOTS = 8  # tracked static discs drawn at most
TRACK_ARROW_HORIZON = 1.0  # a track's velocity arrow: the distance it covers in this [s]
TRACK_ARROW_MIN_SPEED = 0.05  # [m/s] a slower track gets no arrow
TRACK_HEIGHT = 1.0  # [m] the height of a tracked pedestrian's ring and arrow (its waist)
TRACK_RING_GAP = 0.05  # [m] between a tracked disc's radius and its ring's inner edge
TRACK_RING_WIDTH = 0.07  # [m] the ring's width (a static one's at its nominal radius)
TRACK_STATIC_NOMINAL = 0.3  # [m] the radius a static ring is drawn for, scaled to the track's
TRACK_SLOT_GATE = 0.8  # [m] a track stays in its slot when it moved at most this far
_STATIC_HEIGHT = 0.8  # [m] of a static disc's column (and of a wall)
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
        self._track_pool = False  # the tracks' slots are drawn (at the first publish)
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
        self._last_rays: str | None = None
        self._step_start: float | None = None
        self._footstep_count = 0
        # per slot: the position of the track it shows (None: hidden), and whether its
        # arrow is shown; None until the first publish draws every slot's visibility
        self._ped_slots: list[np.ndarray | None] | None = None
        self._static_slots: list[np.ndarray | None] | None = None
        self._arrows: list[bool] = [False] * TRACK_SLOTS

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
            m.SetObject(f"{path}/disc", Cylinder(o.radius, _STATIC_HEIGHT), STATIC_RGBA)
            m.SetTransform(f"{path}/disc", RigidTransform([0, 0, _STATIC_HEIGHT / 2]))
            m.SetObject(
                f"{path}/ring",
                Cylinder(o.radius + c.reward.static_discomfort, 0.01),
                _faded(STATIC_RGBA, 0.25),
            )
            m.SetTransform(f"{path}/ring", RigidTransform([0, 0, 0.005]))
            m.SetTransform(path, RigidTransform([o.center[0], o.center[1], 0.0]))
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
        m.SetObject(f"{path}/slab", Box(length, _WALL_THICKNESS, _STATIC_HEIGHT), STATIC_RGBA)
        m.SetTransform(f"{path}/slab", RigidTransform([0, 0, _STATIC_HEIGHT / 2]))
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
            self._draw_tracks(self._tracks.Eval(context), t)
        return EventStatus.Succeeded()

    # -- the LiDAR tracks ----------------------------------------------------------------

    def _draw_track_pool(self, radius: float) -> None:
        """Every slot, hidden: a ring and a velocity arrow per pedestrian slot (arrow along
        the slot's +x, its shaft 1 m long, scaled to the track's speed), a ring per static
        slot (drawn for `TRACK_STATIC_NOMINAL`, scaled to the track's radius)."""
        m = self._meshcat
        ring = _annulus(radius + TRACK_RING_GAP, radius + TRACK_RING_GAP + TRACK_RING_WIDTH)
        head = np.array([[0.0, -0.1, 0.0], [0.18, 0.0, 0.0], [0.0, 0.1, 0.0]]).T
        for j in range(TRACK_SLOTS):
            path = f"{PREFIX}/tracks/pedestrians/{j}"
            m.SetTriangleMesh(f"{path}/ring", *ring, TRACK_RGBA)
            m.SetTransform(f"{path}/ring", RigidTransform([0, 0, TRACK_HEIGHT]))
            m.SetObject(f"{path}/arrow/shaft", Box(1.0, 0.05, 0.03), TRACK_RGBA)
            m.SetTriangleMesh(
                f"{path}/arrow/head", head, np.array([[0], [1], [2]], dtype=np.int32), TRACK_RGBA
            )
            m.SetProperty(path, "visible", False)
            m.SetProperty(f"{path}/arrow", "visible", False)
        r0 = TRACK_STATIC_NOMINAL
        ring = _annulus(r0 + TRACK_RING_GAP, r0 + TRACK_RING_GAP + TRACK_RING_WIDTH)
        for j in range(TRACK_STATIC_SLOTS):
            path = f"{PREFIX}/tracks/static/{j}"
            m.SetTriangleMesh(f"{path}/ring", *ring, TRACK_STATIC_RGBA)
            m.SetTransform(f"{path}/ring", RigidTransform([0, 0, _STATIC_HEIGHT + 0.02]))
            m.SetProperty(path, "visible", False)
        self._track_pool = True

    def _fill_slot(
        self, slots: list, j: int, path: str, position: np.ndarray | None, first: bool, t: float
    ) -> None:
        """Show slot `j` at a track (`position`) or hide it (None); its "visible" property is
        recorded only when that changes (and at the first publish)."""
        shown = position is not None
        if first or shown != (slots[j] is not None):
            self._meshcat.SetProperty(path, "visible", shown, t)
        slots[j] = position

    def _draw_tracks(self, snap, t: float) -> None:
        """The tracked crowd `snap` (a `CrowdSnapshot`) at t: each track in a slot of its
        own, kept while it lives; slots without a track hidden."""
        if not self._track_pool:
            self._draw_track_pool(float(snap.radius))
        first = self._ped_slots is None
        if first:
            self._ped_slots = [None] * TRACK_SLOTS
            self._static_slots = [None] * TRACK_STATIC_SLOTS
        positions = np.asarray(snap.positions, dtype=float).reshape(-1, 2)
        velocities = np.asarray(snap.velocities, dtype=float).reshape(-1, 2)
        centres = np.asarray(snap.static_centers, dtype=float).reshape(-1, 2)
        radii = np.asarray(snap.static_radii, dtype=float).reshape(-1)
        peds = _assign_slots(self._ped_slots, positions)
        statics = _assign_slots(self._static_slots, centres)
        m = self._meshcat
        for j, i in enumerate(peds):
            path = f"{PREFIX}/tracks/pedestrians/{j}"
            self._fill_slot(self._ped_slots, j, path, None if i is None else positions[i], first, t)
            if i is None:
                if first:
                    m.SetProperty(f"{path}/arrow", "visible", False, t)
                    self._arrows[j] = False
                continue
            (px, py), (vx, vy) = positions[i], velocities[i]
            speed = math.hypot(vx, vy)
            arrow = speed >= TRACK_ARROW_MIN_SPEED  # a still track has no heading to show
            yaw = math.atan2(vy, vx) if arrow else 0.0
            m.SetTransform(path, RigidTransform(RotationMatrix.MakeZRotation(yaw), [px, py, 0]), t)
            if first or arrow != self._arrows[j]:
                m.SetProperty(f"{path}/arrow", "visible", arrow, t)
                self._arrows[j] = arrow
            if arrow:
                length = speed * TRACK_ARROW_HORIZON
                m.SetTransform(
                    f"{path}/arrow/shaft", RigidTransform([length / 2, 0, TRACK_HEIGHT]), t
                )
                m.SetProperty(f"{path}/arrow/shaft", "scale", [length, 1.0, 1.0], t)
                m.SetTransform(f"{path}/arrow/head", RigidTransform([length, 0, TRACK_HEIGHT]), t)
        for j, i in enumerate(statics):
            path = f"{PREFIX}/tracks/static/{j}"
            self._fill_slot(
                self._static_slots, j, path, None if i is None else centres[i], first, t
            )
            if i is None:
                continue
            cx, cy = centres[i]
            scale = (radii[i] + TRACK_RING_GAP + TRACK_RING_WIDTH) / (
                TRACK_STATIC_NOMINAL + TRACK_RING_GAP + TRACK_RING_WIDTH
            )
            m.SetTransform(path, RigidTransform([cx, cy, 0.0]), t)
            m.SetProperty(path, "scale", [scale, scale, 1.0], t)

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
        return EventStatus.Succeeded()

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
        if self._last_rays is not None:
            self._meshcat.SetProperty(self._last_rays, "visible", False, t)
        self._last_rays = path


def _annulus(inner: float, outer: float, sides: int = 48) -> tuple[np.ndarray, np.ndarray]:
    """A flat ring in the plane z = 0, centred at the origin: (vertices (3, 2n), faces
    (3, 2n) int32) for `Meshcat.SetTriangleMesh`."""
    ang = np.linspace(0.0, 2.0 * np.pi, sides, endpoint=False)
    rim = np.vstack([np.cos(ang), np.sin(ang), np.zeros(sides)])
    vertices = np.hstack([inner * rim, outer * rim])
    i = np.arange(sides)
    n = (i + 1) % sides
    faces = np.hstack([np.vstack([i, sides + i, sides + n]), np.vstack([i, sides + n, n])])
    return vertices, faces.astype(np.int32)


def _assign_slots(slots: list[np.ndarray | None], points: np.ndarray) -> list[int | None]:
    """Which of `points` (N, 2) each slot shows now (an index, or None): a point within
    `TRACK_SLOT_GATE` of a slot's last position stays in it (nearest pairs first); the others
    take a slot that showed nothing, else one freed now, so that a new track rarely takes
    the slot a dead one just left. Points beyond the slots are not drawn."""
    out: list[int | None] = [None] * len(slots)
    taken = set()
    pairs = sorted(
        (float(np.hypot(*(points[i] - last))), j, i)
        for j, last in enumerate(slots)
        if last is not None
        for i in range(len(points))
    )
    for gap, j, i in pairs:
        if gap > TRACK_SLOT_GATE:
            break
        if out[j] is None and i not in taken:
            out[j] = i
            taken.add(i)
    # a new track takes a slot that showed nothing before, else one just freed
    free = [j for j in range(len(slots)) if slots[j] is None] + [
        j for j in range(len(slots)) if slots[j] is not None and out[j] is None
    ]
    for i in range(len(points)):
        if i not in taken and free:
            out[free.pop(0)] = i
    return out


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
