"""The SAC training loop: `emonav train --algo sac`.

Progress bar, periodic evaluation (deterministic policy, `eval_episodes` held-out
seeds every `eval_every` steps, the paper: 100 every 2e4), TensorBoard logs and a CSV
learning curve, checkpoints written atomically every `checkpoint_every` steps and on
Ctrl-C. A checkpoint holds everything — networks, optimisers, temperature, replay
buffer, the environment mid-episode and every random state — so `--resume DIR`
continues exactly where the run stopped: the final weights are bit-for-bit those of an
uninterrupted run.
"""

from __future__ import annotations

import csv
import dataclasses as dc
import logging
import pickle
from pathlib import Path

import numpy as np
import torch
from tqdm import tqdm

from emonav_drake.core.metrics import summarize
from emonav_drake.learning.config import SacConfig
from emonav_drake.learning.env import EmoNavLIPEnv
from emonav_drake.learning.policy import atomic_torch_save, save_policy, vector_state
from emonav_drake.learning.replay import FrameReplayBuffer
from emonav_drake.learning.sac import SacAgent
from emonav_drake.params import EmoNavConfig

log = logging.getLogger(__name__)
TRAIN_SEED_OFFSET = 20_000_000


def make_env(
    cfg: SacConfig, env_cfg: EmoNavConfig | None = None, goal_radius: float | None = None
) -> EmoNavLIPEnv:
    """The training environment for the configured observation variant."""
    env_cfg = env_cfg or EmoNavConfig()
    env_cfg.lidar.num_frames = cfg.num_frames
    env_cfg.lidar.grid_size = cfg.grid_size
    return EmoNavLIPEnv(
        env_cfg,
        grid_kind=cfg.grid_kind,
        goal_radius=cfg.goal_radius if goal_radius is None else goal_radius,
    )


class _Episode:
    """The running episode's frame window and vector state (for the replay buffer)."""

    def __init__(self, replay: FrameReplayBuffer, obs: dict, bounds: tuple[float, float]):
        self.replay, self.bounds = replay, bounds
        self.key = next(k for k in ("scan", "image", "lgm") if k in obs)
        fid = replay.add_frame(obs[self.key][-1])
        self.window = np.full(replay.num_frames, fid, np.int64)
        self.state = vector_state(obs["goal"], obs["last_action"], bounds)
        self.obs = obs[self.key]

    def advance(self, obs: dict) -> None:
        fid = self.replay.add_frame(obs[self.key][-1])
        self.window = np.r_[self.window[1:], fid]
        self.state = vector_state(obs["goal"], obs["last_action"], self.bounds)
        self.obs = obs[self.key]


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
            obs, r, term, trunc, _ = env.step(command)
            total += r
            done = term or trunc
        records.append(env.world.record)
        returns.append(total)
    return summarize(records) | {"return_mean": float(np.mean(returns))}


