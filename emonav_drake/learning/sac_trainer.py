"""The SAC training loop: `emonav train --algo sac`.

Progress bar, periodic evaluation (deterministic policy, `eval_episodes` held-out
seeds every `eval_every` steps, the paper: 100 every 2e4), TensorBoard logs and a CSV
learning curve, checkpoints every `checkpoint_every` steps, at the end and on Ctrl-C.

The run directory (`out`):

* `checkpoint.pt` — everything the run needs to continue: networks, optimisers,
  temperature, replay buffer, the environment mid-episode (scenario, robot, crowd,
  tracker, frame stack), the running episode's frame window, every random state (numpy,
  python `random`, torch CPU and CUDA) and the counters. Format `emonav-sac-checkpoint/2`
  (`learning/run_state.py`): plain data as JSON plus arrays and tensors, read with
  `torch.load(weights_only=True)`, so loading it never runs code. Written atomically.
* `policy.pt` — the current actor as a policy checkpoint (`planners/policy.py`).
* `learning_curve.csv`, `tensorboard/` — the evaluations.

`--resume DIR` continues exactly where the run stopped: the final weights are
bit-for-bit those of an uninterrupted run. Ctrl-C stops at a consistent point: the
current step (environment step, replay insertion, updates) finishes, an evaluation in
progress is abandoned and rolled back (it runs again on resume), then the checkpoint is
saved and `RunInterrupted` says where; a second Ctrl-C meanwhile is ignored.
"""

from __future__ import annotations

import dataclasses as dc
import logging
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import torch
from tqdm import tqdm

from emonav_drake.errors import RunInterrupted
from emonav_drake.learning.env import EmoNavLIPEnv
from emonav_drake.learning.env_pool import EnvPool, make_env, make_envs
from emonav_drake.learning.replay import FrameReplayBuffer
from emonav_drake.learning.run_state import (
    SAC_FORMAT,
    InterruptGuard,
    RunStateError,
    check_state,
    clean_stale_temp_files,
    config_changes,
    read_run_state,
    rng_state,
    set_rng_state,
    write_run_state,
)
from emonav_drake.learning.sac import SacAgent
from emonav_drake.learning.sac_config import SacConfig
from emonav_drake.learning.sac_curve import (
    CHECKPOINT,
    CURVE,
    append_curve_row,
    check_curve,
    open_tensorboard,
    truncate_curve,
)
from emonav_drake.navigation.metrics import record_from_json, summarize
from emonav_drake.navigation.observations import observation_kind
from emonav_drake.params import EmoNavConfig
from emonav_drake.planners.policy import encoder_spec, save_policy, vector_state
from emonav_drake.progress import progress_bar

if TYPE_CHECKING:
    from emonav_drake.learning.digit_env import EmoNavDigitEnv

log = logging.getLogger(__name__)
TRAIN_SEED_OFFSET = 20_000_000


class _Episode:
    """The running episode's frame window and vector state (for the replay buffer)."""

    def __init__(self, replay: FrameReplayBuffer, obs: dict, bounds: tuple[float, float]):
        self.replay, self.bounds = replay, bounds
        self.key = next(k for k in ("scan", "image", "lgm") if k in obs)
        fid = replay.add_frame(replay.newest(obs[self.key]))
        self.window = np.full(replay.num_frames, fid, np.int64)
        self.state = vector_state(obs["goal"], obs["last_action"], bounds)
        self.obs = obs[self.key]

    def advance(self, obs: dict) -> None:
        fid = self.replay.add_frame(self.replay.newest(obs[self.key]))
        self.window = np.r_[self.window[1:], fid]
        self.state = vector_state(obs["goal"], obs["last_action"], self.bounds)
        self.obs = obs[self.key]

    def to_plain(self) -> dict:
        """The window (frame ids in the replay buffer), vector state and observation."""
        return {"key": self.key, "window": self.window, "state": self.state, "obs": self.obs}

    @classmethod
    def from_plain(
        cls, replay: FrameReplayBuffer, st: dict, bounds: tuple[float, float]
    ) -> _Episode:
        """Inverse of `to_plain` (`ValueError` if it does not fit the buffer)."""
        window = np.asarray(st["window"])
        if (
            window.dtype != np.int64
            or window.shape != (replay.num_frames,)
            or not ((window >= 0) & (window < len(replay.frames))).all()
        ):
            raise ValueError(f"episode window {window!r} does not fit the replay buffer")
        if st["key"] not in ("scan", "image", "lgm"):
            raise ValueError(f"episode observation key {st['key']!r}")
        ep = object.__new__(cls)
        ep.replay, ep.bounds, ep.key = replay, bounds, st["key"]
        ep.window, ep.state, ep.obs = window, np.asarray(st["state"]), np.asarray(st["obs"])
        return ep


