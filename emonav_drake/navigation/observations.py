"""The map observations a navigation policy can read: one registry entry per kind.

The planner input's `lgm_stack` (the name is the paper's LGM; the field carries whichever
map the policy reads) is built, robot frame, from the CoM and heading at the foot switch
t_k and the crowd at t_k, oldest first:

    kind     variant (paper)                  frame at t_k      stack (observation)
    "lgm"    EmoBipedNav; N = 1: Single-LGM   uint8 (M, M)      uint8 (N, M, M)
    "ogm"    OGM (Cartesian occupancy grid)   uint8 (M, M)      uint8 (N, M, M)
    "scan"   LiDAR-SAC, LNDNL (ranges [m])    float32 (K,)      float32 (N, K)
    "drlvo"  DRL-VO* (scan OGM + ped. v map)  uint8 (3, M, M)   uint8 (1, 3, M, M)
    "lgm_vel" LGM + pedestrians' velocities   uint8 (3, M, M)   uint8 (N + 2, M, M)
    "lgm_tracks" LGM + the pedestrians' table uint8 (2, M, M)   uint8 (N + 1, M, M)

"lgm_vel" (ours, not the paper's) is the LGM stack followed by two planes of the current
step on the LGM's polar grid: the v_x and v_y (robot frame) of the pedestrian covering
each cell (`sensing/kinematic_maps.py::lgm_velocity_planes`) — of the tracked pedestrians
when the maps ring the tracks (`perception.map_rings: tracks`), else of the simulator's.
It tells the policy who is walking where, which the occupancy history shows only through
its frames' differences. "lgm_tracks" (ours) gives the same pedestrians as a second input
instead: the LGM stack followed by one plane whose first row is a table of the nearest
pedestrians (position and velocity in the robot frame, `track_table_plane`), which its
encoder ("lgm_tracks", `planners/networks.py`) reads apart from the maps.

Everything that depends on the kind asks its `ObservationKind`: the environments
(`NavigationWorld`, `EmoNavLIP-v0`, `EmoNavDigit-v0`), the diagram's
`LidarGridMapBuilder`, the policies' encoders and checkpoints, DAgger's mirror
augmentation. A new observation is one `register_observation(ObservationKind(...))`.
The observation dictionary holds the map under the kind's `key` ("lgm", "scan" or
"image") beside "goal" and "last_action".

Every kind reads the LiDAR through `sensing/lidar_sensor.py`: the real scan (the maps' 255
layer, the "scan" ranges) is `sensed_ranges`, the configured sensor's scan (its faults,
pedestrians as legs), the inflated scan (the 127 layer) `inflated_ranges`. With the exact
sensor (`config.sensor`, preset "ideal") the frames are computed by the exact code path
(`lgm_frame`, `scan_discs`, `drlvo_image`), bit for bit the paper simulator's.
"""

from __future__ import annotations

import dataclasses as dc
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np

from emonav_drake.crowd.crowd import CrowdSnapshot, obstacle_discs
from emonav_drake.params import EmoNavConfig, LidarParams
from emonav_drake.registry import Registry
from emonav_drake.sensing.grid_maps import FrameStack, lgm_frame, lgm_from_ranges, ogm_from_ranges
from emonav_drake.sensing.kinematic_maps import (
    TRACK_FIELDS,
    TRACK_TABLE_ROWS,
    drlvo_image,
    drlvo_image_from_ranges,
    lgm_velocity_planes,
    track_table_plane,
)
from emonav_drake.sensing.lidar_sensor import inflated_ranges, sensed_ranges

if TYPE_CHECKING:
    from emonav_drake.robot.lip import LipState

# `ringed_frame(robot, crowd, config, perceived)` (`ObservationKind.ringed_frame`)
RingedFrame = Callable[["LipState", CrowdSnapshot, EmoNavConfig, CrowdSnapshot], np.ndarray]


class ScanStack:
    """The last N LiDAR scans (N, K) float32, oldest first (the LiDAR-SAC observation)."""

    def __init__(self, num_frames: int, num_beams: int) -> None:
        self._scans = np.zeros((num_frames, num_beams), np.float32)

    def reset(self, scan: np.ndarray) -> np.ndarray:
        self._scans[:] = scan
        return self.array

    def push(self, scan: np.ndarray) -> np.ndarray:
        self._scans[:-1] = self._scans[1:]
        self._scans[-1] = scan
        return self.array

    def load(self, scans: np.ndarray) -> None:
        """Restore a saved `array` (N, K)."""
        self._scans[:] = scans

    @property
    def array(self) -> np.ndarray:
        return self._scans.copy()


