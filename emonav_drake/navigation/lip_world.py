"""One navigation episode on the LIP robot, in plain numpy: the fast world.

The timing is the diagram's, step for step (`diagrams/navigation.py`):

* walking step k starts at t_k = kT. The observation is built from the robot at its
  foot switch (p_k, θ_k) and the crowd at t_k; the planner answers u_k at once;
* the crowd advances in T/dt periods of dt. In period j the robot is seen where the
  LIP model has it at t_k + j·dt (`robot_at_substep`): for j = 0 the end of the previous
  step (p_k, walking along θ_k at v_k), for j ≥ 1 the current step's CoM trajectory;
* the robot reaches its next foot switch (p_{k+1}, θ_{k+1}, v_{k+1} = u_v);
* reward and termination are evaluated on (p_{k+1}, crowd at t_{k+1});
* in a scene with walls (the global route on) the planner's goal at t_k is the sub-goal
  along the route as planned up to t_{k−1}; the route is checked at t_k with the robot at
  p_k before it moves, and a route that closes ends the step "no_route"
  (`navigation/route_following.py`, as the diagram's `GlobalRoutePlanner`).

`NavigationWorld` is what the Gymnasium environment wraps; the Drake systems call the
same functions (`robot_at_substep`, `Crowd.step`, `observation_frame`, `evaluate_step`).

Map observations (the planner input's `lgm_stack`; the name is the paper's LGM, the field
carries whichever map the policy reads), robot frame, from the CoM and heading at the
foot switch t_k and the crowd at t_k, oldest first:

    kind     variant (paper)                  frame at t_k      stack (observation)
    "lgm"    EmoBipedNav; N = 1: Single-LGM   uint8 (M, M)      uint8 (N, M, M)
    "ogm"    OGM (Cartesian occupancy grid)   uint8 (M, M)      uint8 (N, M, M)
    "scan"   LiDAR-SAC, LNDNL (ranges [m])    float32 (K,)      float32 (N, K)
    "drlvo"  DRL-VO* (scan OGM + ped. v map)  uint8 (3, M, M)   uint8 (1, 3, M, M)

Each kind is an entry of the registry in `navigation/observations.py` (its frame, stack, shape,
dtype, mirror); a stack holds the frames of the last N walking steps (DRL-VO*: the current
one only), filled with the first frame at the start of the episode.
"""

from __future__ import annotations

import dataclasses as dc
import math

import numpy as np

from emonav_drake.crowd.crowd import Crowd, CrowdSnapshot, CrowdState, with_wall_discs
from emonav_drake.navigation.goal_input import goal_state, policy_goal_state
from emonav_drake.navigation.metrics import EpisodeRecord, EpisodeTracker
from emonav_drake.navigation.observations import observation_frame, observation_kind
from emonav_drake.navigation.reward import StepEvaluation, evaluate_step
from emonav_drake.navigation.route_following import (
    RouteFollower,
    RoutePlan,
    route_follower,
    uses_route,
)
from emonav_drake.navigation.social_metrics import StepMotion
from emonav_drake.params import EmoNavConfig, RobotParams
from emonav_drake.robot.lip import LipState, lip_in_step, lip_step, lip_velocity
from emonav_drake.robot.step_response import StepResponseModel
from emonav_drake.scenarios.scenario import PedestrianSpec, Scenario, StaticDiscSpec, WallSpec
from emonav_drake.sensing.crowd_perception import CrowdPerception, perceived_inflation
from emonav_drake.sensing.crowd_tracker import CrowdTracker
from emonav_drake.sensing.lidar_sensor import sensed_ranges


@dc.dataclass(frozen=True)
class PlannerInput:
    """Everything a planner may use at one walking step (world frame, SI units).

    Learned policies use only `lgm_stack`, `goal_state()` and `last_command`; model-based
    planners (DWA, MPC) use the privileged `crowd` snapshot and ignore `lgm_stack`.
    """

    robot: LipState
    goal_xy: np.ndarray  # (2,) [m]
    last_command: np.ndarray  # (2,) (u_v [m/s], u_Δθ [rad]) of the previous step
    crowd: CrowdSnapshot
    # The map observation of the grid kind, oldest first (module docstring): uint8
    # (N, M, M) for lgm/ogm, float32 (N, K) for scan, uint8 (1, 3, M, M) for drlvo.
    lgm_stack: np.ndarray | None
    step: int
    # `goal_xy` is a sub-goal along a global route that already goes round the walls and
    # static discs (`systems/global_route_planner.py`); False: the episode's goal itself.
    goal_is_subgoal: bool = False

    def goal_state(self) -> np.ndarray:
        """(distance [m], bearing [rad]) of the goal in the robot frame."""
        return goal_state(self.robot, self.goal_xy)

    def policy_goal_state(self, goal_input: str, robot_radius: float) -> np.ndarray:
        """What a policy of `goal_input` reads as its goal (`navigation/goal_input.py`):
        "goal" → `goal_state()`; "guide" → the goal's distance and a guide sub-goal's
        bearing (static discs of `crowd`, clearance from `robot_radius` [m])."""
        return policy_goal_state(self.robot, self.goal_xy, self.crowd, goal_input, robot_radius)


