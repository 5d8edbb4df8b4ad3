"""`EmoNavDigit-v0`: the navigation task on the full-order Digit as a Gymnasium environment.

The Digit navigation diagram (`diagrams/navigation_digit.py`: Digit station, crowd, LiDAR
grid maps, episode monitor) built for an external agent and driven through
`pydrake.gym.DrakeGymEnv`: the agent's action enters the planner's `action` input and is
stored at the next planner instant t_k exactly as a planner's command would be, the
observation is the diagram's `observation` output (`systems.navigation_observation`).
Observation and action spaces are `EmoNavLIP-v0`'s (`learning.env.navigation_spaces`),
so a policy trained on one runs on the other; so are the reward (paper Eq. 6–9, the
episode monitor's evaluation of the step), `terminated` (collision, goal, or a fall —
the station's fall monitor) and `truncated` (time limit).

One `step` advances the simulation by one walking step T = 0.4 s (about 400 plant steps
of 1 ms and the 1 kHz controller). `reset(seed=s)` plays `sample_scenario(s)`, the
scenario `emonav sim --plant digit --seed s` plays, from Digit standing at the start; a
new diagram is built per episode (the crowd and the goal are part of it).
`options={"scenario": Scenario}` plays a given one. An invalid action (NaN, out of the
bounds of Eq. 2) raises `CommandError`, as in `EmoNavLIP-v0`; nothing is clipped.

`state_dict()` / `load_state_dict()` save and continue an episode (for a trainer's
resumable checkpoint): the state is the episode's scenario, its reset seed and the
commands applied so far, and loading simulates them again from the start — the diagram is
deterministic, so the continued episode is the saved one (tested), at the cost of
re-simulating up to one episode.
"""

from __future__ import annotations

import dataclasses as dc
from typing import Any

import gymnasium as gym
import numpy as np
from pydrake.common import RandomGenerator
from pydrake.gym import DrakeGymEnv
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import Context

from emonav_drake.diagrams.episode import EpisodeStepper
from emonav_drake.learning.env import np_random_state, set_np_random_state, set_task
from emonav_drake.navigation.lip_world import check_command, scenario_from_plain
from emonav_drake.params import EmoNavConfig
from emonav_drake.scenarios.scenario import Scenario, sample_scenario


