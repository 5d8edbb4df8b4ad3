"""`LidarGridMapBuilder`: 1800-beam LiDAR scan → the policy's map observation, per step.

Builds, for the grid kind of the planner, exactly the observation the Gymnasium env
(`navigation.lip_world.NavigationWorld`) gives for the same robot and crowd states: both call
`navigation.observations.observation_frame` (docs/learning.md, "Observation variants").

Input ports:
    robot_state (4): (x, y, θ, v) of the robot CoM, world frame; the LiDAR sits at the
        CoM and beam angles are measured from θ (docs/lidar_grid_maps.md).
    crowd (abstract `CrowdSnapshot`): discs to scan (pedestrians and static obstacles)
        with their discomfort margins, and walls (`wall_segments`, with the static
        discomfort margin in the maps' inflated scan); for "drlvo" also the pedestrians'
        velocities.
    perceived_crowd (abstract `CrowdSnapshot`, optional): the pedestrians as the robot
        perceives them (the LiDAR tracker's crowd, with the emotions it keeps per track):
        when connected, the grid maps' inflated layer rings these pedestrians with their
        perceived discomfort distances (the static discs and walls stay `crowd`'s), while
        the real scan stays `crowd`'s ("lgm_vel", "lgm_tracks": their pedestrian planes
        too). Kinds with rings only ("lgm", "ogm", "lgm_vel", "lgm_tracks"; "drlvo"
        refuses it).
Output ports:
    lgm_stack (abstract numpy array): the map observation, robot frame, oldest first —
        the N − 1 frames stored at the previous walking steps followed by the frame seen
        now; before the first step the current frame is repeated N times. The name is
        the paper's LGM; the port carries the observation of `kind` (N = lidar.num_frames,
        M = lidar.grid_size, K = lidar.num_beams):
            "lgm"   uint8 (N, M, M): LiDAR grid maps (EmoBipedNav; N = 1: Single-LGM);
            "ogm"   uint8 (N, M, M): Cartesian occupancy grids (OGM baseline);
            "scan"  float32 (N, K): raw ranges [m] in [min_range, max_range]
                    (LiDAR-SAC; LNDNL min-pools and normalises them in its encoder);
            "drlvo" uint8 (1, 3, M, M): scan OGM + pedestrian velocity map (DRL-VO*,
                    `sensing/kinematic_maps.py`); no stack, the current image only;
            "lgm_vel" uint8 (N + 2, M, M): the LGM stack, then the v_x and v_y planes
                    of the pedestrians now on the LGM's polar grid (robot frame);
            "lgm_tracks" uint8 (N + 1, M, M): the LGM stack, then a plane whose first
                    row is the table of the nearest pedestrians now (robot frame).
    scan (K): the LiDAR ranges now [m], float64, clipped to [0.27, 6.0]: the configured
        sensor's scan (`sensing/lidar_sensor.py::sensed_ranges`, the same real scan as the
        maps' 255 layer and the "scan" observation; its noise is drawn from the sensor's
        seed and the crowd's scenario seed and time, so a re-evaluation gives the same
        ranges). The crowd tracker reads it; the visualiser draws it.
Abstract state: the kind's stack (`ObservationKind.new_stack`), the frame seen at every
walking step t_k = kT pushed on it.
"""

from __future__ import annotations

import copy
import dataclasses as dc
from typing import Any

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import BasicVector, Context, LeafSystem, State, ValueProducer

from emonav_drake.navigation.observations import (
    check_observation_kind,
    observation_dtype,
    observation_frame,
    observation_kind,
    observation_shape,
)
from emonav_drake.params import EmoNavConfig
from emonav_drake.sensing.crowd_perception import perceived_inflation
from emonav_drake.sensing.lidar_sensor import sensed_ranges
from emonav_drake.systems.lip_robot_plant import lip_state_from_vector