def evaluate(agent: SacAgent, cfg: SacConfig, episodes: int) -> dict:
    """Deterministic policy on held-out seeds (evaluation goal radius 0.2 m)."""
    env = make_env(cfg, goal_radius=EmoNavConfig().episode.eval_goal_radius)
    records, returns = [], []
    for i in range(episodes):
        obs, _ = env.reset(seed=cfg.eval_seed_offset + i)
        total, done = 0.0, False
        while not done:
            state = vector_state(obs["goal"], obs["last_action"], agent.bounds)
            command = agent.to_command(agent.act(obs[env.map_key], state, deterministic=True))
            obs, r, term, trunc, info = env.step(command)
            total += r
            done = term or trunc
        records.append(record_from_json(info["episode_record"]))
        returns.append(total)
    return summarize(records) | {"return_mean": float(np.mean(returns))}


def policy_meta(cfg: SacConfig, env: EmoNavLIPEnv | EmoNavDigitEnv) -> dict:
    enc = encoder_spec(
        cfg.grid_kind,
        cfg.encoder,
        cfg.num_frames,
        cfg.grid_size,
        features=cfg.features,
        filters=cfg.filters,
        pool=cfg.pool,
    )
    r = env.config.robot
    return {
        "kind": "gaussian",
        "encoder": enc,
        "hidden": cfg.hidden,
        "observation": {
            "grid_kind": cfg.grid_kind,
            "num_frames": cfg.num_frames,
            "grid_size": cfg.grid_size,
        },
        "bounds": [r.max_speed, r.max_heading_change],
    }


def train_sac(
    out: str | Path,
    cfg: SacConfig,
    resume: bool = False,
    stop_at: int | None = None,
    progress: bool = True,
    ray_address: str | None = None,
    parallel: bool = True,
    resume_command: str | None = None,
) -> SacAgent:
    """Train (or resume) a SAC run in `out`; returns the agent.

    `stop_at` ends the run early after that many steps as an interruption would (a
    checkpoint is written), for tests and for splitting a long run. With `cfg.num_envs`
    > 1 the environments step together, on Ray actors (a local Ray, or the cluster at
    `ray_address`) unless `parallel` is False; the result does not depend on where they
    run (`learning/env_pool.py`). One iteration then takes `num_envs` environment steps
    (env 0's first), inserts them in that order and makes `num_envs × updates_per_step`
    updates; evaluations and checkpoints fall due when the step count crosses a multiple
    of their period, and the run ends at the first multiple of `num_envs` ≥ `total_steps`.
    `resume_command` is the command that continues the run, quoted after Ctrl-C (default:
    `emonav train --algo sac --resume OUT`).

    Raises:
        RunStateError: `resume` and `out` has no checkpoint, or one that is damaged, of
            an older format, not ours, or does not fit `cfg`; or a damaged
            `learning_curve.csv`.
        RunInterrupted: after Ctrl-C, once the checkpoint is saved.
    """
    out = Path(out)
    ckpt_path = out / CHECKPOINT
    saved: dict = {}
    tensors: dict = {}
    if resume:
        if not ckpt_path.is_file():
            raise RunStateError(
                f"no SAC checkpoint ({CHECKPOINT}) in {out}: nothing to resume "
                f"(start a new run with --out {out})"
            )
        saved, tensors = read_run_state(ckpt_path, SAC_FORMAT)  # before any work
        rows = check_state(f"{CHECKPOINT} in {out}", lambda: int(saved["curve_rows"]))
        check_curve(out / CURVE, rows)
    out.mkdir(parents=True, exist_ok=True)
    for p in clean_stale_temp_files(out):
        log.info("removed %s, left by a save that was killed", p)
    torch.set_num_threads(cfg.threads)
    torch.manual_seed(cfg.seed)
    rng = np.random.default_rng(cfg.seed)
    envs = make_envs(cfg, ray_address, parallel)
    try:
        hint = resume_command or f"emonav train --algo sac --resume {out} (same --config)"
        return _train(out, cfg, envs, rng, saved, tensors, progress, stop_at, hint)
    finally:
        envs.close()


