"""`EmoNavLIP-v0`: the paper's navigation task on the LIP robot as a Gymnasium environment.

A thin front over `navigation.lip_world.NavigationWorld` (the same code the Drake diagram
runs), so a trajectory replayed here and in the diagram is the same.

Observation (`Dict`):
    "lgm":         uint8 (N, M, M) = (9, 100, 100): the LiDAR grid-map stack, oldest
                   frame first (or the OGM stack with ``grid_kind="ogm"``).
    "goal":        float32 (2,): goal distance [m] and bearing [rad, CCW from heading].
    "last_action": float32 (2,): the previous command (u_v [m/s], u_Δθ [rad]).
Action: float32 (2,) = (u_v, u_Δθ) with 0 ≤ u_v ≤ 0.4 m/s and |u_Δθ| ≤ 0.2 rad. A NaN
or out-of-range action raises `CommandError` (a `ValueError`); nothing is clipped here.
Reward: paper Eq. 6–9. `terminated` on collision or goal, `truncated` on the time limit
(125 steps = 50 s), which is not terminal for bootstrapping.
`reset(seed=s)` plays the scenario `sample_scenario(s)`, the same one
`emonav sim --seed s` plays; ``options={"scenario": Scenario}`` plays a given one.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from emonav_drake.navigation.lip_world import NavigationWorld, PlannerInput
from emonav_drake.navigation.observations import map_key, observation_kind, observation_kinds
from emonav_drake.params import EmoNavConfig, load_config
from emonav_drake.scenarios.scenario import Scenario, sample_scenario

_BIT_GENERATORS = ("PCG64", "PCG64DXSM", "MT19937", "Philox", "SFC64")


def navigation_spaces(config: EmoNavConfig, grid_kind: str) -> tuple[spaces.Dict, spaces.Box]:
    """(observation space, action space) of the navigation task (module docstring); the
    same for `EmoNavLIP-v0` and `EmoNavDigit-v0`."""
    r, li = config.robot, config.lidar
    kind = observation_kind(grid_kind)
    low = 0.0 if kind.dtype.kind == "f" else 0
    map_space = spaces.Box(low, kind.high(li), shape=kind.shape(li), dtype=kind.dtype)
    bounds = (
        np.array([0.0, -r.max_heading_change], dtype=np.float32),
        np.array([r.max_speed, r.max_heading_change], dtype=np.float32),
    )
    observation = spaces.Dict(
        {
            map_key(grid_kind): map_space,
            "goal": spaces.Box(
                np.array([0.0, -np.pi], dtype=np.float32),
                np.array([1000.0, np.pi], dtype=np.float32),
                dtype=np.float32,
            ),
            "last_action": spaces.Box(*bounds, dtype=np.float32),
        }
    )
    return observation, spaces.Box(*bounds, dtype=np.float32)


def set_task(env: gym.Env, config, grid_kind: str, goal_radius: float | None) -> None:
    """The attributes both navigation envs share: `config` (an `EmoNavConfig`, a YAML path
    or None for the defaults; validated), `grid_kind`, `goal_radius`, `map_key` and the
    spaces of `navigation_spaces`. `ValueError` for an unknown grid kind."""
    if grid_kind not in observation_kinds():
        raise ValueError(f"grid_kind = {grid_kind!r}: must be one of {list(observation_kinds())}")
    if config is None or isinstance(config, str):
        config = load_config(config)
    env.config = config.validate()
    env.grid_kind, env.goal_radius, env.map_key = grid_kind, goal_radius, map_key(grid_kind)
    env.observation_space, env.action_space = navigation_spaces(env.config, grid_kind)


class EmoNavLIPEnv(gym.Env):
    """Emotion-aware social navigation with the LIP reduced-order robot.

    Args:
        config: an `EmoNavConfig`, a path to a YAML config, or None for the defaults.
        grid_kind: "lgm" (the paper's map), "ogm" (the Cartesian baseline) or "scan"
            (stacked raw scans under the key "scan", float32 (N, K) [m]: LiDAR-SAC) or
            "drlvo" (key "image", uint8 (1, 3, M, M): scan OGM + pedestrian velocity map,
            the DRL-VO* baseline; see `sensing/kinematic_maps.py`).
        goal_radius: goal threshold [m]; default `config.episode.goal_radius` (0.1 m).
    """

    metadata = {"render_modes": []}

    def __init__(
        self,
        config: EmoNavConfig | str | None = None,
        grid_kind: str = "lgm",
        goal_radius: float | None = None,
    ) -> None:
        set_task(self, config, grid_kind, goal_radius)
        self.world: NavigationWorld | None = None

    def _observation(self) -> dict[str, np.ndarray]:
        w = self.world
        obs = w.planner_input()
        return {
            self.map_key: obs.lgm_stack,
            "goal": np.clip(
                obs.goal_state(),
                self.observation_space["goal"].low,
                self.observation_space["goal"].high,
            ).astype(np.float32),
            "last_action": np.clip(
                w.last_command, self.action_space.low, self.action_space.high
            ).astype(np.float32),
        }

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict, dict]:
        super().reset(seed=seed)
        scenario = (options or {}).get("scenario")
        if scenario is None:
            scenario_seed = seed if seed is not None else int(self.np_random.integers(2**31))
            scenario = sample_scenario(scenario_seed, self.config)
        elif not isinstance(scenario, Scenario):
            raise TypeError(f"options['scenario'] must be a Scenario, got {type(scenario)}")
        self.world = NavigationWorld(
            scenario.validate(), self.config, goal_radius=self.goal_radius, grid_kind=self.grid_kind
        )
        return self._observation(), {"scenario_seed": scenario.seed}

    def step(self, action: np.ndarray) -> tuple[dict, float, bool, bool, dict]:
        if self.world is None:
            raise RuntimeError("call reset() before step()")
        if self.world.tracker.done:
            raise RuntimeError("the episode has ended: call reset()")
        ev, outcome = self.world.step(np.asarray(action, dtype=float))
        terminated = outcome in ("success", "collision")
        truncated = outcome == "timeout"
        info = {
            "outcome": outcome,
            "collision": ev.collision,
            "reached_goal": ev.reached_goal,
            "in_discomfort": ev.in_discomfort,
            "idt": ev.idt,
        }
        if outcome is not None:
            info["episode_record"] = self.world.record.to_json()
        return self._observation(), ev.reward, terminated, truncated, info

    def state_dict(self) -> dict:
        """The environment's state as plain data: the running episode (`NavigationWorld.
        state_dict`) and gymnasium's `np_random` state; `load_state_dict` reads it back."""
        return {
            "grid_kind": self.grid_kind,
            "goal_radius": self.goal_radius,
            "world": None if self.world is None else self.world.state_dict(),
        } | np_random_state(self)

    def load_state_dict(self, state: dict) -> None:
        """Continue the episode saved by `state_dict` (same configuration and map kind;
        `ValueError` if it does not fit)."""
        if state["grid_kind"] != self.grid_kind:
            raise ValueError(f"saved map kind {state['grid_kind']!r} != {self.grid_kind!r}")
        self.goal_radius = state["goal_radius"]
        w = state["world"]
        self.world = None if w is None else NavigationWorld.from_state_dict(w, self.config)
        set_np_random_state(self, state)

    def planner_input(self) -> PlannerInput:
        """The privileged view (crowd state included) for model-based planners."""
        if self.world is None:
            raise RuntimeError("call reset() first")
        return self.world.planner_input()


def np_random_state(env: gym.Env) -> dict:
    """Gymnasium's `np_random` of `env` (and the seed it was made from) as plain data."""
    rng = env._np_random
    return {
        "np_random": None if rng is None else rng.bit_generator.state,
        "np_random_seed": env._np_random_seed,
    }


def set_np_random_state(env: gym.Env, state: dict) -> None:
    """Restore what `np_random_state` saved (`ValueError` for an unknown generator)."""
    rng_state = state["np_random"]
    if rng_state is None:
        env._np_random = None
    else:
        name = rng_state["bit_generator"]
        if name not in _BIT_GENERATORS:
            raise ValueError(f"unknown bit generator {name!r}")
        rng = np.random.Generator(getattr(np.random, name)())
        rng.bit_generator.state = rng_state
        env._np_random = rng
    env._np_random_seed = state["np_random_seed"]
