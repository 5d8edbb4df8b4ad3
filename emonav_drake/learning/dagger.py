"""The CPU training route: DAgger distillation of a privileged expert into an LGM student.

Paper-scale SAC costs seconds per update on a CPU (docs/learning.md), a GPU job. This
route trains a deployable policy that sees only what the paper's policy sees — the
9-frame LiDAR grid-map stack, the goal state and the last command — in well under two
hours on two cores:

1. **Expert.** A privileged planner with the crowd's true state (default: DWA on the
   LIP model, SR ≈ 0.98 on this world). Its choices come from a fixed command grid
   with deterministic tie-breaking.
2. **Student.** The paper's CNN encoder (4 conv × 32, strides 2-1-1-1, FC → 50,
   LayerNorm, tanh) on the 2 × 2 max-pooled stack (reduced resolution; max-pooling keeps
   every marked cell), an MLP, and a categorical head over the expert's command grid.
   Cross-entropy on the expert's choice keeps multimodal decisions (swerve left *or*
   right) instead of averaging them into "straight ahead", the pitfall of MSE imitation.
3. **DAgger.** Round 0 rolls out the expert; each later round rolls out the student
   (the expert acting with a probability β that halves every round), labels every visited
   state with the expert's choice and aggregates. The student trains on the aggregate.
   Each round evaluates the student alone on held-out seeds; the best round is kept.

Frames are stored once in a `FrameStore` and samples index N-frame windows into it
(90 KB per stack would not fit; 10 KB per frame does). Everything is seeded.

The run directory (`out`): `policy.pt` (the best round so far), `policy_round<r>.pt`,
`history.json` (one entry per round) and `dagger_state.pt`, the state `--resume DIR`
continues from — format `emonav-dagger-state/2` (`learning/run_state.py`): the student
and its optimiser (tensors), the aggregated demonstrations (frames, windows, states,
labels as arrays), every random state, the round's progress (phase, episodes collected,
gradient steps done, recent losses) and the history as JSON; read with
`torch.load(weights_only=True)`, so loading it never runs code. Written atomically after
every round and on Ctrl-C. Ctrl-C stops at a consistent point: an episode being
collected or an evaluation in progress is abandoned and rolled back (it runs again on
resume), a gradient step finishes; a resumed run ends bit-for-bit where an
uninterrupted one does.

This module is the training loop, `train_dagger`, and its steps. The parts it runs:
`learning/demonstrations.py` (the frame store, samples and labels),
`learning/dagger_student.py` (the student), `learning/dagger_rollouts.py` (the
labelled rollouts and the evaluation) and `learning/dagger_state.py` (the run's state,
its file and resuming).
"""

from __future__ import annotations

import copy
import dataclasses as dc
import json
import logging
import time
from pathlib import Path

import numpy as np
import torch

from emonav_drake.atomic_io import write_text_atomic
from emonav_drake.configs import load_setting
from emonav_drake.errors import RunInterrupted
from emonav_drake.learning.config import DaggerConfig
from emonav_drake.learning.config_common import with_run_family, with_run_world
from emonav_drake.learning.dagger_rollouts import (
    evaluate_student,
    make_world,
    run_episode_collect,
)
from emonav_drake.learning.dagger_state import (
    STATE_FILE,
    DaggerRunState,
    RoundProgress,
    read_dagger_state,
)
from emonav_drake.learning.dagger_student import Student
from emonav_drake.learning.demonstrations import Demonstrations, FrameStore
from emonav_drake.learning.run_state import (
    InterruptGuard,
    RunStateError,
    check_state,
    clean_stale_temp_files,
    config_changes,
    rng_state,
    set_rng_state,
)
from emonav_drake.navigation.metrics import format_summary
from emonav_drake.navigation.observations import (
    observation_dtype,
    observation_kind,
)
from emonav_drake.params import ConfigError, EmoNavConfig
from emonav_drake.planners.dwa import DwaPlanner
from emonav_drake.planners.model_aware import load_response
from emonav_drake.planners.policy import save_policy
from emonav_drake.planners.protocol import Planner
from emonav_drake.progress import progress_bar
from emonav_drake.robot.step_response import StepResponseModel
from emonav_drake.scenarios.scenario import sample_scenario
from emonav_drake.typed_yaml import to_plain

