"""One episode's trajectory as plain data: the `"trajectory"` section of `emonav sim --json`.

Built from the `EpisodeTrace` either plant gives (`Plant.simulate` with `trace=True`;
`trajectory_from_trace`) by one function, `build_trajectory`, and read back, checked, by
`load_trajectory` (what `emonav plot` draws).

Layout (world frame W: x towards the goal, y left; metres, radians, seconds), one row per
walking instant t_k = kT, k = 0 … K (K = the record's `steps`), taken before the updates
at t_k; the last row is the episode's end::

    "trajectory": {
      "format": 1, "planner": "dwa", "plant": "lip", "seed": 7, "outcome": "success",
      "step_time": 0.4,
      "scenario": {"start": [x, y], "heading": θ0, "goal": [x, y], "goal_radius": 0.2,
                   "robot_radius": 0.3, "pedestrian_radius": 0.3,
                   "discomfort": {"happy": 0.2, "neutral": 0.35, "negative": 0.5,
                                  "static": 0.2},
                   "obstacles": [{"center": [x, y], "radius": r}, ...],
                   "walls": [{"start": [x, y], "end": [x, y]}, ...]},  (only with walls)
      "t": [t_0, …, t_K],                       # [s]
      "robot": [[x, y, θ, v], …],               # (K + 1) rows: position [m], heading [rad],
                                                #   sagittal speed [m/s]
      "command": [[u_v, u_Δθ], …],              # K rows: u_k, planned at t_k, walked in
                                                #   step k [m/s, rad]
      "pedestrians": [[[x, y], …], …],          # (K + 1) × P centres [m]
      "emotions": [[e, …], …],                  # (K + 1) × P true codes in force:
                                                #   0 happy, 1 neutral, 2 negative
      "collision": null | {"k": K, "t": t_K, "point": [x, y], "with": "negative",
                           "object": "pedestrian 2"}
    }

`collision` (outcome "collision" only) names the object the robot touched at t_K — the
one whose surface is nearest the robot's centre, as `navigation.reward.evaluate_step` decides
— and `point` is the point of that surface nearest the robot's centre. The discomfort
distances are margins beyond an object's surface (the robot is inside a zone when its
centre is within margin + robot radius of the surface).
"""

from __future__ import annotations

import dataclasses as dc
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from emonav_drake.json_input import JsonInputError, read_json
from emonav_drake.navigation.episode_trace import EpisodeTrace
from emonav_drake.navigation.metrics import COLLISION, EpisodeRecord
from emonav_drake.params import EMOTION_NAMES, ConfigError, EmoNavConfig
from emonav_drake.scenarios.scenario import Scenario

FORMAT = 1
# Decimals kept in the JSON: 1 mm, 0.1 mrad, 1 mm/s, 1 ms.
_POS, _ANGLE, _SPEED, _TIME = 3, 4, 3, 3


class TrajectoryFileError(ConfigError):
    """A JSON file that holds no (or a damaged) trajectory section; the message says which."""