def policy_meta(cfg: SacConfig, env: EmoNavLIPEnv) -> dict:
    if cfg.grid_kind == "scan" and cfg.encoder == "lstm":
        enc = {"type": "scan_lstm", "frames": cfg.num_frames, "features": cfg.features}
    elif cfg.grid_kind == "scan":
        enc = {
            "type": "scan",
            "frames": cfg.num_frames,
            "features": cfg.features,
            "filters": cfg.filters,
        }
    else:
        planes = cfg.num_frames * (3 if cfg.grid_kind == "drlvo" else 1)
        enc = {
            "type": "lgm",
            "frames": planes,
            "size": cfg.grid_size,
            "features": cfg.features,
            "filters": cfg.filters,
            "pool": cfg.pool,
        }
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
) -> SacAgent:
    """Train (or resume) a SAC run in `out`; returns the agent.

    `stop_at` ends the run early after that many steps as an interruption would (a
    checkpoint is written), for tests and for splitting a long run.
    """
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    torch.set_num_threads(cfg.threads)
    torch.manual_seed(cfg.seed)
    rng = np.random.default_rng(cfg.seed)
    env = make_env(cfg)
    bounds = (env.config.robot.max_speed, env.config.robot.max_heading_change)
    agent = SacAgent(cfg, bounds)
    space = env.observation_space[env.map_key]
    replay = FrameReplayBuffer(cfg.replay_size, space.shape[1:], space.dtype.type, cfg.num_frames)
    ckpt_path = out / "checkpoint.pt"
    step, episodes = 0, 0
    if resume:
        if not ckpt_path.is_file():
            raise FileNotFoundError(f"nothing to resume: {ckpt_path} does not exist")
        ck = torch.load(ckpt_path, weights_only=False)
        if ck["config"] != dc.asdict(cfg):
            log.warning("resuming with a configuration that differs from the checkpoint's")
        agent.load_state_dict(ck["agent"])
        replay.load_state_dict(ck["replay"])
        rng.bit_generator.state = ck["rng"]
        torch.set_rng_state(ck["torch_rng"])
        env = pickle.loads(ck["env"])
        episode = pickle.loads(ck["episode"])
        episode.replay = replay
        step, episodes = ck["step"], ck["episodes"]
    else:
        obs, _ = env.reset(seed=TRAIN_SEED_OFFSET + episodes)
        episode = _Episode(replay, obs, bounds)

    def save() -> None:
        ep = pickle.dumps(_detached(episode))
        atomic_torch_save(
            {
                "config": dc.asdict(cfg),
                "agent": agent.state_dict(),
                "replay": replay.state_dict(),
                "rng": rng.bit_generator.state,
                "torch_rng": torch.get_rng_state(),
                "env": pickle.dumps(env),
                "episode": ep,
                "step": step,
                "episodes": episodes,
            },
            ckpt_path,
        )
        save_policy(
            out / "policy.pt",
            agent.actor,
            policy_meta(cfg, env)
            | {"provenance": {"route": "sac", "step": step, "config": dc.asdict(cfg)}},
        )

    writer = _tensorboard(out)
    curve = out / "learning_curve.csv"
    end = cfg.total_steps if stop_at is None else min(stop_at, cfg.total_steps)
    bar = tqdm(total=cfg.total_steps, initial=step, desc="SAC", unit="step", disable=not progress)
    try:
        while step < end:
            if step < cfg.random_steps:
                action = rng.uniform(-1.0, 1.0, 2).astype(np.float32)
            else:
                action = agent.act(episode.obs, episode.state, deterministic=False)
            obs, reward, term, trunc, _ = env.step(agent.to_command(action))
            obs_ids, state = episode.window.copy(), episode.state
            episode.advance(obs)
            replay.add(obs_ids, state, action, reward, episode.window, episode.state, term)
            if step >= cfg.random_steps:
                for _ in range(cfg.updates_per_step):
                    info = agent.update(replay.sample(cfg.batch_size, rng, agent.device))
                if writer is not None and step % 100 == 0:
                    for k, v in info.items():
                        writer.add_scalar(f"train/{k}", v, step)
            if term or trunc:
                episodes += 1
                obs, _ = env.reset(seed=TRAIN_SEED_OFFSET + episodes)
                episode = _Episode(replay, obs, bounds)
            step += 1
            bar.update(1)
            if step % cfg.eval_every == 0:
                summary = evaluate(agent, cfg, cfg.eval_episodes)
                _append_csv(curve, step, episodes, summary, agent)
                if writer is not None:
                    for k in ("SR", "collision_rate", "timeout_rate", "DT", "return_mean"):
                        writer.add_scalar(f"eval/{k}", summary[k], step)
                bar.set_postfix(SR=summary["SR"])
            if step % cfg.checkpoint_every == 0:
                save()
    except KeyboardInterrupt:
        log.warning("interrupted at step %d: saving a checkpoint", step)
        save()
        raise
    finally:
        bar.close()
        if writer is not None:
            writer.close()
    save()
    return agent


def _detached(episode: _Episode) -> _Episode:
    """A copy of the episode bookkeeping without the (separately saved) replay buffer."""
    clone = object.__new__(_Episode)
    clone.__dict__.update({k: v for k, v in episode.__dict__.items() if k != "replay"})
    clone.replay = None
    return clone


def _append_csv(path: Path, step: int, episodes: int, s: dict, agent: SacAgent) -> None:
    new = not path.exists()
    with path.open("a", newline="") as f:
        w = csv.writer(f)
        if new:
            w.writerow(
                [
                    "step",
                    "episodes",
                    "SR",
                    "collision_rate",
                    "timeout_rate",
                    "NT_mean",
                    "DT",
                    "return_mean",
                    "alpha",
                ]
            )
        w.writerow(
            [
                step,
                episodes,
                s["SR"],
                s["collision_rate"],
                s["timeout_rate"],
                s["NT_mean"],
                s["DT"],
                s["return_mean"],
                agent.alpha.item(),
            ]
        )


def _tensorboard(out: Path):
    try:
        from torch.utils.tensorboard import SummaryWriter
    except ImportError:  # tensorboard is optional: the CSV has the learning curve
        log.warning("tensorboard is not installed: logging to learning_curve.csv only")
        return None
    return SummaryWriter(str(out / "tensorboard"))
