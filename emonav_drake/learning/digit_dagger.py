"""DAgger rounds on the full-order Digit: the student acts in the Digit diagram, the expert
that plans with Digit's step response labels every planner instant.

    emonav digit-rounds --from runs/emobipednav_digit --rounds 2 --episodes 60 \\
        --first-seed 4000000 --workers 2 --out runs/digit_rounds [--resume]

The calibrated route (`configs/variants/emobipednav_digit.yaml`) learns in a reduced world
fitted to Digit; these rounds close what the fit misses. Each round:

1. **collect** `episodes` Digit navigation episodes (the whole diagram: station, crowd,
   LiDAR grid maps) on seeds `first_seed + round·episodes + i`, one per Ray task, in the
   calibrated run's world (`rounds_world`: its scenario family, LiDAR sensor and
   perception — a student trained in buildings on the tracker's crowd meets them on
   Digit too). The
   planner is `LabellingPlanner`: at every t_k it asks the calibrated run's expert (its
   `DaggerConfig.teacher()`: a planner spec, e.g. the model-aware DWA or the MPC) for its
   command, records
   the newest observation frame, the vector state and the expert's label, and sends the
   student's command (the expert's with probability β, drawn per (seed, step));
2. **aggregate** the new samples with the calibrated run's demonstrations (its
   `dagger_state.pt`) and the earlier Digit rounds';
3. **train** the student, from the previous round's weights, for `grad_steps` minibatch
   steps in which a fraction `digit_fraction` of every batch comes from Digit samples;
4. **save** `policy_round<r>.pt` (with provenance) and `digit_rounds.pt` (the Digit
   samples, the student and its optimiser, the round: `--resume` continues from it).

Each round's policy is evaluated on Digit by `emonav benchmark` (the learning curve);
nothing here looks at evaluation seeds.
"""

from __future__ import annotations

import dataclasses as dc
import logging
import time
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from emonav_drake.learning.digit_rounds_config import DigitRoundsConfig, rounds_plain
from emonav_drake.navigation.observations import observation_kind
from emonav_drake.params import ConfigError, EmoNavConfig
from emonav_drake.planners.dwa import DwaPlanner
from emonav_drake.planners.policy import vector_state
from emonav_drake.planners.protocol import Planner

if TYPE_CHECKING:
    from emonav_drake.learning.config import DaggerConfig

log = logging.getLogger(__name__)
DIGIT_ROUNDS_FORMAT = "emonav-digit-dagger/1"
STATE_FILE = "digit_rounds.pt"
ACT_SALT = 0xDA6


class LabellingPlanner:
    """The student acting on Digit while the expert labels (see the module).

    Records, as a side effect, one sample per planner instant (the diagram calls
    `plan_with_memory` exactly once per instant, in order): `frames` (the newest frame of
    the observation stack), `states` (the vector state), `labels` (the expert's
    command index) and, for an expert that is a distribution over the grid (the LGM
    shield's `last_distribution`), `targets`. Its memory is the expert's.
    """

    name = "labelling"

    def __init__(self, student, expert: Planner, beta: float, seed: int) -> None:
        self.student, self.expert, self.beta, self.seed = student, expert, beta, seed
        self.commands = student.commands
        self.grid_kind = student.grid_kind
        self.expected_shape = student.expected_shape
        self.expected_dtype = student.expected_dtype
        self.frames: list[np.ndarray] = []
        self.states: list[np.ndarray] = []
        self.labels: list[int] = []
        self.targets: list[np.ndarray] = []

    def initial_memory(self):
        return self.expert.initial_memory()

    def plan_with_memory(self, obs, memory):
        from emonav_drake.learning.demonstrations import command_index

        expert_cmd, memory = self.expert.plan_with_memory(obs, memory)
        label = command_index(self.commands, expert_cmd)
        self.frames.append(np.array(observation_kind(self.grid_kind).newest(obs.lgm_stack)))
        self.states.append(
            vector_state(self.student.goal_state(obs), obs.last_command, self.student.bounds)
        )
        self.labels.append(label)
        if getattr(self.expert, "last_distribution", None) is not None:
            self.targets.append(np.asarray(self.expert.last_distribution, np.float32))
        rng = np.random.default_rng([ACT_SALT, self.seed, obs.step])
        if rng.random() < self.beta:
            return self.commands[label].copy(), memory
        return self.student.plan(obs), memory


def _round_worker(beta: float, rounds: DigitRoundsConfig) -> type:
    """The Ray actor class of `collect_round`: one labelled Digit episode per task."""
    from emonav_drake.diagrams.trials import TrialWorker

    class RoundWorker(TrialWorker):
        def run(self, method: str, seed: int) -> dict:
            return _labelled_episode(self.runner, method, seed, beta, rounds)

    return RoundWorker