class CommandError(ValueError):
    """A navigation command is NaN or outside the paper's bounds (Eq. 2)."""


def check_command(
    command: np.ndarray, robot: RobotParams, clip: bool = False, tolerance: float = 1e-6
) -> tuple[np.ndarray, bool]:
    """Validate (u_v, u_Δθ) against 0 ≤ u_v ≤ ū_v, |u_Δθ| ≤ ū_Δθ.

    Returns the command (clipped if `clip` and out of range) and whether it was clipped.
    NaN or a wrong shape always raises `CommandError`; out of range raises unless `clip`.
    """
    u = np.asarray(command, dtype=float).reshape(-1)
    if u.shape != (2,):
        raise CommandError(f"command must be (u_v, u_dtheta), got shape {np.shape(command)}")
    if not np.all(np.isfinite(u)):
        raise CommandError(f"command {u.tolist()} is not finite")
    lo = np.array([0.0, -robot.max_heading_change])
    hi = np.array([robot.max_speed, robot.max_heading_change])
    outside = bool(np.any(u < lo - tolerance) or np.any(u > hi + tolerance))
    if outside and not clip:
        raise CommandError(
            f"command {u.tolist()} is outside the bounds u_v in [0, {robot.max_speed}] m/s, "
            f"u_dtheta in [-{robot.max_heading_change}, {robot.max_heading_change}] rad"
        )
    return np.clip(u, lo, hi), outside


def substeps_per_step(config: EmoNavConfig) -> int:
    """Crowd periods per walking step (T / dt, validated to be an integer)."""
    return round(config.robot.step_time / config.crowd.dt)


def robot_at_substep(
    start: LipState, command: np.ndarray, substep: int, config: EmoNavConfig
) -> LipState:
    """The robot CoM in crowd period `substep` of a walking step.

    `start` is the state at the step's foot switch and `command` the step's command.
    Period 0 sees the end of the previous step (`start` itself, walking along the old
    heading); the last period (T/dt) is the next foot switch, `lip_step`'s result.
    """
    if substep == 0:
        return start
    r = config.robot
    if substep == substeps_per_step(config):
        return lip_step(start, float(command[0]), float(command[1]), r.omega, r.step_time)
    return lip_in_step(
        start, float(command[0]), float(command[1]), r.omega, r.step_time, substep * config.crowd.dt
    )


RESPONSE_SEED_SALT = 0x5E5  # the calibrated robot's residual draws: seeded by (salt, scenario)