@dc.dataclass
class Trajectory:
    """One episode, step by step (module docstring for frames and units)."""

    t: np.ndarray  # (K + 1,) [s]
    robot: np.ndarray  # (K + 1, 4) x [m], y [m], θ [rad], v [m/s]
    command: np.ndarray  # (K, 2) u_v [m/s], u_Δθ [rad]
    pedestrians: np.ndarray  # (K + 1, P, 2) [m]
    emotions: np.ndarray  # (K + 1, P) int codes
    start: np.ndarray  # (2,) [m]
    heading: float  # initial heading [rad]
    goal: np.ndarray  # (2,) [m]
    goal_radius: float  # [m]
    robot_radius: float  # [m]
    pedestrian_radius: float  # [m]
    discomfort: dict[str, float]  # margin beyond the surface [m]: emotion names + "static"
    obstacle_centers: np.ndarray  # (S, 2) [m]
    obstacle_radii: np.ndarray  # (S,) [m]
    planner: str
    plant: str
    seed: int
    outcome: str
    step_time: float  # T [s]
    collision: dict | None = None  # see the module docstring
    # (W, 2, 2) walls: segment k from walls[k, 0] to walls[k, 1] [m]
    walls: np.ndarray = dc.field(default_factory=lambda: np.zeros((0, 2, 2)))

    @property
    def steps(self) -> int:
        """K, the number of walking steps (rows − 1)."""
        return len(self.t) - 1

    @property
    def duration(self) -> float:
        """t_K − t_0 [s]."""
        return float(self.t[-1] - self.t[0])

    def index_at(self, time: float) -> int:
        """The row k whose t_k is nearest `time` [s]; `ValueError` outside the episode."""
        t0, t1 = float(self.t[0]), float(self.t[-1])
        if not (t0 - 1e-9 <= time <= t1 + 1e-9):
            raise ValueError(f"time {time:g} s is outside the episode ({t0:g} … {t1:g} s)")
        return int(np.argmin(np.abs(self.t - time)))

    def to_json(self) -> dict:
        """The `"trajectory"` section: plain lists, floats rounded (module docstring)."""
        robot = self.robot
        rows = np.c_[
            np.round(robot[:, :2], _POS),
            np.round(robot[:, 2], _ANGLE),
            np.round(robot[:, 3], _SPEED),
        ]
        return {
            "format": FORMAT,
            "planner": self.planner,
            "plant": self.plant,
            "seed": int(self.seed),
            "outcome": self.outcome,
            "step_time": float(self.step_time),
            "scenario": {
                "start": _round(self.start, _POS),
                "heading": round(float(self.heading), _ANGLE),
                "goal": _round(self.goal, _POS),
                "goal_radius": float(self.goal_radius),
                "robot_radius": float(self.robot_radius),
                "pedestrian_radius": float(self.pedestrian_radius),
                "discomfort": {k: float(v) for k, v in self.discomfort.items()},
                "obstacles": [
                    {"center": _round(c, _POS), "radius": round(float(r), _POS)}
                    for c, r in zip(self.obstacle_centers, self.obstacle_radii, strict=True)
                ],
                **(
                    {
                        "walls": [
                            {"start": _round(a, _POS), "end": _round(b, _POS)}
                            for a, b in self.walls
                        ]
                    }
                    if len(self.walls)
                    else {}
                ),
            },
            "t": _round(self.t, _TIME),
            "robot": rows.tolist(),
            "command": _round(self.command, _ANGLE),
            "pedestrians": _round(self.pedestrians, _POS),
            "emotions": self.emotions.astype(int).tolist(),
            "collision": self.collision,
        }


def _round(a: object, decimals: int) -> list:
    return np.round(np.asarray(a, dtype=float), decimals).tolist()


def build_trajectory(
    scenario: Scenario,
    config: EmoNavConfig,
    record: EpisodeRecord,
    *,
    t: Sequence[float],
    robot: Sequence[Sequence[float]],
    command: Sequence[Sequence[float]],
    pedestrians: Sequence[Sequence[Sequence[float]]],
    emotions: Sequence[Sequence[int]],
    planner: str,
    plant: str,
    goal_radius: float | None = None,
) -> Trajectory:
    """The one place where logged steps become a `Trajectory`.

    Args:
        scenario, config: the episode's scenario and configuration (start, goal, discs,
            radii, discomfort distances).
        record: the episode's record (outcome, seed).
        t: t_k [s], k = 0 … K.
        robot: (x, y, θ, v) at t_k, world frame [m, m, rad, m/s].
        command: u_k = (u_v [m/s], u_Δθ [rad]), k = 0 … K − 1.
        pedestrians: (P, 2) centres at t_k [m].
        emotions: (P,) true emotion codes at t_k.
        planner, plant: names shown in the figures' titles.
        goal_radius: the goal threshold of the run [m] (default: the evaluation one).
    """
    t_ = np.asarray(t, dtype=float).reshape(-1)
    n = len(t_)
    robot_ = np.asarray(robot, dtype=float).reshape(n, 4)
    p = len(scenario.pedestrians)
    peds = np.asarray(pedestrians, dtype=float).reshape(n, p, 2)
    emo = np.asarray(emotions, dtype=np.int64).reshape(n, p)
    cmd = np.asarray(command, dtype=float).reshape(-1, 2)
    if len(cmd) != n - 1:
        raise ValueError(f"{len(cmd)} commands for {n} logged instants: expected {n - 1}")
    centers = np.array([o.center for o in scenario.obstacles], dtype=float).reshape(-1, 2)
    radii = np.array([o.radius for o in scenario.obstacles], dtype=float)
    distances = dict(zip(EMOTION_NAMES, config.reward.emotion_distances(), strict=True))
    traj = Trajectory(
        t=t_,
        robot=robot_,
        command=cmd,
        pedestrians=peds,
        emotions=emo,
        start=np.asarray(scenario.robot_start, dtype=float),
        heading=float(scenario.robot_heading),
        goal=np.asarray(scenario.robot_goal, dtype=float),
        goal_radius=float(config.episode.eval_goal_radius if goal_radius is None else goal_radius),
        robot_radius=float(config.robot.radius),
        pedestrian_radius=float(config.crowd.pedestrian_radius),
        discomfort={**distances, "static": float(config.reward.static_discomfort)},
        obstacle_centers=centers,
        obstacle_radii=radii,
        planner=planner,
        plant=plant,
        seed=int(scenario.seed),
        outcome=record.outcome,
        step_time=float(config.robot.step_time),
        walls=scenario.wall_segments(),
    )
    if record.outcome == COLLISION:
        traj.collision = collision_contact(traj)
    return traj