class LatestFrame:
    """Holds only the newest observation frame (observations without a frame stack)."""

    def reset(self, frame: np.ndarray) -> np.ndarray:
        self._frame = frame
        return self.array

    push = reset

    def load(self, frame: np.ndarray) -> None:
        """Restore a saved `array`."""
        self._frame = np.array(frame)

    @property
    def array(self) -> np.ndarray:
        return self._frame.copy()


class PlanesStack:
    """A grid stack with extra planes of the present (`ObservationKind.extra_planes`): the
    first plane of the last N frames, oldest first, then the newest frame's other planes —
    uint8 (N + E, M, M). An item is one (1 + E, M, M) frame ("lgm_vel": the LGM, then v_x
    and v_y, `sensing/kinematic_maps.py::lgm_velocity_planes`)."""

    def __init__(self, num_frames: int, grid_size: int, extra_planes: int) -> None:
        self._frames = FrameStack(num_frames, grid_size)
        self._extra = np.zeros((extra_planes, grid_size, grid_size), np.uint8)

    def reset(self, item: np.ndarray) -> np.ndarray:
        self._frames.reset(item[0])
        self._extra = np.array(item[1:], np.uint8)
        return self.array

    def push(self, item: np.ndarray) -> np.ndarray:
        self._frames.push(item[0])
        self._extra = np.array(item[1:], np.uint8)
        return self.array

    def load(self, stack: np.ndarray) -> None:
        """Restore a saved `array` (N + E, M, M)."""
        n = self._frames.num_frames
        self._frames.load(stack[:n])
        self._extra = np.array(stack[n:], np.uint8)

    @property
    def array(self) -> np.ndarray:
        return np.concatenate([self._frames.array, self._extra], axis=0)


