"""Fine-tuning a categorical student by discrete soft actor-critic (`emonav train --algo
finetune`): a learning stage that can exceed its teacher.

The DAgger routes imitate an expert and stay below it. This stage starts from a trained
student (a DAgger route's `policy.pt`, kind "categorical": the frozen encoder over the
observation stack, a trainable head over the command grid; `learning/finetune_agent.py`)
and improves it on the paper's reward (`navigation/reward.py`, Eq. 6–9) in the route's reduced
world: `navigation.lip_world.NavigationWorld` on the LIP, or on the Digit-calibrated robot when
`FinetuneConfig.response` names a step-response model ("digit": the shipped one).

* **Training episodes**: scenario seeds `train_seed_offset + i` (default 2 000 000 …,
  disjoint from the DAgger routes' 1 000 000 … and from the evaluation seeds 0–499),
  goal radius `goal_radius` [m]. Each walking step (T = 0.4 s) the actor samples a command
  of the grid from the frozen encoder's features of `world.planner_input().lgm_stack` and
  the vector state; the transition (features, state, action index, reward, next features
  and state, done) goes to the replay buffer once the episode is over. Collision and
  success are terminal; a timeout is not (its last value is bootstrapped).
* **Updates**: after each episode, until `updates_per_step` per environment step past
  `learning_starts` are done (the first `critic_warmup` train the critics only).
* **Selection that cannot peek**: before the first update (the starting point) and every
  `eval_every` environment steps (and at the end), the greedy actor runs the selection
  seeds `eval_seed_offset + i` (default 600 000 …, `eval_episodes` of them) in the same
  world. The best — highest SR; ties: lower collision rate, then lower DT; an exact tie
  keeps the earlier, nearer the student — is `policy.pt`: an ordinary categorical policy
  (the frozen encoder and the fine-tuned head) that `PolicyPlanner` and `emonav
  sim|benchmark --planner policy --checkpoint` run unchanged, with its provenance (the
  initial policy and its provenance, the configurations, the seed ranges, wall time per
  phase, the steps and updates at selection, the history so far).

The run directory (`out`): `policy.pt`, `history.json` (one entry per evaluation) and
`finetune_state.pt`, the state `--resume DIR` continues from (`learning/finetune_state.py`),
written after every evaluation, at the end and on Ctrl-C. Ctrl-C stops at a consistent
point: an episode being collected is undone (its random draws; nothing of it was stored)
and collected again on resume, an update finishes, an evaluation is abandoned (it runs
first on resume). Everything is seeded by `cfg.seed`: a resumed run ends bit for bit where
an uninterrupted one does.
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
from tqdm import tqdm

from emonav_drake.atomic_io import write_text_atomic
from emonav_drake.errors import RunInterrupted
from emonav_drake.learning.config_common import with_run_family, with_run_world
from emonav_drake.learning.finetune_agent import DiscreteSac, check_observation, load_init
from emonav_drake.learning.finetune_state import (
    STATE_FILE,
    Progress,
    history_entry,
    new_stats,
    policy_meta,
    read_finetune_state,
    restore_finetune_state,
    write_finetune_state,
)
from emonav_drake.learning.replay import FrameReplayBuffer
from emonav_drake.learning.run_state import (
    InterruptGuard,
    RunStateError,
    check_state,
    clean_stale_temp_files,
    config_changes,
    rng_state,
    set_rng_state,
)
from emonav_drake.learning.sac_config import FinetuneConfig
from emonav_drake.navigation.lip_world import NavigationWorld
from emonav_drake.navigation.metrics import COLLISION, SUCCESS, format_summary, summarize
from emonav_drake.params import ConfigError, EmoNavConfig
from emonav_drake.planners.model_aware import load_response
from emonav_drake.planners.policy import (
    build_model,
    goal_input_of,
    save_policy,
    vector_state,
)
from emonav_drake.progress import progress_bar
from emonav_drake.robot.step_response import StepResponseModel
from emonav_drake.scenarios.scenario import sample_scenario
from emonav_drake.torch_device import resolve_device

log = logging.getLogger(__name__)


def train_finetune(
    out: str | Path,
    cfg: FinetuneConfig | None = None,
    init: str | None = None,
    env_cfg: EmoNavConfig | None = None,
    resume: bool = False,
    command: str | None = None,
    resume_command: str | None = None,
    progress: bool = True,
) -> Path:
    """Fine-tune the student `init` ("shipped", a shipped variant's name or a policy file)
    into `out` (or continue the run there: `resume`); returns `out/policy.pt`.

    `env_cfg` is the world's configuration (default: the paper's); its
    `lidar.num_frames` must be the student's. After Ctrl-C the message quotes
    `resume_command` (default: `emonav train --algo finetune --resume OUT`).

    Raises:
        ConfigError: no `init` for a new run, or one that is missing, not a categorical
            student or reads another observation than the world gives.
        RunStateError: `resume` and `out` has no fine-tuning state, or one that is
            damaged, not ours or does not fit.
        RunInterrupted: after Ctrl-C, once the state is saved.
    """
    cfg = (cfg or FinetuneConfig()).validate()
    env_cfg = with_run_world(copy.deepcopy(env_cfg or EmoNavConfig()), cfg)
    with_run_family(env_cfg, cfg.family)  # scenes to train and select in
    out = Path(out)
    device = resolve_device(cfg.device, "device")
    path = out / STATE_FILE
    saved: dict = {}
    tensors: dict = {}
    if resume:
        if not path.is_file():
            raise RunStateError(
                f"no fine-tuning state ({STATE_FILE}) in {out}: nothing to resume "
                f"(start a new run with --init POLICY --out {out})"
            )
        _, saved, tensors = read_finetune_state(path)  # before any work
        meta = saved["init"]["meta"]
        where = f"{STATE_FILE} in {out}"

        def rebuild() -> torch.nn.Module:
            check_observation(meta, env_cfg, "its initial policy")
            return build_model(meta)

        model = check_state(where, rebuild)
        init_info = saved["init"]
    else:
        if init is None:
            raise ConfigError("no initial policy: give --init PATH|shipped (a categorical student)")
        init_path, model, meta = load_init(init, env_cfg, cfg.device)
        init_info = {"path": str(init_path), "meta": meta}
    out.mkdir(parents=True, exist_ok=True)
    for p in clean_stale_temp_files(out):
        log.info("removed %s, left by a save that was killed", p)
    torch.set_num_threads(cfg.threads)
    torch.manual_seed(cfg.seed)
    rng = np.random.default_rng(cfg.seed)
    run = _Run(out, cfg, env_cfg, init_info, DiscreteSac(cfg, model, device), rng, command)
    if resume:
        run.restore(saved, tensors)
    hint = resume_command or f"emonav train --algo finetune --resume {out} (same --config)"
    run.train(progress, hint)
    return out / "policy.pt"


class _Run:
    """One fine-tuning run: the learner, replay buffer, generator and progress, and the
    steps of its loop (`train`)."""

    def __init__(
        self,
        out: Path,
        cfg: FinetuneConfig,
        env_cfg: EmoNavConfig,
        init: dict,
        agent: DiscreteSac,
        rng: np.random.Generator,
        command: str | None,
    ) -> None:
        self.out, self.cfg, self.env_cfg, self.init = out, cfg, env_cfg, init
        self.agent, self.rng, self.command = agent, rng, command
        self.response: StepResponseModel | None = load_response(cfg.response)
        meta = init["meta"]
        self.grid_kind = meta["observation"]["grid_kind"]
        self.goal_input = goal_input_of(meta)  # the initial student's (`navigation/goal_input.py`)
        self.commands = np.asarray(meta["commands"], dtype=float)
        self.bounds = (env_cfg.robot.max_speed, env_cfg.robot.max_heading_change)
        # one "frame" per step: the encoder's features; windows of one frame
        self.replay = FrameReplayBuffer(cfg.replay_size, (agent.features,), np.float32, 1)
        self.prog = Progress()
        self.saved_at: tuple | None = None  # (env steps, updates, eval pending) of the file

    def restore(self, saved: dict, tensors: dict) -> None:
        """Continue from a saved state (`RunStateError` if it does not fit), warning first
        of the configuration fields that differ from the saved run's."""
        changes = config_changes(
            {"config": saved["config"], "env": saved["env_config"]},
            {"config": dc.asdict(self.cfg), "env": dc.asdict(self.env_cfg)},
        )
        if changes:
            log.warning(
                "resuming with a configuration that differs from the saved one: %s",
                ", ".join(changes),
            )
        where = f"{STATE_FILE} in {self.out}"
        self.prog = check_state(
            where,
            lambda: restore_finetune_state(saved, tensors, self.agent, self.replay, self.rng),
            changes,
        )
        self.saved_at = self._marker()
        log.info("resumed at step %d (%d updates)", self.prog.env_steps, self.agent.updates)

    def _marker(self) -> tuple:
        return (self.prog.env_steps, self.agent.updates, self.prog.eval_pending)

    def save(self) -> None:
        write_finetune_state(
            self.out / STATE_FILE,
            self.cfg,
            self.env_cfg,
            self.init,
            self.prog,
            self.agent,
            self.replay,
            self.rng,
        )
        self.saved_at = self._marker()

    def updates_due(self) -> int:
        """Updates the run owes after `env_steps` steps."""
        past = self.prog.env_steps - self.cfg.learning_starts
        return int(past * self.cfg.updates_per_step) if past > 0 else 0

    def finished(self) -> bool:
        prog = self.prog
        return (
            prog.env_steps >= self.cfg.total_steps
            and self.agent.updates >= self.updates_due()
            and not prog.eval_pending
        )

    def train(self, progress: bool, resume_command: str) -> None:
        """The loop: owed updates, then the due evaluation, then the next episode."""
        cfg, prog = self.cfg, self.prog
        bar = progress_bar(
            total=cfg.total_steps,
            initial=min(prog.env_steps, cfg.total_steps),
            desc="finetune",
            unit="step",
            enabled=progress,
        )
        self._postfix(bar)
        with InterruptGuard() as guard:
            try:
                while not guard.requested:
                    if self.agent.updates < self.updates_due():
                        self._update(guard)
                    elif prog.eval_pending:
                        if not self._evaluate(guard, bar):
                            break  # Ctrl-C: abandoned, still due
                    elif prog.env_steps >= cfg.total_steps:
                        break
                    else:
                        steps = self._collect(guard)
                        self._postfix(bar)
                        bar.update(steps)
            finally:
                bar.close()
            interrupted = guard.requested and not self.finished()
            if self.saved_at != self._marker():
                if interrupted:
                    log.warning("interrupted at step %d: saving the state", prog.env_steps)
                self.save()
            if guard.extra:
                log.warning("Ctrl-C pressed again while stopping: ignored (the save completed)")
        if interrupted:
            raise RunInterrupted(
                f"interrupted at step {prog.env_steps} of {cfg.total_steps} "
                f"({self.agent.updates} updates); state saved in {self.out}; continue with "
                f"`{resume_command}`"
            )

    def _postfix(self, bar: tqdm) -> None:
        """The bar's last evaluation SR, update count and α (shown at the next refresh)."""
        last = self.prog.history[-1]["eval"]["SR"] if self.prog.history else None
        bar.set_postfix(
            SR=last, upd=self.agent.updates, alpha=f"{self.agent.alpha:.3g}", refresh=False
        )

    # ------------------------------------------------------------------ the phases

    def _world(self, seed: int) -> NavigationWorld:
        return NavigationWorld(
            sample_scenario(seed, self.env_cfg),
            self.env_cfg,
            goal_radius=self.cfg.goal_radius,
            grid_kind=self.grid_kind,
            response=self.response,
        )

    def _observe(self, world: NavigationWorld) -> tuple[np.ndarray, np.ndarray]:
        obs = world.planner_input()
        goal = obs.policy_goal_state(self.goal_input, self.env_cfg.robot.radius)
        state = vector_state(goal, obs.last_command, self.bounds)
        return self.agent.encode(obs.lgm_stack), state

    def _collect(self, guard: InterruptGuard) -> int:
        """One training episode by the sampling actor, stored whole; its steps (0 if
        Ctrl-C undid it)."""
        cfg, prog = self.cfg, self.prog
        t0 = time.perf_counter()
        before = rng_state(self.rng)
        try:
            with guard.abortable():
                world = self._world(cfg.train_seed_offset + prog.episodes)
                features, states = self._observe(world)
                feats, sts, actions, rewards = [features], [states], [], []
                outcome = None
                while outcome is None:
                    a = self.agent.act(feats[-1], sts[-1], self.rng, cfg.temperature)
                    evaluation, outcome = world.step(self.commands[a])
                    actions.append(a)
                    rewards.append(evaluation.reward)
                    features, states = self._observe(world)
                    feats.append(features)
                    sts.append(states)
        except KeyboardInterrupt:
            set_rng_state(self.rng, *before)
            prog.collect_s += time.perf_counter() - t0
            return 0
        ids = [self.replay.add_frame(f) for f in feats]
        terminal = outcome in (SUCCESS, COLLISION)  # a timeout is bootstrapped
        n = len(actions)
        for t in range(n):
            self.replay.add(
                ids[t : t + 1],
                sts[t],
                np.array([actions[t], 0.0], np.float32),
                rewards[t],
                ids[t + 1 : t + 2],
                sts[t + 1],
                terminal and t == n - 1,
            )
        before_steps = prog.env_steps
        prog.env_steps += n
        prog.episodes += 1
        stats = prog.since
        stats["episodes"] += 1
        stats["successes"] += outcome == SUCCESS
        stats["collisions"] += outcome == COLLISION
        period = cfg.eval_every
        crossed = prog.env_steps // period > before_steps // period
        prog.eval_pending = crossed or prog.env_steps >= cfg.total_steps
        prog.collect_s += time.perf_counter() - t0
        return min(prog.env_steps, cfg.total_steps) - min(before_steps, cfg.total_steps)

    def _update(self, guard: InterruptGuard) -> None:
        """The owed updates; stops early after the update during which Ctrl-C came."""
        cfg, agent, stats = self.cfg, self.agent, self.prog.since
        t0 = time.perf_counter()
        device = agent.device
        while agent.updates < self.updates_due() and not guard.requested:
            info = agent.update(self.replay.sample(cfg.batch_size, self.rng, device))
            stats["updates"] += 1
            stats["critic_loss"] += info["critic_loss"]
            stats["entropy"] += info["entropy"]
            if "actor_loss" in info:
                stats["actor_updates"] += 1
                stats["actor_loss"] += info["actor_loss"]
                stats["kl"] += info.get("kl", 0.0)
        self.prog.update_s += time.perf_counter() - t0

    def evaluate(self) -> dict:
        """The greedy actor on the selection seeds in the training world (`summarize`)."""
        cfg, records = self.cfg, []
        for i in range(cfg.eval_episodes):
            world = self._world(cfg.eval_seed_offset + i)
            outcome = None
            while outcome is None:
                a = self.agent.act(*self._observe(world))
                _, outcome = world.step(self.commands[a])
            records.append(world.record)
        return summarize(records)

    def _evaluate(self, guard: InterruptGuard, bar: tqdm) -> bool:
        """The due evaluation; the selection, `history.json` and the state. False if Ctrl-C
        abandoned it (it changed nothing; it runs again on resume)."""
        prog, agent = self.prog, self.agent
        t0 = time.perf_counter()
        try:
            with guard.abortable():
                summary = self.evaluate()
        except KeyboardInterrupt:
            prog.eval_s += time.perf_counter() - t0
            return False
        prog.eval_s += time.perf_counter() - t0
        key = [summary["SR"], -summary["collision_rate"], -summary["DT"]]
        selected = prog.best is None or key > prog.best
        entry = history_entry(prog, agent, summary, selected)
        prog.history.append(entry)
        prog.since, prog.eval_pending = new_stats(), False
        if selected:
            prog.best = key
            prog.best_at = {k: entry[k] for k in ("env_steps", "updates", "episodes")}
            meta = policy_meta(self.init, self.cfg, self.env_cfg, prog, agent, self.command)
            save_policy(self.out / "policy.pt", agent.policy, meta)
        write_text_atomic(
            self.out / "history.json", json.dumps(prog.history, indent=2), durable=True
        )
        self.save()
        self._postfix(bar)
        bar.refresh()
        tqdm.write(
            f"step {prog.env_steps} ({agent.updates} updates, α {agent.alpha:.4f}): "
            f"{format_summary(summary)}{' — selected' if selected else ''}"
        )
        return True
