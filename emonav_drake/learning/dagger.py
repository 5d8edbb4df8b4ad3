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
"""

from __future__ import annotations

import copy
import dataclasses as dc
import json
import logging
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import torch
from torch.nn import functional as F
from tqdm import tqdm

from emonav_drake.atomic_io import write_text_atomic
from emonav_drake.core.dwa import DwaPlanner
from emonav_drake.core.metrics import format_summary, summarize
from emonav_drake.core.navigation import NavigationWorld
from emonav_drake.core.observations import (
    mirror_observation,
    observation_dtype,
    observation_kind,
    observation_shape,
)
from emonav_drake.core.scenario import Scenario, sample_scenario
from emonav_drake.core.step_response import StepResponseModel
from emonav_drake.errors import RunInterrupted
from emonav_drake.learning.config import DaggerConfig
from emonav_drake.learning.run_state import (
    DAGGER_FORMAT,
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
from emonav_drake.params import ConfigError, EmoNavConfig
from emonav_drake.planners.model_aware import model_aware_expert
from emonav_drake.planners.networks import CategoricalPolicy
from emonav_drake.planners.policy import (
    DEFAULT_POLICY,
    build_encoder,
    encoder_spec,
    load_policy,
    save_policy,
    vector_state,
)

log = logging.getLogger(__name__)
STATE_FILE = "dagger_state.pt"
# What a DAgger state holds (`train_dagger`'s `save`).
STATE_KEYS = ("config", "env_config", "progress", "episodes", "best_sr", "history", "rng")
DEMO_KEYS = ("frames", "windows", "states", "labels")


class FrameStore:
    """Append-only observation frames; samples refer to frames by index.

    Args:
        shape: one frame's shape — (M, M) grid maps, (K,) scans, (3, M, M) DRL-VO* images;
            an int M means (M, M).
        dtype: the frames' dtype (uint8 maps, float32 scans).
    """

    def __init__(
        self, shape: int | tuple[int, ...], capacity: int = 4096, dtype: type = np.uint8
    ) -> None:
        shape = (shape, shape) if isinstance(shape, int) else tuple(shape)
        self.frames = np.zeros((capacity, *shape), dtype)
        self.count = 0

    def add(self, frame: np.ndarray) -> int:
        if self.count == len(self.frames):
            grown = np.zeros((2 * len(self.frames), *self.frames.shape[1:]), self.frames.dtype)
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

    def truncate(self, samples: int, frames: int) -> None:
        """Back to `samples` samples and `frames` stored frames (undo a partial episode)."""
        del self.windows[samples:], self.states[samples:], self.labels[samples:]
        self.store.count = frames

    def to_plain(self, num_frames: int) -> dict:
        """Frames, windows, vector states and labels as arrays (plain data)."""
        n = len(self)
        return {
            "frames": self.store.frames[: self.store.count].copy(),
            "windows": np.asarray(self.windows, np.int64).reshape(n, num_frames),
            "states": np.asarray(self.states, np.float32).reshape(n, 4),
            "labels": np.asarray(self.labels, np.int64).reshape(n),
        }

    def load_plain(self, d: dict, num_frames: int) -> None:
        """Inverse of `to_plain` (`ValueError` if the arrays are inconsistent)."""
        frames, windows = d["frames"], d["windows"]
        states, labels = d["states"], d["labels"]
        n, size = len(labels), self.store.frames.shape[1:]
        if (
            frames.dtype != self.store.frames.dtype
            or frames.shape[1:] != size
            or windows.dtype != np.int64
            or windows.shape != (n, num_frames)
            or states.dtype != np.float32
            or states.shape != (n, 4)
            or labels.dtype != np.int64
            or labels.shape != (n,)
            or (n and not ((windows >= 0) & (windows < len(frames))).all())
        ):
            raise ValueError("the saved demonstrations are inconsistent or of another size")
        self.store.frames = frames.copy() if len(frames) else self.store.frames
        self.store.count = len(frames)
        self.windows = list(windows)
        self.states = list(states)
        self.labels = labels.tolist()


def command_index(commands: np.ndarray, command: np.ndarray) -> int:
    """Index of the grid command nearest to `command`."""
    return int(np.argmin(np.abs(commands - command).sum(axis=1)))


def read_dagger_state(path: str | Path) -> tuple[DaggerConfig, dict, dict]:
    """A DAgger run's state file, read without running code and checked: (its
    configuration, its plain state, its tensors).

    `RunStateError` naming the file if it is missing, damaged, of another format, lacks
    part of the state (`STATE_KEYS`, the demonstrations' `DEMO_KEYS`), or its
    configuration has fields this emonav does not know or values out of range.
    """
    path = Path(path)
    saved, tensors = read_run_state(path, DAGGER_FORMAT)

    def check() -> DaggerConfig:
        missing = [k for k in (*STATE_KEYS, "demos") if k not in saved]
        if not missing and isinstance(saved["demos"], dict):
            missing = [f"demos.{k}" for k in DEMO_KEYS if k not in saved["demos"]]
        if missing:
            raise ValueError(f"no {', '.join(missing)} in it")
        bad = [k for k in DEMO_KEYS if not isinstance(saved["demos"][k], np.ndarray)]
        if bad:
            raise ValueError(f"demos.{bad[0]} is not an array")
        for key in ("model", "optim"):
            if not isinstance(tensors.get(key), dict):
                raise ValueError(f"no {key} state in it")
        if not isinstance(saved["config"], dict):
            raise ValueError("its configuration is not a mapping")
        known = {f.name for f in dc.fields(DaggerConfig)}
        unknown = sorted(set(saved["config"]) - known)
        if unknown:
            raise ValueError(f"configuration fields this emonav does not know: {unknown}")
        try:
            return DaggerConfig(**saved["config"]).validate()
        except ConfigError as e:
            raise ValueError(f"its configuration: {e}") from None

    return check_state(f"{path.name} in {path.parent}", check), saved, tensors


class Student:
    """The student: network over the variant's observation, optimiser and greedy action.

    The encoder is the one the SAC trainer uses for the same variant (`encoder_spec`):
    the paper's 2-D CNN on grid maps (max-pooled by `cfg.pool`), a 1-D CNN on scans, an
    LSTM on scans (LNDNL).
    """

    def __init__(self, cfg: DaggerConfig, env_cfg: EmoNavConfig, commands: np.ndarray) -> None:
        li = env_cfg.lidar
        self.grid_kind = cfg.grid_kind
        self.encoder_spec = encoder_spec(
            cfg.grid_kind, cfg.encoder, cfg.num_frames, li.grid_size, pool=cfg.pool
        )
        self.model = CategoricalPolicy(
            build_encoder(self.encoder_spec), len(commands), cfg.hidden
        ).to(cfg.device)
        self.optim = torch.optim.AdamW(
            self.model.parameters(), lr=cfg.lr, weight_decay=cfg.weight_decay
        )
        self.commands = commands
        # Every observation is exactly left-right symmetric (`mirror_observation`):
        # mirrored samples double the data and make the student's choices symmetric.
        self.mirror_augment = cfg.mirror_augment
        self.mirrored = np.array([command_index(commands, c * [1.0, -1.0]) for c in commands])
        self.device = cfg.device
        self.bounds = (env_cfg.robot.max_speed, env_cfg.robot.max_heading_change)

    def load_weights(self, policy: str) -> None:
        """Start from a trained policy ("shipped" = the shipped LGM policy, or a path);
        `ConfigError` if its network or command grid is not this student's."""
        path = DEFAULT_POLICY if policy == "shipped" else Path(policy)
        model, meta = load_policy(path)
        ob = meta["observation"]
        if meta["kind"] != "categorical" or (ob["grid_kind"], ob["num_frames"]) != (
            self.grid_kind,
            self.encoder_spec["frames"] // observation_kind(self.grid_kind).planes_per_frame,
        ):
            raise ConfigError(
                f"init_policy {path}: a {meta['kind']} policy on {ob['grid_kind']} x "
                f"{ob['num_frames']} is not this configuration's student (categorical, "
                f"{self.grid_kind})"
            )
        if not np.allclose(np.asarray(meta["commands"]), self.commands):
            raise ConfigError(f"init_policy {path}: its command grid is not the expert's")
        try:
            self.model.load_state_dict(model.state_dict())
        except RuntimeError as e:  # another network size (hidden, pool, filters)
            raise ConfigError(
                f"init_policy {path}: its network is not this configuration's: "
                f"{str(e).splitlines()[0]}"
            ) from None

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
        return self.loss_on_stacks(frames[windows], states, labels, mirror)

    def loss_on_stacks(
        self,
        stacks: np.ndarray,
        states: np.ndarray,
        labels: np.ndarray,
        mirror: np.ndarray | None = None,
    ) -> torch.Tensor:
        """`loss` on gathered observation stacks (B, …)."""
        if mirror is not None and mirror.any():
            stacks, states, labels = stacks.copy(), states.copy(), labels.copy()
            stacks[mirror] = mirror_observation(stacks[mirror], self.grid_kind)
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
        losses: list[float] = []
        self.train_steps(demos, 0, steps, batch, rng, desc, losses)
        return float(np.mean(losses[-100:]))

    def train_steps(
        self,
        demos: Demonstrations,
        done: int,
        steps: int,
        batch: int,
        rng: np.random.Generator,
        desc: str,
        losses: list[float],
        stop: Callable[[], bool] | None = None,
    ) -> int:
        """Updates `done`..`steps` − 1, appending each loss to `losses`; `stop()` is asked
        after every update and ends the loop early. Returns the updates done in all."""
        windows, states, labels = demos.arrays()
        frames = demos.store.frames
        self.model.train()
        bar = tqdm(
            range(done, steps), desc=desc, unit="upd", leave=False, initial=done, total=steps
        )
        for _ in bar:
            idx = rng.integers(0, len(labels), batch)
            mirror = rng.random(batch) < 0.5 if self.mirror_augment else None
            loss = self.loss(frames, windows[idx], states[idx], labels[idx], mirror)
            self.optim.zero_grad(set_to_none=True)
            loss.backward()
            self.optim.step()
            losses.append(loss.item())
            done += 1
            if stop is not None and stop():
                break
        return done


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
    expert.reset()  # a model-aware expert remembers the episode's commands
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
        run_episode_collect(world, expert, student, 0.0, None, rng)
        records.append(world.record)
    return summarize(records)


@dc.dataclass
class _Progress:
    """Where a run is inside a round (saved with the state; plain data)."""

    round: int = 0
    phase: str = "collect"  # collect → train → eval, then the next round
    episode: int = 0  # episodes collected in this round
    grad_step: int = 0  # gradient steps done in this round
    outcomes: list[str] = dc.field(default_factory=list)  # of the episodes collected
    losses: list[float] = dc.field(default_factory=list)  # the last 100 training losses
    collect_s: float = 0.0  # wall time so far [s]
    train_s: float = 0.0


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

    Raises:
        RunStateError: `resume` and `out` has no DAgger state, or one that is damaged, of
            an older format, not ours or does not fit; or no round was trained.
        RunInterrupted: after Ctrl-C, once the state is saved.
    """
    cfg = cfg or DaggerConfig()
    env_cfg = copy.deepcopy(env_cfg or EmoNavConfig())
    env_cfg.lidar.num_frames = cfg.num_frames  # the variant's stack depth
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
    torch.set_num_threads(cfg.threads)
    torch.manual_seed(cfg.seed)
    rng = np.random.default_rng(cfg.seed)
    expert = model_aware_expert(env_cfg, cfg.expert_margin, cfg.response)
    response = expert.response
    commands = expert.candidates.copy()
    student = Student(cfg, env_cfg, commands)
    if cfg.init_policy and not resume:
        student.load_weights(cfg.init_policy)
    n_frames = env_cfg.lidar.num_frames
    frame_shape = observation_shape(cfg.grid_kind, env_cfg.lidar)[1:]
    demos = Demonstrations(FrameStore(frame_shape, dtype=observation_dtype(cfg.grid_kind).type))
    prog, episode_counter, best_sr, history = _Progress(), 0, -1.0, []
    if resume:
        changes = config_changes(
            {"config": saved["config"], "env": saved["env_config"]},
            {"config": dc.asdict(cfg), "env": dc.asdict(env_cfg)},
        )
        if changes:
            log.warning(
                "resuming with a configuration that differs from the saved one: %s",
                ", ".join(changes),
            )

        def restore() -> tuple[_Progress, int, float, list]:
            student.model.load_state_dict(tensors["model"])
            student.optim.load_state_dict(tensors["optim"])
            demos.load_plain(saved["demos"], n_frames)
            set_rng_state(rng, saved["rng"], tensors)
            progress = _Progress(**saved["progress"])
            if (
                progress.phase not in ("collect", "train", "eval")
                or min(progress.round, progress.episode, progress.grad_step) < 0
            ):
                raise ValueError(f"progress {saved['progress']} is invalid")
            return progress, int(saved["episodes"]), float(saved["best_sr"]), list(saved["history"])

        where = f"{STATE_FILE} in {out}"
        prog, episode_counter, best_sr, history = check_state(where, restore, changes)
        log.info("resumed in round %d (%s; %d samples)", prog.round, prog.phase, len(demos))

    def save() -> None:
        rng_plain, rng_tensors = rng_state(rng)
        state = {
            "config": dc.asdict(cfg),
            "env_config": dc.asdict(env_cfg),
            "progress": dc.asdict(prog) | {"losses": prog.losses[-100:]},
            "episodes": episode_counter,
            "best_sr": best_sr,
            "history": history,
            "rng": rng_plain,
            "demos": demos.to_plain(n_frames),
        }
        tensors = {"model": student.model.state_dict(), "optim": student.optim.state_dict()}
        write_run_state(ckpt, DAGGER_FORMAT, state, tensors | rng_tensors)

    meta = {
        "kind": "categorical",
        "encoder": student.encoder_spec,
        "hidden": cfg.hidden,
        "commands": commands.tolist(),
        "observation": {
            "grid_kind": cfg.grid_kind,
            "num_frames": n_frames,
            "grid_size": env_cfg.lidar.grid_size,
        },
        "bounds": [env_cfg.robot.max_speed, env_cfg.robot.max_heading_change],
    }
    saved_round = None  # the round whose start the state file holds
    with InterruptGuard() as guard:
        while prog.round <= cfg.rounds and not guard.requested:
            rnd = prog.round
            episodes = cfg.expert_episodes if rnd == 0 else cfg.episodes_per_round
            beta = 1.0 if rnd == 0 else cfg.beta * 0.5 ** (rnd - 1)
            if prog.phase == "collect":
                t0 = time.perf_counter()
                bar = tqdm(
                    total=episodes,
                    initial=prog.episode,
                    desc=f"round {rnd} rollouts",
                    unit="ep",
                    leave=False,
                )
                while prog.episode < episodes and not guard.requested:
                    # An episode is all or nothing: on Ctrl-C it is undone (demonstrations,
                    # frames and random state back to where it began) and collected again
                    # on resume.
                    undo = (rng_state(rng), len(demos), demos.store.count)
                    try:
                        with guard.abortable():
                            sc = sample_scenario(cfg.train_seed_offset + episode_counter, env_cfg)
                            if rng.random() < cfg.heading_noise_prob:  # off course: seek the goal
                                sc.robot_heading += float(
                                    rng.uniform(-cfg.heading_noise, cfg.heading_noise)
                                )
                            world = make_world(sc, env_cfg, cfg, response)
                            outcome = run_episode_collect(
                                world, expert, None if rnd == 0 else student, beta, demos, rng
                            )
                    except KeyboardInterrupt:
                        set_rng_state(rng, *undo[0])
                        demos.truncate(undo[1], undo[2])
                        break
                    episode_counter += 1
                    prog.episode += 1
                    prog.outcomes.append(outcome)
                    bar.update(1)
                bar.close()
                prog.collect_s += time.perf_counter() - t0
                if prog.episode >= episodes:
                    prog.phase = "train"
            if prog.phase == "train" and not guard.requested:
                t0 = time.perf_counter()
                steps = cfg.grad_steps_first if rnd == 0 else cfg.grad_steps_per_round
                prog.grad_step = student.train_steps(
                    demos,
                    prog.grad_step,
                    steps,
                    cfg.batch_size,
                    rng,
                    f"round {rnd} training",
                    prog.losses,
                    stop=lambda: guard.requested,
                )
                prog.train_s += time.perf_counter() - t0
                if prog.grad_step >= steps:
                    prog.phase = "eval"
            if prog.phase == "eval" and not guard.requested:
                t0 = time.perf_counter()
                try:  # evaluation changes nothing: abandoned on Ctrl-C, run again on resume
                    with guard.abortable():
                        summary = evaluate_student(student, env_cfg, cfg, response)
                except KeyboardInterrupt:
                    break
                entry = _round_entry(prog, summary, time.perf_counter() - t0, beta, len(demos))
                history.append(entry)
                wall = sum(h["collect_s"] + h["train_s"] + h["eval_s"] for h in history)
                round_meta = {
                    **meta,
                    "provenance": {
                        "route": "dagger",
                        "variant": variant,
                        "command": command,
                        "round": rnd,
                        "seed": cfg.seed,
                        "config": dc.asdict(cfg),
                        "samples": len(demos),
                        "wall_seconds": round(wall, 1),
                        "training_seeds": [
                            cfg.train_seed_offset,
                            cfg.train_seed_offset + episode_counter - 1,
                        ],
                        "selection_seeds": [
                            cfg.eval_seed_offset,
                            cfg.eval_seed_offset + cfg.eval_episodes - 1,
                        ],
                        "eval_SR": summary["SR"],
                    },
                }
                save_policy(out / f"policy_round{rnd}.pt", student.model, round_meta)
                if summary["SR"] >= best_sr:
                    best_sr = summary["SR"]
                    save_policy(out / "policy.pt", student.model, round_meta)
                prog = _Progress(round=rnd + 1)
                save()
                saved_round = prog.round
                write_text_atomic(out / "history.json", json.dumps(history, indent=2), durable=True)
        interrupted = guard.requested and prog.round <= cfg.rounds
        if interrupted:
            log.warning("interrupted in round %d (%s): saving the state", prog.round, prog.phase)
            if not (prog.phase == "collect" and prog.episode == 0 and saved_round == prog.round):
                save()
            if guard.extra:
                log.warning("Ctrl-C pressed again while stopping: ignored (the save completed)")
    if interrupted:
        where = {
            "collect": f"{prog.episode} of its episodes collected",
            "train": f"{prog.grad_step} gradient steps done",
            "eval": "evaluation to run",
        }[prog.phase]
        hint = resume_command or f"emonav train --algo dagger --resume {out} (same --config)"
        raise RunInterrupted(
            f"interrupted in round {prog.round} ({where}); state saved in {out}; continue "
            f"with `{hint}`"
        )
    policy = out / "policy.pt"
    if not history or not policy.is_file():
        raise RunStateError(
            f"no DAgger round was trained (rounds = {cfg.rounds}): no policy written in {out}"
        )
    return policy


def _round_entry(prog: _Progress, summary: dict, eval_s: float, beta: float, samples: int) -> dict:
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