@dc.dataclass(frozen=True)
class ObservationKind:
    """One map observation.

    Attributes:
        name: the kind (`grid_kind` in configurations and checkpoints).
        description: in words, for users ("LiDAR grid maps").
        key: the observation dictionary's key of the map.
        frame: `frame(robot, crowd, config)` → one frame seen from the robot's CoM and
            heading (`LipState`) at t_k, of the crowd `CrowdSnapshot` at t_k.
        shape: `shape(lidar)` → the stack's shape (`LidarParams`: N, M, K).
        dtype: the stack's dtype.
        high: `high(lidar)` → the largest value (the observation space's bound; low is 0).
        new_stack: `new_stack(lidar)` → an empty stack: `reset(item)` fills it with the
            first item, `push(item)` appends one (`stack_item` of a frame), `array` the
            observation (a copy), `load(array)` restores a saved `array`.
        mirror: the observation of the left-right mirrored world (y → −y in the robot
            frame), on a frame, a stack or a batch of stacks; returns a new array.
        lidar_for: `lidar_for(shape, lidar)` → the `LidarParams` fields (num_frames,
            grid_size) that make `shape(lidar)` equal a policy's declared stack `shape`;
            `ValueError` if no setting can (e.g. another number of beams).
        single_frame: the stack is the current frame only (no history; num_frames 1).
        planes_per_frame: input planes each frame gives a 2-D CNN encoder.
        scans: a 1-D range signal (scan encoders), not an image (2-D CNN).
        extra_planes: a grid kind whose frame is (1 + extra_planes, M, M): its stack holds
            the first plane of each of the N frames, then the newest frame's other planes
            ("lgm_vel": the LGM of N steps, then v_x and v_y now). Stores that keep one
            item per step (DAgger's frames, the SAC replay) keep the whole frame
            (`item_shape`, `newest`) and rebuild the stack (`from_items`).
        ringed_frame: `ringed_frame(robot, crowd, config, perceived)` → the frame whose
            discomfort rings (and velocities) are those of the perceived crowd `perceived`
            while the real scan stays `crowd`'s; None: the kind has no rings.
        refuses_perceived: the kind cannot take a perceived crowd (`ValueError` when one
            is given) rather than ignore it.
        encoder: the encoder type of an image kind in a policy checkpoint
            (`planners.policy.encoder_spec`), with `encoder_args` added to its spec.
    """

    name: str
    description: str
    key: str
    frame: Callable[[LipState, CrowdSnapshot, EmoNavConfig], np.ndarray]
    shape: Callable[[LidarParams], tuple[int, ...]]
    dtype: np.dtype
    high: Callable[[LidarParams], float]
    new_stack: Callable[[LidarParams], Any]
    mirror: Callable[[np.ndarray], np.ndarray]
    lidar_for: Callable[[tuple[int, ...], LidarParams], dict[str, int]]
    single_frame: bool = False
    planes_per_frame: int = 1
    scans: bool = False
    extra_planes: int = 0
    ringed_frame: RingedFrame | None = None
    refuses_perceived: bool = False
    encoder: str = "lgm"
    encoder_args: dict[str, Any] = dc.field(default_factory=dict)

    def planes(self, num_frames: int) -> int:
        """Input planes (channels) of a 2-D CNN encoder on a stack of `num_frames`."""
        return num_frames * self.planes_per_frame + self.extra_planes

    def frames_of(self, planes: int) -> int:
        """The number of frames of a stack of `planes` planes (`planes` inverted)."""
        return (planes - self.extra_planes) // self.planes_per_frame

    def item_shape(self, lidar: LidarParams) -> tuple[int, ...]:
        """The shape of what a store keeps per step (the stack holds N of them)."""
        shape = self.shape(lidar)[1:]
        return (1 + self.extra_planes, *shape) if self.extra_planes else shape

    def newest(self, stack: np.ndarray) -> np.ndarray:
        """The newest item of a stack (the frame seen now, as a store keeps it)."""
        return stack[-1 - self.extra_planes :] if self.extra_planes else stack[-1]

    def from_items(self, items: np.ndarray) -> np.ndarray:
        """Stacks from windows of items (…, N, *item_shape), oldest first → (…, *shape)."""
        if not self.extra_planes:
            return items
        return np.concatenate([items[..., 0, :, :], items[..., -1, 1:, :, :]], axis=-3)

    def stack_item(self, frame: np.ndarray) -> np.ndarray:
        """What one frame is in the stack (a single-frame kind stores the whole (1, …))."""
        return frame[None] if self.single_frame else frame


_KINDS: Registry[ObservationKind] = Registry("observation kind")


def register_observation(kind: ObservationKind, replace: bool = False) -> ObservationKind:
    """Add an observation kind (`ValueError` if the name is taken and not `replace`)."""
    return _KINDS.add(kind.name, kind, replace)


def unregister_observation(name: str) -> None:
    """Remove an observation kind (tests that register a throw-away one)."""
    _KINDS.remove(name)


def observation_kinds() -> tuple[str, ...]:
    """The registered kinds, in registration order."""
    return tuple(_KINDS)


def observation_kind(kind: str) -> ObservationKind:
    """The kind called `kind`; `ValueError` listing the kinds otherwise."""
    if kind not in _KINDS:
        raise ValueError(f"grid kind = {kind!r}: must be one of {list(_KINDS)}")
    return _KINDS[kind]


def check_observation_kind(kind: str) -> str:
    """`kind` if it is registered, else `ValueError`."""
    return observation_kind(kind).name


def map_key(grid_kind: str) -> str:
    """The map observation's key: "lgm" for grid maps (LGM or OGM), "scan" for scans,
    "image" for the DRL-VO* image (an unregistered kind: "lgm")."""
    return _KINDS[grid_kind].key if grid_kind in _KINDS else "lgm"


def observation_shape(kind: str, lidar: LidarParams) -> tuple[int, ...]:
    """Shape of the map observation (the stack) of `kind` (module docstring)."""
    return observation_kind(kind).shape(lidar)


def observation_dtype(kind: str) -> np.dtype:
    """dtype of the map observation of `kind`: float32 ranges for scans, else uint8."""
    return observation_kind(kind).dtype