class EmoNavDigitEnv(DrakeGymEnv):
    """Emotion-aware social navigation with the full-order Digit (see the module).

    Args:
        config: an `EmoNavConfig`, a path to a YAML config, or None for the defaults.
        grid_kind: the map observation, as `EmoNavLIPEnv` ("lgm", "ogm", "scan", "drlvo").
        goal_radius: goal threshold [m]; default `config.episode.goal_radius`.
    """

    metadata = {"render_modes": []}

    def __init__(
        self,
        config: EmoNavConfig | str | None = None,
        grid_kind: str = "lgm",
        goal_radius: float | None = None,
    ) -> None:
        set_task(self, config, grid_kind, goal_radius)
        observation_space, action_space = self.observation_space, self.action_space
        self._scenario: Scenario | None = None
        self._reset_seed: int | None = None
        self._commands: list[list[float]] = []  # this episode's commands (for state_dict)
        self.navigation = None  # the episode's `DigitNavigationDiagram`
        self._stepper: EpisodeStepper | None = None  # walks it (`diagrams.episode`)
        super().__init__(
            simulator=self._make_simulator,
            time_step=self.config.robot.step_time,
            action_space=action_space,
            observation_space=observation_space,
            reward=self._reward,
            action_port_id="action",
            observation_port_id="observation",
            reset_handler=self._reset_handler,
        )
        self.render_mode = None

    def _make_simulator(self, generator: RandomGenerator) -> Simulator:
        from emonav_drake.diagrams.navigation_digit import build_digit_navigation_diagram

        self.navigation = build_digit_navigation_diagram(
            self._scenario, self.config, None, grid_kind=self.grid_kind,
            goal_radius=self.goal_radius,
        )  # fmt: skip
        return Simulator(self.navigation.diagram)

    def _reset_handler(self, simulator: Simulator, context: Context, seed: int | None) -> None:
        # `DrakeGymEnv.reset` initialised, then set the default context (Digit standing at
        # the start): initialise again from it, as a plain `Simulator` run does
        simulator.Initialize()
        self._stepper = EpisodeStepper(
            simulator, self.navigation.systems(), self.config.robot.step_time
        )

    def _reward(self, system, context: Context) -> float:
        status = self._stepper.status()
        return 0.0 if status.last_step is None else float(status.last_step.reward)

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict, dict]:
        gym.Env.reset(self, seed=seed)  # seeds `np_random` (as `EmoNavLIP-v0` does)
        scenario = (options or {}).get("scenario")
        if scenario is None:
            scenario_seed = seed if seed is not None else int(self.np_random.integers(2**31))
            scenario = sample_scenario(scenario_seed, self.config)
        elif not isinstance(scenario, Scenario):
            raise TypeError(f"options['scenario'] must be a Scenario, got {type(scenario)}")
        self._scenario = scenario.validate()
        self._reset_seed, self._commands = seed, []
        observation, info = super().reset(seed=seed)
        return observation, {**info, "scenario_seed": scenario.seed}

    def step(self, action: np.ndarray) -> tuple[dict, float, bool, bool, dict]:
        if self.navigation is None:
            raise RuntimeError("call reset() before step()")
        stepper = self._stepper
        if stepper.outcome() is not None:
            raise RuntimeError("the episode has ended: call reset()")
        command, _ = check_command(np.asarray(action, dtype=float), self.config.robot)
        self._commands.append([float(c) for c in command])
        # `DrakeGymEnv.step` advances to t + T; the stepper advances to k·T exactly
        self.action_port.FixValue(stepper.context, command)
        fell = stepper.advance()
        if fell is not None:  # the simulator gave up: a fall (an outcome, not a crash)
            observation = self.observation_port.Eval(stepper.context)
            info = {"outcome": fell.outcome, "episode_record": fell.to_json()}
            return observation, 0.0, True, False, info
        observation = self.observation_port.Eval(stepper.context)
        status = stepper.status()
        reward = 0.0 if status.last_step is None else float(status.last_step.reward)
        record = stepper.outcome(status)
        outcome = None if record is None else record.outcome
        info: dict[str, Any] = {"outcome": outcome}
        if status.last_step is not None:
            ev = status.last_step
            info |= {
                "collision": ev.collision,
                "reached_goal": ev.reached_goal,
                "in_discomfort": ev.in_discomfort,
                "idt": ev.idt,
            }
        if record is not None:
            info["episode_record"] = record.to_json()
        terminated = outcome in ("success", "collision", "fall")
        truncated = outcome == "timeout"
        return observation, reward, terminated, truncated, info

    def state_dict(self) -> dict:
        """The running episode as plain data (see the module): map kind, goal radius, the
        scenario, the reset seed, the commands so far and gymnasium's `np_random`."""
        scenario = self._scenario if self.navigation is not None else None
        return {
            "grid_kind": self.grid_kind,
            "goal_radius": self.goal_radius,
            "scenario": None if scenario is None else dc.asdict(scenario),
            "reset_seed": self._reset_seed,
            "commands": [list(c) for c in self._commands],
        } | np_random_state(self)

    def load_state_dict(self, state: dict) -> None:
        """Continue the episode saved by `state_dict`: reset to its scenario and apply its
        commands again (`ValueError` if it does not fit this environment)."""
        if state["grid_kind"] != self.grid_kind:
            raise ValueError(f"saved map kind {state['grid_kind']!r} != {self.grid_kind!r}")
        self.goal_radius = state["goal_radius"]
        if state["scenario"] is None:
            self.navigation, self._scenario, self._commands = None, None, []
        else:
            scenario = scenario_from_plain(state["scenario"])
            self.reset(seed=state["reset_seed"], options={"scenario": scenario})
            for k, command in enumerate(state["commands"]):
                if self._stepper.outcome() is not None:
                    raise ValueError(f"the saved episode ended before its command {k}")
                self.step(np.asarray(command, dtype=float))
        set_np_random_state(self, state)