def _labelled_episode(
    runner,
    method: str,
    seed: int,
    beta: float,
    rounds: DigitRoundsConfig,
) -> dict:
    """One Digit episode of the student (`runner`'s method) labelled by the expert of
    `rounds` (`DigitRoundsConfig.expert`, the calibrated run's)."""
    from emonav_drake.diagrams.navigation_digit import run_digit_episode
    from emonav_drake.scenarios.scenario import sample_scenario

    student, cfg, grid_kind = runner.planner(method)
    expert = rounds.expert.build(cfg)
    planner = LabellingPlanner(student, expert, beta, seed)
    scenario = sample_scenario(seed, runner.config)
    t0 = time.perf_counter()
    record, _ = run_digit_episode(scenario, cfg, planner, grid_kind=grid_kind)
    return {
        "method": method,
        "seed": seed,
        "outcome": record.outcome,
        "walls": len(scenario.walls),
        "wall_seconds": time.perf_counter() - t0,
        "frames": np.asarray(planner.frames),
        "states": np.asarray(planner.states, np.float32).reshape(-1, 4),
        "labels": np.asarray(planner.labels, np.int64),
        "targets": np.asarray(planner.targets, np.float32).reshape(
            len(planner.targets), len(planner.commands)
        ),
    }


def collect_round(
    policy: Path,
    cfg: DigitRoundsConfig,
    rnd: int,
    workers: int,
    ray_address: str | None,
    env_config=None,
) -> list[dict]:
    """The labelled Digit episodes of round `rnd`, sorted by seed (serial = parallel)."""
    from emonav_drake.diagrams.trials import BenchmarkSpec, MethodSpec, run_serial, run_trials
    from emonav_drake.params import EmoNavConfig, dump_config
    from emonav_drake.provenance import sha256_file

    spec = BenchmarkSpec(
        [MethodSpec("student", "policy", str(policy), sha256_file(policy))],
        "digit",
        dump_config(env_config or EmoNavConfig()),
        planner_modules=list(cfg.planner_modules),
    )
    beta = cfg.beta * 0.5**rnd
    first = cfg.first_seed + rnd * cfg.episodes
    tasks = [("student", first + i) for i in range(cfg.episodes)]
    results: list[dict] = []
    if workers <= 1 and ray_address is None:  # one torch thread, as in a Ray worker

        def episode(runner, method: str, seed: int) -> dict:
            return _labelled_episode(runner, method, seed, beta, cfg)

        run_serial(spec, tasks, results.append, episode)
    else:
        worker_cls = _round_worker(beta, cfg)
        run_trials(spec, tasks, results.append, workers, ray_address, worker_cls=worker_cls)
    return sorted(results, key=lambda r: r["seed"])


def episodes_to_demos(episodes: list[dict], demos, num_frames: int, soft: bool = False) -> None:
    """Append labelled episodes to `Demonstrations` (windows as the LIP route builds them);
    with `soft`, their soft labels too."""
    for ep in episodes:
        ids = [demos.store.add(f) for f in ep["frames"]]
        for k in range(len(ids)):
            window = [ids[max(0, k - num_frames + 1 + j)] for j in range(num_frames)]
            demos.windows.append(np.asarray(window, np.int64))
            demos.states.append(ep["states"][k])
            demos.labels.append(int(ep["labels"][k]))
            if soft:
                demos.targets.append(ep["targets"][k])