def observation_frame(
    robot: LipState,
    crowd: CrowdSnapshot,
    config: EmoNavConfig,
    kind: str = "lgm",
    inflation: CrowdSnapshot | None = None,
) -> np.ndarray:
    """One observation frame of `kind` seen from the robot's CoM and heading (module
    docstring). The environment (`NavigationWorld`) and the diagram
    (`LidarGridMapBuilder`) both build their observations from this function.

    `inflation`: the crowd whose discs (grown by their discomfort margins) make the grid
    maps' inflated layer instead of `crowd`'s — e.g. the pedestrians as the robot tracks
    them, with the emotions it keeps for them — while the real scan stays `crowd`'s (the
    world the LiDAR sees); with "lgm_vel" the velocity planes are its pedestrians' too.
    Kinds without rings ("scan") ignore it; "drlvo" refuses it."""
    k = observation_kind(kind)
    if inflation is None:
        return k.frame(robot, crowd, config)
    if k.refuses_perceived:
        raise ValueError(f"the {kind} kind's maps cannot take a perceived crowd's inflation")
    if k.ringed_frame is None:
        return k.frame(robot, crowd, config)
    return k.ringed_frame(robot, crowd, config, inflation)


def _grid_from_ranges(
    kind: str, robot: LipState, crowd: CrowdSnapshot, inflation: CrowdSnapshot, config: EmoNavConfig
) -> np.ndarray:
    """A grid frame from the sensor's scan of `crowd` and the inflated scan of
    `inflation` (`lgm_from_ranges` / `ogm_from_ranges`)."""
    li = config.lidar
    xy = np.array([robot.x, robot.y])
    hit = sensed_ranges(xy, robot.heading, crowd, config)
    inflated = inflated_ranges(xy, robot.heading, inflation, config)
    to_grid = lgm_from_ranges if kind == "lgm" else ogm_from_ranges
    return to_grid(hit, inflated, li.grid_size, li.max_range)


def mirror_observation(stacks: np.ndarray, kind: str) -> np.ndarray:
    """The observation of the left-right mirrored world (y → −y in the robot frame), on a
    frame, a stack or a batch of stacks; returns a new array (`ObservationKind.mirror`)."""
    return observation_kind(kind).mirror(np.asarray(stacks))


# ------------------------------------------------------------------ the paper's kinds
def _grid_frame(kind: str) -> Callable[[LipState, CrowdSnapshot, EmoNavConfig], np.ndarray]:
    def frame(robot: LipState, crowd: CrowdSnapshot, config: EmoNavConfig) -> np.ndarray:
        li = config.lidar
        if not config.sensor.is_exact():
            return _grid_from_ranges(kind, robot, crowd, crowd, config)
        centers, radii, margins = obstacle_discs(crowd)
        return lgm_frame(
            np.array([robot.x, robot.y]),
            robot.heading,
            centers,
            radii,
            margins,
            num_beams=li.num_beams,
            grid_size=li.grid_size,
            max_range=li.max_range,
            min_range=li.min_range,
            kind=kind,
            segments=crowd.wall_segments,
            segment_margin=crowd.static_discomfort,
        )

    return frame


def _scan_frame(robot: LipState, crowd: CrowdSnapshot, config: EmoNavConfig) -> np.ndarray:
    ranges = sensed_ranges(np.array([robot.x, robot.y]), robot.heading, crowd, config)
    return ranges.astype(np.float32)


def _drlvo_frame(robot: LipState, crowd: CrowdSnapshot, config: EmoNavConfig) -> np.ndarray:
    li = config.lidar
    xy = np.array([robot.x, robot.y])
    if not config.sensor.is_exact():
        return drlvo_image_from_ranges(
            sensed_ranges(xy, robot.heading, crowd, config),
            inflated_ranges(xy, robot.heading, crowd, config),
            xy,
            robot.heading,
            crowd.positions,
            crowd.velocities,
            crowd.radius,
            li.grid_size,
            li.max_range,
        )
    centers, radii, margins = obstacle_discs(crowd)
    return drlvo_image(
        np.array([robot.x, robot.y]),
        robot.heading,
        centers,
        radii,
        margins,
        crowd.positions,
        crowd.velocities,
        crowd.radius,
        li.num_beams,
        li.grid_size,
        li.max_range,
        li.min_range,
        segments=crowd.wall_segments,
        segment_margin=crowd.static_discomfort,
    )


def _ringed_grid_frame(kind: str) -> RingedFrame:
    def frame(
        robot: LipState, crowd: CrowdSnapshot, config: EmoNavConfig, perceived: CrowdSnapshot
    ) -> np.ndarray:
        return _grid_from_ranges(kind, robot, crowd, perceived, config)

    return frame