def _train(
    out: Path,
    cfg: SacConfig,
    envs: EnvPool,
    rng: np.random.Generator,
    saved: dict,
    tensors: dict,
    progress: bool,
    stop_at: int | None,
    resume_command: str,
) -> SacAgent:
    """The run in `out`, from its start (or the checkpoint `saved`, `tensors`) to `stop_at`
    or the end; the steps are `_Run`'s methods.

    One iteration = one environment step, its replay insertion, the updates and the
    episode reset; the evaluation and checkpoint due at a step run at the top of the next
    iteration. Ctrl-C is polled between iterations (replay size = step there). An
    evaluation in progress is abandoned at once and rolled back (it does not change the
    agent; its random draws are undone), and the checkpoint records that it is due.
    """
    run = _Run(out, cfg, envs, rng)
    if saved:
        run.restore(saved, tensors)
    else:
        run.start()
    truncate_curve(run.curve, run.curve_rows)  # drop rows of evaluations after the checkpoint
    writer = open_tensorboard(out)
    end = cfg.total_steps if stop_at is None else min(stop_at, cfg.total_steps)
    bar = progress_bar(
        total=cfg.total_steps, initial=run.step, desc="SAC", unit="step", enabled=progress
    )
    with InterruptGuard() as guard:
        try:
            while True:
                if run.eval_pending and not run.evaluate(guard, writer, bar):
                    break  # Ctrl-C during the evaluation: rolled back, still due
                run.checkpoint_if_due()
                if guard.requested or run.step >= end:
                    break
                run.iterate(writer)
                bar.update(run.n_envs)
        finally:
            bar.close()
            if writer is not None:
                writer.close()
        interrupted = guard.requested and (run.step < end or run.eval_pending)
        if interrupted:
            log.warning("interrupted at step %d: saving the checkpoint", run.step)
        if run.saved_at != (run.step, run.eval_pending):
            run.save()
        if guard.extra:
            log.warning("Ctrl-C pressed again while stopping: ignored (the save completed)")
    if interrupted:
        raise RunInterrupted(
            f"interrupted at step {run.step} of {cfg.total_steps}; checkpoint saved in {out}; "
            f"continue with `{resume_command}`"
        )
    return run.agent