def trajectory_from_trace(
    scenario: Scenario,
    config: EmoNavConfig,
    record: EpisodeRecord,
    trace: EpisodeTrace,
    planner: str,
    plant: str,
    goal_radius: float | None = None,
) -> Trajectory:
    """The trajectory of an episode on any plant from its `EpisodeTrace` (`Plant.simulate`
    with `trace=True`): row k's time, robot, pedestrians and emotions, and u_k = row
    k + 1's held command; `plant` is the plant's name (shown in the figures' titles)."""
    if len(trace) == 0:
        raise ValueError("the trace is empty")
    steps = {"t": trace.t, "robot": trace.robot, "command": trace.commands}
    steps |= {"pedestrians": trace.pedestrians, "emotions": trace.emotions}
    names = {"planner": planner, "plant": plant, "goal_radius": goal_radius}
    return build_trajectory(scenario, config, record, **steps, **names)


def collision_contact(traj: Trajectory) -> dict:
    """What the robot touched at the last instant: the object whose surface is nearest
    its centre (pedestrian, static disc or wall), and the nearest point of that surface."""
    k = traj.steps
    xy = traj.robot[k, :2]
    centers = np.vstack([traj.pedestrians[k], traj.obstacle_centers]).reshape(-1, 2)
    radii = np.concatenate(
        [np.full(len(traj.pedestrians[k]), traj.pedestrian_radius), traj.obstacle_radii]
    )
    # walls: the nearest point of each segment, a "disc" of radius 0 there
    for a, b in traj.walls:
        d = b - a
        f = float(np.clip(np.dot(xy - a, d) / max(float(np.dot(d, d)), 1e-12), 0.0, 1.0))
        centers = np.vstack([centers, a + f * d])
        radii = np.append(radii, 0.0)
    if len(centers) == 0:
        return {"k": k, "t": float(traj.t[k]), "point": xy.tolist(), "with": "", "object": ""}
    offset = xy - centers
    dist = np.hypot(offset[:, 0], offset[:, 1])
    i = int(np.argmin(dist - radii))
    direction = offset[i] / max(dist[i], 1e-9)
    point = centers[i] + radii[i] * direction
    p, s = len(traj.pedestrians[k]), len(traj.obstacle_radii)
    if i < p:
        with_, obj = EMOTION_NAMES[int(traj.emotions[k, i])], f"pedestrian {i}"
    elif i < p + s:
        with_, obj = "static", f"static disc {i - p}"
    else:
        with_, obj = "wall", f"wall {i - p - s}"
    return {
        "k": k,
        "t": round(float(traj.t[k]), _TIME),
        "point": _round(point, _POS),
        "with": with_,
        "object": obj,
    }


# --------------------------------------------------------------------------- reading