def run_digit_rounds(
    out: str | Path,
    source: str | Path,
    cfg: DigitRoundsConfig,
    workers: int = 1,
    ray_address: str | None = None,
    resume: bool = False,
    env_config=None,
) -> Path:
    """Digit rounds after the calibrated run in `source` (module docstring); returns the
    last round's policy. `env_config`: the episodes' navigation configuration (default:
    the setting the calibrated run trained in, `DaggerConfig.setting`), made the calibrated
    run's world (`rounds_world`).

    Raises:
        ConfigError: a setting of `cfg` out of range (its flag named); `env_config` of
            another scenario family than the calibrated run's.
        RunStateError: `source` has no DAgger state, or one that `train --resume` would
            refuse (`dagger.read_dagger_state`); `resume` and `out` has no state of the
            rounds, or a damaged one.
    """
    import torch

    cfg.validate()
    out, source = Path(out), Path(source)
    n, calibrated, digit, student, start_policy, dcfg = _start_from(source)
    # the calibrated run's teacher labels here too
    cfg = dc.replace(cfg, expert=dcfg.teacher(), planner_modules=list(dcfg.planner_modules))
    env_config = rounds_world(dcfg, env_config)
    world = {  # in every round's line of the history
        "family": env_config.crowd.family,
        "sensor": dcfg.sensor,
        "perception": dcfg.perception,
    }
    rnd, history = _resume_rounds(out, cfg, digit, student, n) if resume else (0, [])
    out.mkdir(parents=True, exist_ok=True)
    torch.manual_seed(cfg.seed + rnd)
    rng = np.random.default_rng([cfg.seed, rnd])
    policy = out / f"policy_round{rnd - 1}.pt" if rnd else start_policy
    base_meta = _policy_meta(start_policy)  # network, observation, commands: read once
    while rnd < cfg.rounds:
        t0 = time.perf_counter()
        episodes = collect_round(policy, cfg, rnd, workers, ray_address, env_config)
        collect_s = time.perf_counter() - t0
        episodes_to_demos(episodes, digit, n, soft=calibrated.soft)
        t0 = time.perf_counter()
        losses = _train_mixed(student, calibrated, digit, cfg, rng)
        train_s = time.perf_counter() - t0
        entry = _round_entry(rnd, cfg, episodes, len(digit), losses, collect_s, train_s)
        entry["world"] = world
        history.append(entry)
        print(
            f"Digit round {rnd}: {len(episodes)} episodes (student SR with β = "
            f"{entry['beta']:.3f}: {entry['rollout_success']:.2f}), {len(digit)} Digit samples, "
            f"loss {entry['loss']:.3f} [{collect_s:.0f}+{train_s:.0f} s]",
            flush=True,
        )
        policy = _save_round(out, source, cfg, rnd, history, base_meta, student, digit, n)
        rnd += 1
    return policy


def rounds_world(dcfg: DaggerConfig, env_config: EmoNavConfig | None = None) -> EmoNavConfig:
    """The Digit rounds' navigation configuration (a copy): `env_config` (default: the
    setting the calibrated run trained in, `DaggerConfig.setting`) with the calibrated run
    `dcfg`'s world — its LiDAR `sensor`, its `perception` (`with_run_world`) and its scenario
    `family` (`with_run_family`) — so that the student meets on Digit the world it learnt
    in. `ConfigError` if `env_config` names another family than the run's (other than the
    paper's arena)."""
    import copy

    from emonav_drake.configs import load_setting
    from emonav_drake.learning.config_common import with_run_family, with_run_world

    env = copy.deepcopy(env_config) if env_config is not None else load_setting(dcfg.setting)
    return with_run_family(with_run_world(env, dcfg), dcfg.family)


def _start_from(source: Path) -> tuple:
    """What the rounds start from in the calibrated run `source`: `(num_frames, its
    demonstrations, empty Digit demonstrations, the student with its weights, the path of
    its policy, its DAgger configuration)` (`RunStateError` if its DAgger state is missing
    or refused)."""
    from emonav_drake.learning.dagger_state import STATE_FILE as SOURCE_STATE
    from emonav_drake.learning.dagger_state import read_dagger_state
    from emonav_drake.learning.dagger_student import Student
    from emonav_drake.learning.demonstrations import Demonstrations, FrameStore
    from emonav_drake.learning.run_state import check_state
    from emonav_drake.params import EmoNavConfig

    dcfg, saved, _ = read_dagger_state(source / SOURCE_STATE)
    env_cfg = EmoNavConfig()
    env_cfg.lidar.num_frames = dcfg.num_frames
    n = dcfg.num_frames
    shape = saved["demos"]["frames"].shape[1:]
    calibrated = Demonstrations(FrameStore(shape))
    where = f"{SOURCE_STATE} in {source}"
    check_state(where, lambda: calibrated.load_plain(saved["demos"], n))
    digit = Demonstrations(FrameStore(shape))
    commands = DwaPlanner(env_cfg).candidates.copy()
    student = Student(dcfg, env_cfg, commands)
    start_policy = source / "policy.pt"
    student.load_weights(str(start_policy))
    return n, calibrated, digit, student, start_policy, dcfg


def _resume_rounds(out: Path, cfg: DigitRoundsConfig, digit, student, n: int) -> tuple[int, list]:
    """Load `out`'s state of the rounds into `digit` and `student`; returns the rounds
    done and their history (`RunStateError` if it is missing or damaged)."""
    from emonav_drake.learning.run_state import check_state, config_changes, read_run_state

    state, tensors = read_run_state(out / STATE_FILE, DIGIT_ROUNDS_FORMAT)
    changes = config_changes(state.get("config"), rounds_plain(cfg))
    if changes:
        log.warning(
            "resuming the rounds with settings that differ from the saved ones: %s",
            ", ".join(changes),
        )

    def restore() -> tuple[int, list]:
        digit.load_plain(state["demos"], n)
        student.model.load_state_dict(tensors["model"])
        student.optim.load_state_dict(tensors["optim"])
        done, past = int(state["round"]), list(state["history"])
        if not 0 <= done == len(past):
            raise ValueError(f"round {done} with {len(past)} rounds in its history")
        return done, past

    return check_state(f"{STATE_FILE} in {out}", restore, changes)