def _velocity_planes(robot: LipState, crowd: CrowdSnapshot, config: EmoNavConfig) -> np.ndarray:
    li = config.lidar
    return lgm_velocity_planes(
        np.array([robot.x, robot.y]),
        robot.heading,
        crowd.positions,
        crowd.velocities,
        crowd.radius,
        li.num_beams,
        li.grid_size,
        li.max_range,
    )


def _track_table(robot: LipState, crowd: CrowdSnapshot, config: EmoNavConfig) -> np.ndarray:
    li = config.lidar
    xy = np.array([robot.x, robot.y])
    table = track_table_plane(
        xy, robot.heading, crowd.positions, crowd.velocities, li.grid_size, li.max_range
    )
    return table[None]


def _lgm_and(
    planes: Callable[[LipState, CrowdSnapshot, EmoNavConfig], np.ndarray],
) -> tuple[Callable[[LipState, CrowdSnapshot, EmoNavConfig], np.ndarray], RingedFrame]:
    """(frame, ringed_frame) of a kind whose frame is the LGM followed by `planes` of the
    pedestrians (E, M, M): of `crowd`, or — ringed — of the perceived crowd."""

    def frame(robot: LipState, crowd: CrowdSnapshot, config: EmoNavConfig) -> np.ndarray:
        lgm = _grid_frame("lgm")(robot, crowd, config)
        return np.concatenate([lgm[None], planes(robot, crowd, config)])

    def ringed(
        robot: LipState, crowd: CrowdSnapshot, config: EmoNavConfig, perceived: CrowdSnapshot
    ) -> np.ndarray:
        lgm = _grid_from_ranges("lgm", robot, crowd, perceived, config)
        return np.concatenate([lgm[None], planes(robot, perceived, config)])

    return frame, ringed


def _mirror_lgm_tracks(x: np.ndarray) -> np.ndarray:
    """The "lgm_tracks" stack (…, N + 1, M, M): sectors reversed in the LGM planes (`_mirror_rows`);
    in the table (the last plane's first row) y and v_y negated about 128."""
    out = np.array(x, copy=True)
    out[..., :-1, :, :] = x[..., :-1, ::-1, :]
    row = out[..., -1, 0, : TRACK_TABLE_ROWS * TRACK_FIELDS]
    table = row.reshape(*row.shape[:-1], TRACK_TABLE_ROWS, TRACK_FIELDS)
    for field in (2, 4):
        table[..., field] = _negated_codes(table[..., field])
    out[..., -1, 0, : TRACK_TABLE_ROWS * TRACK_FIELDS] = table.reshape(row.shape)
    return out


def _mirror_lgm_vel(x: np.ndarray) -> np.ndarray:
    """The "lgm_vel" stack (…, N + 2, M, M): sectors reversed in every plane
    (`_mirror_rows`) and the v_y plane (the last) negated about its zero, 128 (256 − value,
    at most 255)."""
    out = _mirror_rows(x)
    out[..., -1, :, :] = _negated_codes(out[..., -1, :, :])
    return out


def _mirror_rows(x: np.ndarray) -> np.ndarray:
    """LGM (…, M, M): sector i ↔ M − 1 − i (rows; beam i ↔ K − 1 − i)."""
    return np.ascontiguousarray(x[..., ::-1, :])


def _mirror_last_axis(x: np.ndarray) -> np.ndarray:
    """OGM (…, M, M): column j ↔ M − 1 − j (y ↔ −y); scan (…, K): beam i ↔ K − 1 − i."""
    return np.ascontiguousarray(x[..., ::-1])


def _negated_codes(codes: np.ndarray) -> np.ndarray:
    """Signed byte codes about 128 (`kinematic_maps.byte_code`) negated: 256 − code, at
    most 255."""
    return np.minimum(256 - codes.astype(np.int16), 255).astype(np.uint8)


def _mirror_drlvo(x: np.ndarray) -> np.ndarray:
    """DRL-VO* (…, 3, M, M): columns reversed and the v_y plane negated about its zero,
    128."""
    out = np.ascontiguousarray(x[..., ::-1])
    out[..., 2, :, :] = _negated_codes(out[..., 2, :, :])
    return out