@dc.dataclass(frozen=True)
class _Stored:
    """The abstract state's value: the stack, None before the first walking step (a
    wrapper, so that Drake holds one Python object whatever the kind's stack is)."""

    stack: Any


class LidarGridMapBuilder(LeafSystem):
    """LiDAR + observation stack (grid maps, scans or the DRL-VO* image).

    Args:
        config: LiDAR (K, L, M, N) and robot step time.
        kind: "lgm" (pie-shaped LiDAR grid map, the paper's), "ogm" (Cartesian), "scan"
            (stacked raw scans) or "drlvo" (scan OGM + pedestrian velocity map).
    """

    def __init__(self, config: EmoNavConfig, kind: str = "lgm") -> None:
        super().__init__()
        self._config, self._kind = config, check_observation_kind(kind)
        self.shape = observation_shape(kind, config.lidar)  # of `lgm_stack`
        self.dtype = observation_dtype(kind)
        self._observation = observation_kind(kind)
        # The kind's stack as it stood after the last walking step; None before the first.
        self._stored = self.DeclareAbstractState(AbstractValue.Make(_Stored(None)))
        self._robot_in = self.DeclareVectorInputPort("robot_state", 4)
        self._crowd_in = self.DeclareAbstractInputPort("crowd", AbstractValue.Make(object()))
        self._perceived_in = self.DeclareAbstractInputPort(
            "perceived_crowd", AbstractValue.Make(object())
        )
        self._frame_cache = self.DeclareCacheEntry(
            "frame",
            ValueProducer(lambda: AbstractValue.Make(np.zeros(0, self.dtype)), self._calc_frame),
            {self.all_input_ports_ticket()},
        )
        self.DeclareAbstractOutputPort(
            "lgm_stack",
            lambda: AbstractValue.Make(np.zeros(self.shape, self.dtype)),
            self._calc_stack,
            {self.all_input_ports_ticket(), self.all_state_ticket()},
        )
        li = config.lidar
        scan_inputs = {
            self.input_port_ticket(self._robot_in.get_index()),
            self.input_port_ticket(self._crowd_in.get_index()),
        }  # not perceived_crowd: the tracker reads the scan and writes that crowd
        self.DeclareVectorOutputPort("scan", li.num_beams, self._calc_scan, scan_inputs)
        self.DeclarePeriodicUnrestrictedUpdateEvent(config.robot.step_time, 0.0, self._push)

    @property
    def kind(self) -> str:
        return self._kind

    def _calc_frame(self, context: Context, value: AbstractValue) -> None:
        robot = lip_state_from_vector(self._robot_in.Eval(context))
        crowd = self._crowd_in.Eval(context)
        inflation = None
        if self._perceived_in.HasValue(context):
            inflation = perceived_inflation(crowd, self._perceived_in.Eval(context))
        value.set_value(observation_frame(robot, crowd, self._config, self._kind, inflation))

    def _stacked(self, context: Context) -> Any:
        """The kind's stack with the frame seen now pushed (a new object: the stored one
        is not touched); the stack of the current frame repeated before the first step."""
        item = self._observation.stack_item(self._frame_cache.Eval(context))
        stored = context.get_abstract_state(self._stored).get_value().stack
        if stored is None:
            stack = self._observation.new_stack(self._config.lidar)
            stack.reset(item)
        else:
            stack = copy.deepcopy(stored)
            stack.push(item)
        return stack

    def _calc_stack(self, context: Context, output: AbstractValue) -> None:
        output.set_value(self._stacked(context).array)

    def _push(self, context: Context, state: State) -> None:
        state.get_mutable_abstract_state(self._stored).set_value(_Stored(self._stacked(context)))

    def _calc_scan(self, context: Context, output: BasicVector) -> None:
        robot = lip_state_from_vector(self._robot_in.Eval(context))
        crowd = self._crowd_in.Eval(context)
        xy = np.array([robot.x, robot.y])
        output.SetFromVector(sensed_ranges(xy, robot.heading, crowd, self._config))
