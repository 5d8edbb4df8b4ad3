"""The episodes of the CPU route (`learning/dagger.py`) in the route's world.

`run_episode_collect` is one labelled rollout: the student acts (the expert with a
probability β, or alone in round 0) and every visited state is labelled with the
expert's choice; `evaluate_student` runs the student alone on the held-out evaluation
seeds. `make_world` is that world: the paper's LIP, or the calibrated robot of a
step-response model.
"""

from __future__ import annotations

import numpy as np

from emonav_drake.learning.config import DaggerConfig
from emonav_drake.learning.dagger_student import Student
from emonav_drake.learning.demonstrations import Demonstrations, command_index
from emonav_drake.navigation.lip_world import NavigationWorld
from emonav_drake.navigation.metrics import summarize
from emonav_drake.navigation.observations import observation_kind
from emonav_drake.params import EmoNavConfig
from emonav_drake.planners.dwa import DwaPlanner
from emonav_drake.planners.policy import vector_state
from emonav_drake.planners.protocol import Planner
from emonav_drake.robot.step_response import StepResponseModel
from emonav_drake.scenarios.scenario import Scenario, sample_scenario


def run_episode_collect(
    world: NavigationWorld,
    expert: Planner,
    student: Student | None,
    beta: float,
    demos: Demonstrations | None,
    rng: np.random.Generator,
    grid: np.ndarray | None = None,
    goal_input: str = "goal",
    soft: bool = False,
) -> str:
    """One episode; the student acts (expert with probability `beta`); label every state.

    `expert` is any planner with `reset()` and `plan(PlannerInput)`; its command is
    labelled as the nearest command of the grid: the student's, else `grid` (N, 2), else
    the expert's own DWA candidates. The student's vector state reads the goal as
    `goal_input` says (`navigation/goal_input.py`). With `soft` the expert's distribution over
    the grid (`last_distribution`, written by its `plan`) is stored as the soft label."""
    n = world.config.lidar.num_frames
    kind = observation_kind(world.grid_kind or "lgm")
    expert.reset()  # a model-aware expert remembers the episode's commands
    obs = world.planner_input()
    frame_ids: list[int] = []
    if demos is not None:
        frame_ids.append(demos.store.add(kind.newest(obs.lgm_stack)))
    if student is not None:
        commands = student.commands
    else:
        commands = grid if grid is not None else expert.candidates
    bounds = (world.config.robot.max_speed, world.config.robot.max_heading_change)
    radius = world.config.robot.radius
    k = 0
    while True:
        state = vector_state(obs.policy_goal_state(goal_input, radius), obs.last_command, bounds)
        use_expert = student is None or (beta > 0 and rng.random() < beta)
        label = None
        if demos is not None or use_expert:
            label = command_index(commands, expert.plan(obs))
        if demos is not None:
            window = [frame_ids[max(0, k - n + 1 + j)] for j in range(n)]
            demos.windows.append(np.asarray(window, np.int64))
            demos.states.append(state)
            demos.labels.append(label)
            if soft:
                demos.targets.append(np.asarray(expert.last_distribution, np.float32))
        choice = label if use_expert else student.act(obs.lgm_stack, state)
        _, outcome = world.step(commands[choice])
        if outcome is not None:
            return outcome
        obs = world.planner_input()
        if demos is not None:
            frame_ids.append(demos.store.add(kind.newest(obs.lgm_stack)))
        k += 1


def make_world(
    scenario: Scenario,
    env_cfg: EmoNavConfig,
    cfg: DaggerConfig,
    response: StepResponseModel | None,
) -> NavigationWorld:
    """The training world of the route: the LIP, or the calibrated robot of `response`."""
    return NavigationWorld(
        scenario, env_cfg, goal_radius=cfg.goal_radius, grid_kind=cfg.grid_kind, response=response
    )


def evaluate_student(
    student: Student,
    env_cfg: EmoNavConfig,
    cfg: DaggerConfig,
    response: StepResponseModel | None = None,
) -> dict:
    """The student alone on the held-out evaluation seeds (in the route's world)."""
    records = []
    expert = DwaPlanner(env_cfg, response=response)
    rng = np.random.default_rng(0)
    for i in range(cfg.eval_episodes):
        sc = sample_scenario(cfg.eval_seed_offset + i, env_cfg)
        world = make_world(sc, env_cfg, cfg, response)
        run_episode_collect(world, expert, student, 0.0, None, rng, goal_input=cfg.goal_input)
        records.append(world.record)
    return summarize(records)