log = logging.getLogger(__name__)


@dc.dataclass
class _Route:
    """What the steps of one `train_dagger` call share besides the run's state."""

    out: Path  # the run directory
    expert: Planner  # labels the states (`DaggerConfig.expert`)
    response: StepResponseModel | None  # the training world's robot (None: the LIP)
    meta: dict  # of every policy file, but its provenance
    variant: str | None
    command: str | None


def train_dagger(
    out: str | Path,
    cfg: DaggerConfig | None = None,
    env_cfg: EmoNavConfig | None = None,
    resume: bool = False,
    command: str | None = None,
    variant: str | None = None,
    resume_command: str | None = None,
) -> Path:
    """Run the CPU route; write `out/policy.pt` (best round) and a per-round log.

    Returns the path of the best policy, which this run (or the run it resumes) wrote.
    Every policy file carries its provenance: the route, `variant` and `command` (as
    given), round, seed, configuration, samples, cumulative wall time, the training
    scenario seeds and the seeds the round was evaluated (selected) on. After Ctrl-C the
    message quotes `resume_command`, the command that continues the run (default:
    `emonav train --algo dagger --resume OUT`).

    Steps: `_start` (seeds, expert, student), `_resume`, then each round's phases
    `_collect`, `_train` and `_evaluate`.

    Raises:
        RunStateError: `resume` and `out` has no DAgger state, or one that is damaged, of
            an older format, not ours or does not fit; or no round was trained.
        RunInterrupted: after Ctrl-C, once the state is saved.
    """
    cfg = cfg or DaggerConfig()
    if env_cfg is not None and cfg.setting != "var_dd":
        raise ConfigError(
            f"setting = {cfg.setting!r} and an explicit environment configuration: give one"
        )
    env_cfg = copy.deepcopy(env_cfg or load_setting(cfg.setting))
    env_cfg.lidar.num_frames = cfg.num_frames  # the variant's stack depth
    with_run_world(env_cfg, cfg)  # its LiDAR (ideal: the setting's own), its perception
    with_run_family(env_cfg, cfg.family)  # scenes to train and select on
    out = Path(out)
    ckpt = out / STATE_FILE
    if resume:
        if not ckpt.is_file():
            raise RunStateError(
                f"no DAgger state ({STATE_FILE}) in {out}: nothing to resume "
                f"(start a new run with --out {out})"
            )
        _, saved, tensors = read_dagger_state(ckpt)  # before any work
    out.mkdir(parents=True, exist_ok=True)
    for p in clean_stale_temp_files(out):
        log.info("removed %s, left by a save that was killed", p)
    run, expert, response = _start(cfg, env_cfg, resume)
    if resume:
        _resume(run, saved, tensors, out)
    route = _Route(out, expert, response, _policy_meta(run), variant, command)
    saved_round = None  # the round whose start the state file holds
    with InterruptGuard() as guard:
        while run.prog.round <= cfg.rounds and not guard.requested:
            rnd = run.prog.round
            beta = 1.0 if rnd == 0 else cfg.beta * 0.5 ** (rnd - 1)
            if run.prog.phase == "collect":
                _collect(run, route, guard, rnd, beta)
            if run.prog.phase == "train" and not guard.requested:
                _train(run, guard, rnd)
            if run.prog.phase == "eval" and not guard.requested:
                if not _evaluate(run, route, guard, rnd, beta):
                    break
                saved_round = run.prog.round
        interrupted = guard.requested and run.prog.round <= cfg.rounds
        if interrupted:
            prog = run.prog
            log.warning("interrupted in round %d (%s): saving the state", prog.round, prog.phase)
            if not (prog.phase == "collect" and prog.episode == 0 and saved_round == prog.round):
                run.save(ckpt)
            if guard.extra:
                log.warning("Ctrl-C pressed again while stopping: ignored (the save completed)")
    if interrupted:
        raise _interruption(run.prog, out, resume_command)
    policy = out / "policy.pt"
    if not run.history or not policy.is_file():
        raise RunStateError(
            f"no DAgger round was trained (rounds = {cfg.rounds}): no policy written in {out}"
        )
    return policy