def _round_entry(
    rnd: int,
    cfg: DigitRoundsConfig,
    episodes: list[dict],
    digit_samples: int,
    losses: list[float],
    collect_s: float,
    train_s: float,
) -> dict:
    """Round `rnd`'s line of the history (in the policies' provenance and the state)."""
    outcomes = [e["outcome"] for e in episodes]
    return {
        "round": rnd,
        "beta": cfg.beta * 0.5**rnd,
        "episodes": len(episodes),
        "seeds": [episodes[0]["seed"], episodes[-1]["seed"]],
        "rollout_success": outcomes.count("success") / len(outcomes),
        "walled_episodes": sum(1 for e in episodes if e.get("walls")),
        "digit_samples": digit_samples,
        "loss": float(np.mean(losses[-100:])),
        "collect_s": round(collect_s, 1),
        "train_s": round(train_s, 1),
        "digit_steps_per_second_per_worker": round(
            sum(len(e["labels"]) for e in episodes)
            / max(1e-9, sum(e["wall_seconds"] for e in episodes)),
            3,
        ),
    }


def _save_round(
    out: Path,
    source: Path,
    cfg: DigitRoundsConfig,
    rnd: int,
    history: list,
    base_meta: dict,
    student,
    digit,
    n: int,
) -> Path:
    """Write round `rnd`'s `policy_round<rnd>.pt` (with provenance), then the state of the
    rounds (`rnd + 1` done); returns the policy's path."""
    from emonav_drake.learning.run_state import write_run_state
    from emonav_drake.planners.policy import save_policy

    meta = dict(base_meta)
    meta["provenance"] = {
        "route": "dagger+digit",
        "source": str(source),
        "round": rnd,
        "config": rounds_plain(cfg),
        "history": history,
    }
    policy = out / f"policy_round{rnd}.pt"
    save_policy(policy, student.model, meta)
    write_run_state(
        out / STATE_FILE,
        DIGIT_ROUNDS_FORMAT,
        {
            "round": rnd + 1,
            "history": history,
            "demos": digit.to_plain(n),
            "config": rounds_plain(cfg),
        },
        {"model": student.model.state_dict(), "optim": student.optim.state_dict()},
    )
    return policy


def _policy_meta(path: Path) -> dict:
    """The metadata of the policy the rounds start from (network, observation, commands)."""
    from emonav_drake.planners.policy import load_policy

    _, meta = load_policy(path)
    return {k: v for k, v in meta.items() if k not in ("state_dict", "format", "provenance")}


def _train_mixed(student, calibrated, digit, cfg: DigitRoundsConfig, rng) -> list[float]:
    """`grad_steps` updates; each batch: `digit_fraction` Digit samples, the rest calibrated."""
    if len(digit) == 0:
        raise ConfigError("no Digit samples collected")
    cw, cs, cl = calibrated.arrays()
    dw, ds, dl = digit.arrays()
    # soft labels where the calibrated run learnt them (its expert is then the shield's,
    # which gives them on Digit too)
    soft = calibrated.soft and digit.soft
    ct, dt = calibrated.target_array(), digit.target_array()
    n_digit = max(1, round(cfg.digit_fraction * cfg.batch_size))
    n_cal = cfg.batch_size - n_digit
    losses = []
    student.model.train()
    for _ in range(cfg.grad_steps):
        i = rng.integers(0, len(dl), n_digit)
        j = rng.integers(0, len(cl), n_cal)
        items = np.concatenate([digit.store.frames[dw[i]], calibrated.store.frames[cw[j]]])
        stacks = observation_kind(student.grid_kind).from_items(items)
        states = np.concatenate([ds[i], cs[j]])
        labels = np.concatenate([dl[i], cl[j]])
        targets = np.concatenate([dt[i], ct[j]]) if soft else None
        mirror = rng.random(len(labels)) < 0.5 if student.mirror_augment else None
        loss = student.loss_on_stacks(stacks, states, labels, mirror, targets)
        student.optim.zero_grad(set_to_none=True)
        loss.backward()
        student.optim.step()
        losses.append(loss.item())
    return losses
