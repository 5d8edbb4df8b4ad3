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
(90 KB per stack would not fit; 10 KB per frame does). Everything is seeded; a run
checkpoints after every round (atomically) and `--resume` continues from the last one.
"""

from __future__ import annotations

import dataclasses as dc
import json
import logging
import time
from pathlib import Path

import numpy as np
import torch
from torch.nn import functional as F
from tqdm import tqdm

from emonav_drake.core.dwa import DwaPlanner
from emonav_drake.core.metrics import format_summary, summarize
from emonav_drake.core.navigation import NavigationWorld
from emonav_drake.core.scenario import sample_scenario
from emonav_drake.learning.config import DaggerConfig
from emonav_drake.learning.networks import CategoricalPolicy, LgmEncoder
from emonav_drake.learning.policy import atomic_torch_save, save_policy, vector_state
from emonav_drake.params import EmoNavConfig

log = logging.getLogger(__name__)


class FrameStore:
    """Append-only uint8 frames (F, M, M); samples refer to frames by index."""

    def __init__(self, size: int, capacity: int = 4096) -> None:
        self.frames = np.zeros((capacity, size, size), np.uint8)
        self.count = 0

    def add(self, frame: np.ndarray) -> int:
        if self.count == len(self.frames):
            grown = np.zeros((2 * len(self.frames), *self.frames.shape[1:]), np.uint8)
            grown[: self.count] = self.frames[: self.count]
            self.frames = grown
        self.frames[self.count] = frame
        self.count += 1
        return self.count - 1


@dc.dataclass
class Demonstrations:
    """Aggregated (observation, expert label) pairs."""

    store: FrameStore
    windows: list[np.ndarray] = dc.field(default_factory=list)  # (N,) frame indices
    states: list[np.ndarray] = dc.field(default_factory=list)  # (4,) vector state
    labels: list[int] = dc.field(default_factory=list)  # expert's command index

    def __len__(self) -> int:
        return len(self.labels)

    def arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        return (
            np.asarray(self.windows),
            np.asarray(self.states, np.float32),
            np.asarray(self.labels, np.int64),
        )


def command_index(commands: np.ndarray, command: np.ndarray) -> int:
    """Index of the grid command nearest to `command`."""
    return int(np.argmin(np.abs(commands - command).sum(axis=1)))


class Student:
    """The LGM student: network, optimiser and greedy action."""

    def __init__(self, cfg: DaggerConfig, env_cfg: EmoNavConfig, commands: np.ndarray) -> None:
        li = env_cfg.lidar
        self.encoder_spec = {
            "type": "lgm",
            "frames": li.num_frames,
            "size": li.grid_size,
            "pool": cfg.pool,
        }
        self.model = CategoricalPolicy(
            LgmEncoder(li.num_frames, li.grid_size, pool=cfg.pool), len(commands), cfg.hidden
        ).to(cfg.device)
        self.optim = torch.optim.AdamW(
            self.model.parameters(), lr=cfg.lr, weight_decay=cfg.weight_decay
        )
        self.commands = commands
        # The LGM is exactly left-right symmetric (beam i ↔ K − 1 − i, sector i ↔ M − 1 − i):
        # mirrored samples double the data and make the student's choices symmetric.
        self.mirror_augment = cfg.mirror_augment and cfg.grid_kind == "lgm"
        self.mirrored = np.array([command_index(commands, c * [1.0, -1.0]) for c in commands])
        self.device = cfg.device
        self.bounds = (env_cfg.robot.max_speed, env_cfg.robot.max_heading_change)

    @torch.no_grad()
    def act(self, stack: np.ndarray, state: np.ndarray) -> int:
        self.model.eval()
        obs = torch.from_numpy(stack[None]).to(self.device)
        logits = self.model(obs, torch.from_numpy(state[None]).to(self.device))
        return int(logits.argmax())

    def loss(
        self,
        frames: np.ndarray,
        windows: np.ndarray,
        states: np.ndarray,
        labels: np.ndarray,
        mirror: np.ndarray | None = None,
    ) -> torch.Tensor:
        """Cross-entropy on a batch; rows where `mirror` is True are mirrored left↔right."""
        stacks = frames[windows]
        if mirror is not None and mirror.any():
            stacks, states, labels = stacks.copy(), states.copy(), labels.copy()
            stacks[mirror] = stacks[mirror][:, :, ::-1, :]  # sector i ↔ M − 1 − i
            states[mirror, 1] *= -1.0  # goal bearing
            states[mirror, 3] *= -1.0  # last heading change
            labels[mirror] = self.mirrored[labels[mirror]]
        obs = torch.from_numpy(np.ascontiguousarray(stacks)).to(self.device)
        logits = self.model(obs, torch.from_numpy(states).to(self.device))
        return F.cross_entropy(logits, torch.from_numpy(labels).to(self.device))

    def train(
        self, demos: Demonstrations, steps: int, batch: int, rng: np.random.Generator, desc: str
    ) -> float:
        """`steps` minibatch updates on the aggregate; returns the mean loss of the last 100."""
        windows, states, labels = demos.arrays()
        frames = demos.store.frames
        self.model.train()
        losses = []
        for _ in tqdm(range(steps), desc=desc, unit="upd", leave=False):
            idx = rng.integers(0, len(labels), batch)
            mirror = rng.random(batch) < 0.5 if self.mirror_augment else None
            loss = self.loss(frames, windows[idx], states[idx], labels[idx], mirror)
            self.optim.zero_grad(set_to_none=True)
            loss.backward()
            self.optim.step()
            losses.append(loss.item())
        return float(np.mean(losses[-100:]))


def run_episode_collect(
    world: NavigationWorld,
    expert: DwaPlanner,
    student: Student | None,
    beta: float,
    demos: Demonstrations | None,
    rng: np.random.Generator,
) -> str:
    """One episode; the student acts (expert with probability `beta`); label every state."""
    n = world.config.lidar.num_frames
    obs = world.planner_input()
    frame_ids: list[int] = []
    if demos is not None:
        frame_ids.append(demos.store.add(obs.lgm_stack[-1]))
    commands = student.commands if student is not None else expert.candidates
    bounds = (world.config.robot.max_speed, world.config.robot.max_heading_change)
    k = 0
    while True:
        state = vector_state(obs.goal_state(), obs.last_command, bounds)
        use_expert = student is None or (beta > 0 and rng.random() < beta)
        label = None
        if demos is not None or use_expert:
            label = command_index(commands, expert.plan(obs))
        if demos is not None:
            window = [frame_ids[max(0, k - n + 1 + j)] for j in range(n)]
            demos.windows.append(np.asarray(window, np.int64))
            demos.states.append(state)
            demos.labels.append(label)
        choice = label if use_expert else student.act(obs.lgm_stack, state)
        _, outcome = world.step(commands[choice])
        if outcome is not None:
            return outcome
        obs = world.planner_input()
        if demos is not None:
            frame_ids.append(demos.store.add(obs.lgm_stack[-1]))
        k += 1


def evaluate_student(student: Student, env_cfg: EmoNavConfig, cfg: DaggerConfig) -> dict:
    """The student alone on the held-out evaluation seeds."""
    records = []
    expert = DwaPlanner(env_cfg)
    rng = np.random.default_rng(0)
    for i in range(cfg.eval_episodes):
        sc = sample_scenario(cfg.eval_seed_offset + i, env_cfg)
        world = NavigationWorld(sc, env_cfg, goal_radius=cfg.goal_radius, grid_kind=cfg.grid_kind)
        run_episode_collect(world, expert, student, 0.0, None, rng)
        records.append(world.record)
    return summarize(records)


def train_dagger(
    out: str | Path,
    cfg: DaggerConfig | None = None,
    env_cfg: EmoNavConfig | None = None,
    resume: bool = False,
) -> Path:
    """Run the CPU route; write `out/policy.pt` (best round) and a per-round log."""
    cfg = cfg or DaggerConfig()
    env_cfg = env_cfg or EmoNavConfig()
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    torch.set_num_threads(cfg.threads)
    torch.manual_seed(cfg.seed)
    rng = np.random.default_rng(cfg.seed)
    expert = DwaPlanner(env_cfg)
    commands = expert.candidates.copy()
    student = Student(cfg, env_cfg, commands)
    demos = Demonstrations(FrameStore(env_cfg.lidar.grid_size))
    first_round, episode_counter, best_sr, history = 0, 0, -1.0, []
    ckpt = out / "dagger_state.pt"
    if resume and ckpt.is_file():
        st = torch.load(ckpt, weights_only=False)
        student.model.load_state_dict(st["model"])
        student.optim.load_state_dict(st["optim"])
        demos.store.frames, demos.store.count = st["frames"], st["frame_count"]
        demos.windows, demos.states, demos.labels = (
            list(st["windows"]),
            list(st["states"]),
            list(st["labels"]),
        )
        rng.bit_generator.state = st["rng"]
        torch.set_rng_state(st["torch_rng"])
        first_round, episode_counter = st["round"] + 1, st["episodes"]
        best_sr, history = st["best_sr"], st["history"]
        log.info("resumed after round %d (%d samples)", st["round"], len(demos))

    meta = {
        "kind": "categorical",
        "encoder": student.encoder_spec,
        "hidden": cfg.hidden,
        "commands": commands.tolist(),
        "observation": {
            "grid_kind": cfg.grid_kind,
            "num_frames": env_cfg.lidar.num_frames,
            "grid_size": env_cfg.lidar.grid_size,
        },
        "bounds": [env_cfg.robot.max_speed, env_cfg.robot.max_heading_change],
    }
    for rnd in range(first_round, cfg.rounds + 1):
        t0 = time.perf_counter()
        episodes = cfg.expert_episodes if rnd == 0 else cfg.episodes_per_round
        beta = 1.0 if rnd == 0 else cfg.beta * 0.5 ** (rnd - 1)
        outcomes = []
        for _ in tqdm(range(episodes), desc=f"round {rnd} rollouts", unit="ep", leave=False):
            sc = sample_scenario(cfg.train_seed_offset + episode_counter, env_cfg)
            episode_counter += 1
            if rng.random() < cfg.heading_noise_prob:  # start off course: learn to seek the goal
                sc.robot_heading += float(rng.uniform(-cfg.heading_noise, cfg.heading_noise))
            world = NavigationWorld(
                sc, env_cfg, goal_radius=cfg.goal_radius, grid_kind=cfg.grid_kind
            )
            outcomes.append(
                run_episode_collect(world, expert, None if rnd == 0 else student, beta, demos, rng)
            )
        t_collect = time.perf_counter() - t0
        steps = cfg.grad_steps_first if rnd == 0 else cfg.grad_steps_per_round
        loss = student.train(demos, steps, cfg.batch_size, rng, f"round {rnd} training")
        t_train = time.perf_counter() - t0 - t_collect
        summary = evaluate_student(student, env_cfg, cfg)
        entry = {
            "round": rnd,
            "beta": beta,
            "samples": len(demos),
            "loss": loss,
            "rollout_success": outcomes.count("success") / len(outcomes),
            "eval": summary,
            "collect_s": t_collect,
            "train_s": t_train,
            "eval_s": time.perf_counter() - t0 - t_collect - t_train,
        }
        history.append(entry)
        print(
            f"round {rnd}: {len(demos)} samples, loss {loss:.3f}, rollouts SR "
            f"{entry['rollout_success']:.2f} | student: {format_summary(summary)} "
            f"[{t_collect:.0f}+{t_train:.0f}+{entry['eval_s']:.0f} s]",
            flush=True,
        )
        round_meta = {
            **meta,
            "provenance": {
                "route": "dagger",
                "round": rnd,
                "config": dc.asdict(cfg),
                "eval_SR": summary["SR"],
            },
        }
        save_policy(out / f"policy_round{rnd}.pt", student.model, round_meta)
        if summary["SR"] >= best_sr:
            best_sr = summary["SR"]
            save_policy(out / "policy.pt", student.model, round_meta)
        atomic_torch_save(
            {
                "model": student.model.state_dict(),
                "optim": student.optim.state_dict(),
                "frames": demos.store.frames[: demos.store.count].copy(),
                "frame_count": demos.store.count,
                "windows": demos.windows,
                "states": demos.states,
                "labels": demos.labels,
                "rng": rng.bit_generator.state,
                "torch_rng": torch.get_rng_state(),
                "round": rnd,
                "episodes": episode_counter,
                "best_sr": best_sr,
                "history": history,
            },
            ckpt,
        )
        (out / "history.json").write_text(json.dumps(history, indent=2))
    return out / "policy.pt"