def _interruption(prog: RoundProgress, out: Path, resume_command: str | None) -> RunInterrupted:
    """The error after Ctrl-C: where the run stopped and the command that continues it."""
    where = {
        "collect": f"{prog.episode} of its episodes collected",
        "train": f"{prog.grad_step} gradient steps done",
        "eval": "evaluation to run",
    }[prog.phase]
    hint = resume_command or f"emonav train --algo dagger --resume {out} (same --config)"
    return RunInterrupted(
        f"interrupted in round {prog.round} ({where}); state saved in {out}; continue with `{hint}`"
    )


def _start(
    cfg: DaggerConfig, env_cfg: EmoNavConfig, resume: bool
) -> tuple[DaggerRunState, Planner, StepResponseModel | None]:
    """Seed torch and the run's generator; the expert, its response model, the student
    (on the expert's command grid; from `cfg.init_policy` unless `resume`) and empty
    demonstrations."""
    torch.set_num_threads(cfg.threads)
    torch.manual_seed(cfg.seed)
    rng = np.random.default_rng(cfg.seed)
    expert = cfg.teacher().build(env_cfg)  # imports planner_modules: a user's expert too
    response = load_response(cfg.response)
    commands = DwaPlanner(env_cfg).candidates.copy()  # the student's grid: the DWA's
    student = Student(cfg, env_cfg, commands)
    if cfg.init_policy and not resume:
        student.load_weights(cfg.init_policy)
    n_frames = env_cfg.lidar.num_frames
    frame_shape = observation_kind(cfg.grid_kind).item_shape(env_cfg.lidar)
    demos = Demonstrations(FrameStore(frame_shape, dtype=observation_dtype(cfg.grid_kind).type))
    return DaggerRunState(cfg, env_cfg, student, demos, rng, n_frames), expert, response


def _resume(run: DaggerRunState, saved: dict, tensors: dict, out: Path) -> None:
    """Restore the saved state (`RunStateError` if it does not fit), warning first of the
    configuration fields that differ from the saved run's."""
    changes = config_changes(
        {"config": to_plain(DaggerConfig.from_saved(saved["config"])), "env": saved["env_config"]},
        {"config": to_plain(run.cfg), "env": dc.asdict(run.env_cfg)},
    )
    if changes:
        log.warning(
            "resuming with a configuration that differs from the saved one: %s",
            ", ".join(changes),
        )
    where = f"{STATE_FILE} in {out}"
    check_state(where, lambda: run.restore(saved, tensors), changes)
    prog = run.prog
    log.info("resumed in round %d (%s; %d samples)", prog.round, prog.phase, len(run.demos))


def _policy_meta(run: DaggerRunState) -> dict:
    """What every policy file of the run records, but its provenance."""
    cfg, env_cfg = run.cfg, run.env_cfg
    return {
        "kind": "categorical",
        "encoder": run.student.encoder_spec,
        "hidden": cfg.hidden,
        "commands": run.student.commands.tolist(),
        "observation": {
            "grid_kind": cfg.grid_kind,
            "num_frames": run.n_frames,
            "grid_size": env_cfg.lidar.grid_size,
            "goal_input": cfg.goal_input,
        },
        "bounds": [env_cfg.robot.max_speed, env_cfg.robot.max_heading_change],
    }


def _collect(
    run: DaggerRunState, route: _Route, guard: InterruptGuard, rnd: int, beta: float
) -> None:
    """Collect the round's remaining episodes; then the round trains."""
    cfg, env_cfg, prog, rng, demos = run.cfg, run.env_cfg, run.prog, run.rng, run.demos
    episodes = cfg.expert_episodes if rnd == 0 else cfg.episodes_per_round
    t0 = time.perf_counter()
    bar = progress_bar(
        total=episodes,
        initial=prog.episode,
        desc=f"round {rnd} rollouts",
        unit="ep",
        leave=False,
    )
    while prog.episode < episodes and not guard.requested:
        # An episode is all or nothing: on Ctrl-C it is undone (demonstrations, frames and
        # random state back to where it began) and collected again on resume.
        undo = (rng_state(rng), len(demos), demos.store.count)
        try:
            with guard.abortable():
                sc = sample_scenario(cfg.train_seed_offset + run.episode_counter, env_cfg)
                if rng.random() < cfg.heading_noise_prob:  # off course: seek the goal
                    sc.robot_heading += float(rng.uniform(-cfg.heading_noise, cfg.heading_noise))
                world = make_world(sc, env_cfg, cfg, route.response)
                student = None if rnd == 0 else run.student
                outcome = run_episode_collect(
                    world,
                    route.expert,
                    student,
                    beta,
                    demos,
                    rng,
                    grid=run.student.commands,
                    goal_input=cfg.goal_input,
                    soft=cfg.soft_labels,
                )
        except KeyboardInterrupt:
            set_rng_state(rng, *undo[0])
            demos.truncate(undo[1], undo[2])
            break
        run.episode_counter += 1
        prog.episode += 1
        prog.outcomes.append(outcome)
        bar.update(1)
    bar.close()
    prog.collect_s += time.perf_counter() - t0
    if prog.episode >= episodes:
        prog.phase = "train"