class _Run:
    """One SAC run's agent, replay buffer, running episodes and counters: what the steps of
    `_train` share and the checkpoint holds.

    `step` environment steps taken (= replay insertions), `episodes` finished,
    `eval_pending` the evaluation due at `step` has not run, `curve_rows` evaluations in
    the learning curve, `saved_at` the (step, eval_pending) of the last save (None: none).
    """

    def __init__(self, out: Path, cfg: SacConfig, envs: EnvPool, rng: np.random.Generator) -> None:
        self.out, self.cfg, self.envs, self.rng = out, cfg, envs, rng
        self.env = env = envs.spec
        self.bounds = (env.config.robot.max_speed, env.config.robot.max_heading_change)
        self.agent = SacAgent(cfg, self.bounds)
        space = env.observation_space[env.map_key]
        kind = observation_kind(cfg.grid_kind)
        self.replay = FrameReplayBuffer(
            cfg.replay_size,
            kind.item_shape(env.config.lidar),
            space.dtype.type,
            cfg.num_frames,
            kind,
        )
        self.curve = out / CURVE
        self.n_envs = len(envs)
        self.step, self.episodes, self.eval_pending, self.curve_rows = 0, 0, False, 0
        self.saved_at: tuple[int, bool] | None = None
        self.running: list[_Episode] = []

    def start(self) -> None:
        """A new run: environment i starts with training scenario i."""
        for i in range(self.n_envs):
            self.running.append(
                _Episode(self.replay, self.envs.reset(i, TRAIN_SEED_OFFSET + i), self.bounds)
            )

    def restore(self, saved: dict, tensors: dict) -> None:
        """Continue from a checkpoint's state (`RunStateError` if it does not fit)."""
        cfg, n_envs = self.cfg, self.n_envs
        changes = config_changes(saved.get("config"), dc.asdict(cfg))
        if changes:
            log.warning(
                "resuming with a configuration that differs from the checkpoint's: %s",
                ", ".join(changes),
            )

        def restore() -> list[_Episode]:
            self.agent.load_state_dict(tensors["agent"])
            self.replay.load_state_dict(saved["replay"])
            set_rng_state(self.rng, saved["rng"], tensors)
            # one environment: the keys of checkpoints written before `num_envs`
            env_states = saved["envs"] if "envs" in saved else [saved["env"]]
            running = saved["running"] if "running" in saved else [saved["episode"]]
            self.envs.load_state_dicts(env_states)
            if len(running) != n_envs:
                raise ValueError(f"{len(running)} saved episodes for {n_envs} environments")
            return [_Episode.from_plain(self.replay, st, self.bounds) for st in running]

        self.running = check_state(f"{CHECKPOINT} in {self.out}", restore, changes)
        self.step, self.episodes = int(saved["step"]), int(saved["episodes"])
        self.eval_pending = bool(saved["eval_pending"])
        self.curve_rows = int(saved["curve_rows"])
        self.saved_at = (self.step, self.eval_pending)

    def save(self) -> None:
        """Write `checkpoint.pt` and `policy.pt` (module docstring)."""
        cfg, running = self.cfg, self.running
        rng_plain, rng_tensors = rng_state(self.rng)
        state = {
            "config": dc.asdict(cfg),
            "step": self.step,
            "episodes": self.episodes,
            "eval_pending": self.eval_pending,  # the evaluation due at `step` has not run
            "curve_rows": self.curve_rows,
            "rng": rng_plain,
            "envs": self.envs.state_dicts(),
            "running": [ep.to_plain() for ep in running],
            "replay": self.replay.state_dict(windows=[ep.window for ep in running]),
        }
        write_run_state(
            self.out / CHECKPOINT,
            SAC_FORMAT,
            state,
            {"agent": self.agent.state_dict()} | rng_tensors,
        )
        save_policy(
            self.out / "policy.pt",
            self.agent.actor,
            policy_meta(cfg, self.env)
            | {"provenance": {"route": "sac", "step": self.step, "config": dc.asdict(cfg)}},
        )
        self.saved_at = (self.step, self.eval_pending)

    def evaluate(self, guard: InterruptGuard, writer, bar: tqdm) -> bool:
        """Run the due evaluation and log it; False if Ctrl-C abandoned it (its random
        draws undone, still due)."""
        before = rng_state(self.rng)
        try:
            with guard.abortable():
                summary = evaluate(self.agent, self.cfg, self.cfg.eval_episodes)
        except KeyboardInterrupt:
            set_rng_state(self.rng, *before)
            return False
        self.eval_pending = False
        self.curve_rows += 1
        append_curve_row(self.curve, self.step, self.episodes, summary, self.agent)
        if writer is not None:
            for k in ("SR", "collision_rate", "timeout_rate", "DT", "return_mean"):
                writer.add_scalar(f"eval/{k}", summary[k], self.step)
        bar.set_postfix(SR=summary["SR"])
        return True

    def checkpoint_if_due(self) -> None:
        """Save if the last iteration crossed a checkpoint period and this state is unsaved."""
        step = self.step
        if (
            step > 0
            and _crossed(step, self.n_envs, self.cfg.checkpoint_every)
            and self.saved_at != (step, False)
        ):
            self.save()

    def iterate(self, writer) -> None:
        """One iteration: every environment acts and steps, the transitions go into the
        replay buffer (env 0's first), the updates, the ended episodes' resets."""
        actions = self._actions()
        results = self.envs.step([self.agent.to_command(a) for a in actions])
        ended = self._store(results, actions)
        self._update(writer)
        self._next_episodes(ended)
        self.step += self.n_envs
        self.eval_pending = _crossed(self.step, self.n_envs, self.cfg.eval_every)

    def _actions(self) -> list[np.ndarray]:
        """Each environment's action: uniform during the first `random_steps`, else sampled
        from the policy."""
        actions = []
        for i, ep in enumerate(self.running):
            if self.step + i < self.cfg.random_steps:
                actions.append(self.rng.uniform(-1.0, 1.0, 2).astype(np.float32))
            else:
                actions.append(self.agent.act(ep.obs, ep.state, deterministic=False))
        return actions

    def _store(self, results: list, actions: list[np.ndarray]) -> list[int]:
        """Insert the transitions in the order of the environments; the ones that ended."""
        ended = []
        for i, (ep, action) in enumerate(zip(self.running, actions, strict=True)):
            obs, reward, term, trunc, _ = results[i]
            obs_ids, state = ep.window.copy(), ep.state
            ep.advance(obs)
            self.replay.add(obs_ids, state, action, reward, ep.window, ep.state, term)
            if term or trunc:
                ended.append(i)
        return ended

    def _update(self, writer) -> None:
        """`updates_per_step` updates per environment step past `random_steps`."""
        cfg, agent, step = self.cfg, self.agent, self.step
        for k in range(self.n_envs):
            if step + k < cfg.random_steps:
                continue
            for _ in range(cfg.updates_per_step):
                info = agent.update(self.replay.sample(cfg.batch_size, self.rng, agent.device))
            if writer is not None and (step + k) % 100 == 0:
                for key, v in info.items():
                    writer.add_scalar(f"train/{key}", v, step + k)

    def _next_episodes(self, ended: list[int]) -> None:
        """Reset the ended environments to the next scenarios, in the order of the
        environments."""
        for i in ended:
            self.episodes += 1
            seed = TRAIN_SEED_OFFSET + self.n_envs - 1 + self.episodes
            self.running[i] = _Episode(self.replay, self.envs.reset(i, seed), self.bounds)


def _crossed(step: int, stride: int, period: int) -> bool:
    """Whether the last `stride` steps up to `step` reached a multiple of `period`."""
    return step // period > (step - stride) // period