class NavigationWorld:
    """A navigation episode on the LIP robot.

    Args:
        scenario: the episode's pedestrians, discs, start and goal.
        config: the project configuration.
        goal_radius: goal-reaching threshold [m]; default `config.episode.goal_radius`.
        grid_kind: "lgm" (the paper's map), "ogm" (Cartesian baseline), "scan" (stacked
            raw LiDAR scans, the LiDAR-SAC baseline), "drlvo" (scan OGM + pedestrian
            velocity map, (1, 3, M, M), the DRL-VO* baseline) or None (no map).
        response: None walks the paper's LIP (Eq. 1); a fitted
            `robot.step_response.StepResponseModel` walks the Digit-calibrated reduced
            robot instead: each step's outcome from the step-averaged speed and the
            commands u_{k−2}, u_{k−1}, u_k, plus one residual draw per step (seeded by the
            scenario's seed) unless `response_noise` is False. The robot's `speed` is then
            the step-averaged speed v̄, and within a step the crowd sees the robot moving
            at constant velocity between the two instants.
        response_noise: add the model's residuals (True) or walk its expectation.
        global_route: in a scene with walls, follow a route on the known map
            (`navigation/route_following.py`, as the Drake diagram's `GlobalRoutePlanner`
            does, bit for bit): the planner's goal is the sub-goal along it, and an
            episode with no route left ends "no_route". None: `config.route.enabled`
            (on by default); never in a scene without walls.

    With `perception.state_source` "lidar" the world perceives the crowd as the diagram's
    `CrowdTrackerSystem` does (`sensing/crowd_perception.py`): at every crowd period it
    scans (the configured sensor, from where the crowd sees the robot) and updates a
    tracker, and the planner input's `crowd` is the tracked crowd (emotions associated
    from the simulator's pedestrians); with `perception.map_rings` "tracks" the grid maps'
    discomfort rings go round the tracked pedestrians too. Camera emotions are the
    diagram's only.
    """

    def __init__(
        self,
        scenario: Scenario,
        config: EmoNavConfig,
        goal_radius: float | None = None,
        grid_kind: str | None = "lgm",
        response: StepResponseModel | None = None,
        response_noise: bool = True,
        global_route: bool | None = None,
    ) -> None:
        self.response = response
        self.response_noise = response_noise
        self.scenario = scenario
        self.config = config
        self.goal_radius = config.episode.goal_radius if goal_radius is None else goal_radius
        self.grid_kind = grid_kind
        self.goal_xy = np.asarray(scenario.robot_goal, dtype=float)
        self.crowd = Crowd(scenario, config)
        self._substeps = substeps_per_step(config)
        self.perception: CrowdPerception | None = None
        if config.perception.state_source == "lidar":
            self.perception = CrowdPerception(config, scenario.wall_segments())
        self._rings_tracks = self.perception is not None and config.perception.map_rings == "tracks"
        if self._rings_tracks and grid_kind and observation_kind(grid_kind).refuses_perceived:
            raise ValueError(
                "perception.map_rings = tracks rings the tracked pedestrians in the grid maps; "
                f"the {grid_kind} observation cannot take them"
            )
        self.route: RouteFollower | None = None
        if uses_route(scenario, config, global_route):
            self.route = route_follower(scenario, config)
        self.reset()

    def reset(self) -> PlannerInput:
        """Back to the scenario's initial state; returns the first planner input."""
        s = self.scenario
        self.robot = LipState(
            float(s.robot_start[0]), float(s.robot_start[1]), float(s.robot_heading), 0.0
        )
        self.crowd_state: CrowdState = self.crowd.initial_state()
        self.last_command = np.zeros(2)
        self.command_before = np.zeros(2)  # u_{k−2}: the calibrated robot still feels it
        self.response_rng = np.random.default_rng([RESPONSE_SEED_SALT, s.seed % 2**64])
        self.step_count = 0
        # the LiDAR tracker's state (`perception.state_source` "lidar"), else None
        self.lidar_tracker: CrowdTracker | None = None
        if self.perception is not None:
            self.lidar_tracker = self.perception.new_tracker()
        self.route_plan: RoutePlan | None = None
        self._subgoal: np.ndarray | None = None  # this step's, once asked for
        if self.route is not None:  # planned once at the start, as the diagram initialises
            self.route_plan = self.route.replan(self.route.initial_plan(), self._xy(), 0.0)
        self.goal_distance = float(goal_state(self.robot, self.goal_xy)[0])
        self.tracker = EpisodeTracker(
            self.config.episode.max_steps, self.config.robot.step_time, seed=s.seed
        )
        self.frames = None
        if self.grid_kind is not None:
            self.frames = observation_kind(self.grid_kind).new_stack(self.config.lidar)
            self.frames.reset(self._frame())
        return self.planner_input()

    def _frame(self) -> np.ndarray:
        """The current frame, as its stack stores it (DRL-VO*: the whole (1, 3, M, M))."""
        kind = observation_kind(self.grid_kind or "lgm")
        crowd = self.crowd.snapshot(self.crowd_state)
        if self._rings_tracks:  # the real scan is the world's, the rings the tracked crowd's
            inflation = perceived_inflation(crowd, self._perceived(crowd))
            frame = observation_frame(self.robot, crowd, self.config, kind.name, inflation)
        else:
            frame = kind.frame(self.robot, crowd, self.config)
        return kind.stack_item(frame)

    def _perceived(self, crowd: CrowdSnapshot) -> CrowdSnapshot:
        """The tracked crowd now (emotions associated from `crowd`, the simulator's)."""
        return self.perception.snapshot(self.lidar_tracker, self._time(), reported=crowd)

    def _scan(self, crowd: CrowdState, seen: LipState) -> None:
        """The tracker's update with the scan of `crowd` (at its time) from `seen`."""
        snap = self.crowd.snapshot(crowd)
        xy = np.array([seen.x, seen.y])
        ranges = sensed_ranges(xy, seen.heading, snap, self.config)
        self.perception.update(self.lidar_tracker, snap.time, ranges, xy, seen.heading)

    def _xy(self) -> np.ndarray:
        return np.array([self.robot.x, self.robot.y])

    def _time(self) -> float:
        return self.step_count * self.config.robot.step_time

    def planner_input(self) -> PlannerInput:
        """The planner's view of the current walking step: with a global route, its goal
        is the sub-goal along the route (`goal_is_subgoal`)."""
        goal = self.goal_xy
        if self.route is not None:  # computed once per walking step, however often asked
            if self._subgoal is None:
                self._subgoal = self.route.subgoal(self.route_plan, self._xy(), self._time())
            goal = self._subgoal
        return PlannerInput(
            robot=self.robot,
            goal_xy=goal,
            last_command=self.last_command.copy(),
            crowd=with_wall_discs(self._planner_crowd()),
            lgm_stack=None if self.frames is None else self.frames.array,
            step=self.step_count,
            goal_is_subgoal=self.route is not None,
        )

    def _planner_crowd(self) -> CrowdSnapshot:
        crowd = self.crowd.snapshot(self.crowd_state)
        return crowd if self.perception is None else self._perceived(crowd)

    @property
    def route_points(self) -> np.ndarray:
        """The global route [m, world], robot to goal ((0, 2) without one)."""
        return np.zeros((0, 2)) if self.route_plan is None else self.route_plan.route

    @property
    def record(self) -> EpisodeRecord:
        return self.tracker.record

    def state_dict(self) -> dict:
        """The episode as plain data (Python scalars, lists, dicts, NumPy arrays).

        The scenario, goal radius and map kind (what the world was built from) and
        everything that changes: robot, crowd state, last command, counters, the
        episode tracker and record, the frame stack, the route and the LiDAR tracker
        (with `perception.state_source` "lidar"). `from_state_dict` with the same
        configuration rebuilds a world that continues exactly as this one would.
        """
        t = self.tracker
        return {
            "scenario": dc.asdict(self.scenario),
            "goal_radius": self.goal_radius,
            "grid_kind": self.grid_kind,
            "robot": list(self.robot),
            "crowd_state": self.crowd_state.to_plain(),
            "last_command": np.array(self.last_command),
            "command_before": np.array(self.command_before),
            "response_rng": self.response_rng.bit_generator.state,
            "step_count": self.step_count,
            "goal_distance": self.goal_distance,
            "tracker": {
                "max_steps": t.max_steps,
                "step_time": t.step_time,
                "done": t.done,
                "record": dc.asdict(t.record),
                "social": t.social_state(),
            },
            "frames": None if self.frames is None else self.frames.array,
            "route_plan": None if self.route_plan is None else self.route_plan.to_plain(),
            "lidar_tracker": None
            if self.lidar_tracker is None
            else self.lidar_tracker.state_dict(),
        }

    @classmethod
    def from_state_dict(cls, state: dict, config: EmoNavConfig) -> NavigationWorld:
        """A world rebuilt from `state_dict()` (`ValueError` if it does not fit)."""
        world = cls(
            scenario_from_plain(state["scenario"]),
            config,
            goal_radius=state["goal_radius"],
            grid_kind=state["grid_kind"],
        )
        world.load_state_dict(state)
        return world

    def load_state_dict(self, state: dict) -> None:
        """Restore what `state_dict` saved into a world built from the same scenario."""
        if state["grid_kind"] != self.grid_kind:
            raise ValueError(f"saved map kind {state['grid_kind']!r} != {self.grid_kind!r}")
        if dc.asdict(self.scenario) != state["scenario"]:
            raise ValueError("the saved episode is of another scenario")
        saved_tracks = state.get("lidar_tracker")
        if (saved_tracks is None) != (self.lidar_tracker is None):
            source = self.config.perception.state_source
            raise ValueError(
                "the saved episode was perceived "
                + ("from LiDAR tracks" if saved_tracks is not None else "from the true crowd")
                + f", this world's perception.state_source is {source!r}"
            )
        self.goal_radius = state["goal_radius"]
        self.robot = LipState(*state["robot"])
        self.crowd_state = CrowdState.from_plain(state["crowd_state"])
        if self.crowd_state.positions.shape[0] != self.crowd.num_pedestrians:
            raise ValueError("the saved crowd does not match the scenario")
        self.last_command = np.array(state["last_command"])
        if "command_before" in state:  # absent in states saved before the calibrated robot
            self.command_before = np.array(state["command_before"])
            self.response_rng.bit_generator.state = state["response_rng"]
        self.step_count = state["step_count"]
        self.goal_distance = state["goal_distance"]
        self._subgoal = None
        if self.route is not None:  # a state saved without a route: planned from here
            saved = state.get("route_plan")
            self.route_plan = (
                RoutePlan.from_plain(saved)
                if saved is not None
                else self.route.replan(self.route.initial_plan(), self._xy(), self._time())
            )
        if saved_tracks is not None:
            self.lidar_tracker.load_state_dict(saved_tracks)
        tr = state["tracker"]
        self.tracker = EpisodeTracker(tr["max_steps"], tr["step_time"])
        self.tracker.record = EpisodeRecord(**tr["record"])
        self.tracker.done = tr["done"]
        self.tracker.load_social_state(tr.get("social"))
        frames = state["frames"]
        if (frames is None) != (self.frames is None):
            raise ValueError("the saved frame stack does not match the map kind")
        if frames is not None:
            current = self.frames.array
            if frames.shape != current.shape or frames.dtype != current.dtype:
                raise ValueError(
                    f"saved frames are {frames.dtype} {frames.shape}, this world's "
                    f"{current.dtype} {current.shape}"
                )
            self.frames.load(np.array(frames))

    def step(self, command: np.ndarray) -> tuple[StepEvaluation, str | None]:
        """Walk one step with a valid command; returns its evaluation and the outcome
        (success | collision | timeout | no_route) if the episode ended, else None."""
        u, _ = check_command(command, self.config.robot)
        if self.route is not None:  # the check at t_k, with the robot where it is
            self.route_plan = self.route.replan(self.route_plan, self._xy(), self._time())
        start = self.robot
        crowd = self.crowd_state
        r = self.config.robot
        if self.response is None:
            for j in range(self._substeps):
                seen = robot_at_substep(start, u, j, self.config)
                if self.perception is not None:
                    self._scan(crowd, seen)
                crowd = self.crowd.step(crowd, np.array([seen.x, seen.y]), lip_velocity(seen))
            self.robot = lip_step(start, float(u[0]), float(u[1]), r.omega, r.step_time)
        else:
            commands = np.stack([self.command_before, self.last_command, u])
            rng = self.response_rng if self.response_noise else None
            end = self.response.step(start, commands, rng)
            delta = np.array([end.x - start.x, end.y - start.y])
            for j in range(self._substeps):
                xy = np.array([start.x, start.y]) + delta * (j / self._substeps)
                if self.perception is not None:  # the new heading from the switch on
                    heading = start.heading if j == 0 else end.heading
                    self._scan(crowd, LipState(float(xy[0]), float(xy[1]), heading, 0.0))
                crowd = self.crowd.step(crowd, xy, delta / r.step_time)
            self.robot = end
        self.crowd_state = crowd
        self.command_before = self.last_command
        self.last_command = u
        self.step_count += 1
        robot_xy = np.array([self.robot.x, self.robot.y])
        ev = evaluate_step(
            robot_xy,
            self.goal_xy,
            self.goal_distance,
            self.crowd.snapshot(crowd),
            r.radius,
            self.goal_radius,
            self.config.reward,
        )
        self.goal_distance = ev.goal_distance
        outcome = self.tracker.add(
            ev,
            math.hypot(self.robot.x - start.x, self.robot.y - start.y),
            motion=StepMotion(
                start, self.robot, self.crowd.snapshot(crowd), self.goal_xy, r.radius, u
            ),
            no_route=self.route_plan is not None and not self.route_plan.found,
        )
        self._subgoal = None
        if self.frames is not None:
            self.frames.push(self._frame())
        return ev, outcome


def scenario_from_plain(d: dict) -> Scenario:
    """A `Scenario` from `dataclasses.asdict(scenario)` (validated)."""
    d = dict(d)
    d["pedestrians"] = [PedestrianSpec(**p) for p in d.get("pedestrians", [])]
    d["obstacles"] = [StaticDiscSpec(**o) for o in d.get("obstacles", [])]
    d["walls"] = [WallSpec(**w) for w in d.get("walls", [])]
    return Scenario(**d).validate()