def _train(run: DaggerRunState, guard: InterruptGuard, rnd: int) -> None:
    """The round's remaining gradient steps on the aggregate; then the round evaluates."""
    cfg, prog = run.cfg, run.prog
    t0 = time.perf_counter()
    steps = cfg.grad_steps_first if rnd == 0 else cfg.grad_steps_per_round
    prog.grad_step = run.student.train_steps(
        run.demos,
        prog.grad_step,
        steps,
        cfg.batch_size,
        run.rng,
        f"round {rnd} training",
        prog.losses,
        stop=lambda: guard.requested,
    )
    prog.train_s += time.perf_counter() - t0
    if prog.grad_step >= steps:
        prog.phase = "eval"


def _evaluate(
    run: DaggerRunState, route: _Route, guard: InterruptGuard, rnd: int, beta: float
) -> bool:
    """Evaluate the round's student; write its policy files (and `policy.pt` if it is the
    best so far), the state at the next round's start and the history. False if Ctrl-C
    abandoned the evaluation (it changes nothing; it runs again on resume)."""
    cfg, out = run.cfg, route.out
    t0 = time.perf_counter()
    try:
        with guard.abortable():
            summary = evaluate_student(run.student, run.env_cfg, cfg, route.response)
    except KeyboardInterrupt:
        return False
    entry = _round_entry(run.prog, summary, time.perf_counter() - t0, beta, len(run.demos))
    run.history.append(entry)
    wall = sum(h["collect_s"] + h["train_s"] + h["eval_s"] for h in run.history)
    round_meta = {
        **route.meta,
        "provenance": {
            "route": "dagger",
            "variant": route.variant,
            "command": route.command,
            "round": rnd,
            "seed": cfg.seed,
            "config": to_plain(cfg),
            "samples": len(run.demos),
            "wall_seconds": round(wall, 1),
            "training_seeds": [
                cfg.train_seed_offset,
                cfg.train_seed_offset + run.episode_counter - 1,
            ],
            "selection_seeds": [
                cfg.eval_seed_offset,
                cfg.eval_seed_offset + cfg.eval_episodes - 1,
            ],
            "eval_SR": summary["SR"],
        },
    }
    save_policy(out / f"policy_round{rnd}.pt", run.student.model, round_meta)
    if summary["SR"] >= run.best_sr:
        run.best_sr = summary["SR"]
        save_policy(out / "policy.pt", run.student.model, round_meta)
    run.prog = RoundProgress(round=rnd + 1)
    run.save(out / STATE_FILE)
    write_text_atomic(out / "history.json", json.dumps(run.history, indent=2), durable=True)
    return True


def _round_entry(
    prog: RoundProgress, summary: dict, eval_s: float, beta: float, samples: int
) -> dict:
    """The round's history entry; printed as one line."""
    loss = float(np.mean(prog.losses[-100:]))
    entry = {
        "round": prog.round,
        "beta": beta,
        "samples": samples,
        "loss": loss,
        "rollout_success": prog.outcomes.count("success") / len(prog.outcomes),
        "eval": summary,
        "collect_s": prog.collect_s,
        "train_s": prog.train_s,
        "eval_s": eval_s,
    }
    print(
        f"round {prog.round}: {samples} samples, loss {loss:.3f}, rollouts SR "
        f"{entry['rollout_success']:.2f} | student: {format_summary(summary)} "
        f"[{prog.collect_s:.0f}+{prog.train_s:.0f}+{eval_s:.0f} s]",
        flush=True,
    )
    return entry