def _grid_shape(li: LidarParams) -> tuple[int, ...]:
    return (li.num_frames, li.grid_size, li.grid_size)


def _byte_max(li: LidarParams) -> float:
    return 255


def _grid_stack(li: LidarParams) -> FrameStack:
    return FrameStack(li.num_frames, li.grid_size)


def _grid_lidar(shape: tuple[int, ...], li: LidarParams) -> dict[str, int]:
    return {"num_frames": shape[0], "grid_size": shape[1]}


def _scan_lidar(shape: tuple[int, ...], li: LidarParams) -> dict[str, int]:
    num_frames, beams = shape
    if beams != li.num_beams:
        raise ValueError(
            f"the policy reads {beams}-beam scans, but lidar.num_beams = {li.num_beams}"
        )
    return {"num_frames": num_frames}


def _drlvo_lidar(shape: tuple[int, ...], li: LidarParams) -> dict[str, int]:
    num_frames, _, size, _ = shape
    if num_frames != 1:
        raise ValueError(
            f"the DRL-VO* policy declares num_frames = {num_frames}: its observation is "
            "one (3, M, M) image (num_frames 1), as the environment gives it"
        )
    return {"num_frames": 1, "grid_size": size}


register_observation(
    ObservationKind(
        "lgm",
        "LiDAR grid maps",
        "lgm",
        _grid_frame("lgm"),
        _grid_shape,
        np.dtype(np.uint8),
        _byte_max,
        _grid_stack,
        _mirror_rows,
        _grid_lidar,
        ringed_frame=_ringed_grid_frame("lgm"),
    )
)
register_observation(
    ObservationKind(
        "ogm",
        "occupancy grids",
        "lgm",
        _grid_frame("ogm"),
        _grid_shape,
        np.dtype(np.uint8),
        _byte_max,
        _grid_stack,
        _mirror_last_axis,
        _grid_lidar,
        ringed_frame=_ringed_grid_frame("ogm"),
    )
)
register_observation(
    ObservationKind(
        "scan",
        "raw scans",
        "scan",
        _scan_frame,
        lambda li: (li.num_frames, li.num_beams),
        np.dtype(np.float32),
        lambda li: li.max_range,
        lambda li: ScanStack(li.num_frames, li.num_beams),
        _mirror_last_axis,
        _scan_lidar,
        scans=True,
    )
)
register_observation(
    ObservationKind(
        "drlvo",
        "DRL-VO* image",
        "image",
        _drlvo_frame,
        lambda li: (1, 3, li.grid_size, li.grid_size),
        np.dtype(np.uint8),
        _byte_max,
        lambda li: LatestFrame(),
        _mirror_drlvo,
        _drlvo_lidar,
        single_frame=True,
        planes_per_frame=3,
        refuses_perceived=True,
    )
)


def _lgm_and_planes_kind(
    name: str,
    description: str,
    planes: Callable[[LipState, CrowdSnapshot, EmoNavConfig], np.ndarray],
    extra: int,
    mirror: Callable[[np.ndarray], np.ndarray],
    **options: Any,
) -> ObservationKind:
    """A kind whose frame is the LGM followed by `extra` `planes` of the pedestrians: its
    stack (N + extra, M, M) the LGM of N steps, then those planes now (`PlanesStack`)."""
    frame, ringed = _lgm_and(planes)
    return ObservationKind(
        name,
        description,
        "lgm",
        frame,
        lambda li: (li.num_frames + extra, li.grid_size, li.grid_size),
        np.dtype(np.uint8),
        _byte_max,
        lambda li: PlanesStack(li.num_frames, li.grid_size, extra),
        mirror,
        lambda shape, li: {"num_frames": shape[0] - extra, "grid_size": shape[1]},
        extra_planes=extra,
        ringed_frame=ringed,
        **options,
    )


register_observation(
    _lgm_and_planes_kind(
        "lgm_vel", "LiDAR grid maps + pedestrians' velocities", _velocity_planes, 2, _mirror_lgm_vel
    )
)
register_observation(
    _lgm_and_planes_kind(
        "lgm_tracks",
        "LiDAR grid maps + the pedestrians' table",
        _track_table,
        1,
        _mirror_lgm_tracks,
        encoder="lgm_tracks",
        encoder_args={"tracks": TRACK_TABLE_ROWS},
    )
)