def trajectory_from_json(data: dict, source: str = "the JSON") -> Trajectory:
    """A `Trajectory` from a `"trajectory"` section; `TrajectoryFileError` naming what is
    missing or inconsistent."""
    try:
        sc = data["scenario"]
        t = np.asarray(data["t"], dtype=float).reshape(-1)
        n = len(t)
        if n < 1:
            raise ValueError("it has no rows")
        robot = np.asarray(data["robot"], dtype=float)
        peds = np.asarray(data["pedestrians"], dtype=float)
        emo = np.asarray(data["emotions"], dtype=np.int64)
        cmd = np.asarray(data["command"], dtype=float).reshape(-1, 2)
        p = peds.shape[1] if peds.ndim == 3 else 0
        peds = peds.reshape(n, p, 2)
        emo = emo.reshape(n, p)
        if robot.shape != (n, 4):
            raise ValueError(f"'robot' has shape {robot.shape}, expected ({n}, 4)")
        if len(cmd) != n - 1:
            raise ValueError(f"'command' has {len(cmd)} rows, expected {n - 1}")
        if emo.size and (emo.min() < 0 or emo.max() >= len(EMOTION_NAMES)):
            raise ValueError("'emotions' holds codes outside 0 … 2")
        obstacles = sc["obstacles"]
        return Trajectory(
            t=t,
            robot=robot,
            command=cmd,
            pedestrians=peds,
            emotions=emo,
            start=np.asarray(sc["start"], dtype=float).reshape(2),
            heading=float(sc["heading"]),
            goal=np.asarray(sc["goal"], dtype=float).reshape(2),
            goal_radius=float(sc["goal_radius"]),
            robot_radius=float(sc["robot_radius"]),
            pedestrian_radius=float(sc["pedestrian_radius"]),
            discomfort={str(k): float(v) for k, v in sc["discomfort"].items()},
            obstacle_centers=np.array([o["center"] for o in obstacles], dtype=float).reshape(-1, 2),
            obstacle_radii=np.array([o["radius"] for o in obstacles], dtype=float),
            planner=str(data["planner"]),
            plant=str(data["plant"]),
            seed=int(data["seed"]),
            outcome=str(data["outcome"]),
            step_time=float(data["step_time"]),
            collision=data.get("collision"),
            walls=np.array(
                [[w["start"], w["end"]] for w in sc.get("walls", [])], dtype=float
            ).reshape(-1, 2, 2),
        )
    except KeyError as e:
        raise TrajectoryFileError(
            f"{source}: the trajectory section lacks the field {e.args[0]!r}"
        ) from None
    except (ValueError, TypeError) as e:
        raise TrajectoryFileError(f"{source}: the trajectory section is damaged: {e}") from None


def load_trajectory(path: str | Path) -> Trajectory:
    """The trajectory of an `emonav sim --json` file.

    Raises `TrajectoryFileError` (a `ConfigError`: the CLI prints one line, exit code 2)
    for a file that is not JSON, an `emonav eval` summary, or a sim JSON written without
    a trajectory (an older version); `OSError` when it cannot be read.
    """
    path = Path(path)
    try:
        data = read_json(path, "not a JSON file")
    except JsonInputError as e:  # bad syntax, binary content, nesting too deep
        raise TrajectoryFileError(str(e)) from None
    if not isinstance(data, dict) or "trajectory" not in data:
        if isinstance(data, dict) and "episodes" in data and "summary" in data:
            what = "an `emonav eval` summary (episode records only, no steps)"
        elif isinstance(data, dict) and "outcome" in data:
            what = "an `emonav sim --json` record without a trajectory (an older version)"
        else:
            what = "not an `emonav sim --json` file"
        raise TrajectoryFileError(
            f"{path} has no 'trajectory' section: it is {what}; write one with "
            "`emonav sim ... --json RUN.json`"
        )
    if not isinstance(data["trajectory"], dict):
        raise TrajectoryFileError(f"{path}: 'trajectory' is not an object")
    fmt = data["trajectory"].get("format")
    if fmt != FORMAT:
        raise TrajectoryFileError(
            f"{path}: trajectory format {fmt!r} is not the supported {FORMAT}"
        )
    return trajectory_from_json(data["trajectory"], str(path))
