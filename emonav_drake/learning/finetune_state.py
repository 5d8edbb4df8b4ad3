"""The state of a fine-tuning run (`learning/finetune.py`): what `finetune_state.pt` holds,
and its saving, reading and restoring.

`finetune_state.pt` (`STATE_FILE`, in the run directory) is what `--resume DIR` continues
from — format `emonav-finetune-state/1`, written by `learning/run_state.py`'s
`write_run_state` (plain data as JSON plus arrays and tensors, read with
`torch.load(weights_only=True)`: loading it never runs code), atomically:

* plain data: the configuration and environment configuration, the initial policy (its
  file and metadata, weights excluded), the progress (`Progress`: environment steps,
  episodes, whether the evaluation due now has run, the selection's best key, the history,
  the statistics since the last evaluation, wall time per phase), the update count, the
  replay buffer (`FrameReplayBuffer.state_dict`: its filled part) and the numpy and python
  generator states;
* tensors: the learner (`DiscreteSac.state_dict`: the student being fine-tuned, the frozen
  initial student, the critics and their targets, log α, the three optimisers) and the
  torch generator states.

It is written after every selection evaluation, at the end and on Ctrl-C; the run never
stops inside an episode (Ctrl-C undoes the episode being collected), so no world is saved.
"""

from __future__ import annotations

import dataclasses as dc
from pathlib import Path

import numpy as np

from emonav_drake.learning.finetune_agent import DiscreteSac
from emonav_drake.learning.replay import FrameReplayBuffer
from emonav_drake.learning.run_state import (
    check_state,
    read_run_state,
    rng_state,
    set_rng_state,
    write_run_state,
)
from emonav_drake.learning.sac_config import FinetuneConfig
from emonav_drake.params import ConfigError, EmoNavConfig

FINETUNE_FORMAT = "emonav-finetune-state/1"
STATE_FILE = "finetune_state.pt"
# What of the initial policy's metadata the fine-tuned policy file keeps.
POLICY_FIELDS = ("kind", "encoder", "hidden", "commands", "observation", "bounds")
# What a fine-tuning state holds (`write_finetune_state`).
STATE_KEYS = ("config", "env_config", "init", "progress", "updates", "replay", "rng")
AGENT_KEYS = (
    "policy",
    "init_policy",
    "critic",
    "critic_target",
    "log_alpha",
    "actor_optim",
    "critic_optim",
    "alpha_optim",
)


def new_stats() -> dict:
    """Sums over the training episodes and updates since the last evaluation."""
    return {
        "episodes": 0,
        "successes": 0,
        "collisions": 0,
        "updates": 0,
        "critic_loss": 0.0,
        "entropy": 0.0,
        "actor_updates": 0,
        "actor_loss": 0.0,
        "kl": 0.0,
    }


@dc.dataclass
class Progress:
    """Where a run is (plain data, saved with the state)."""

    env_steps: int = 0  # environment steps of the training episodes (= replay insertions)
    episodes: int = 0  # training episodes collected (their scenario seeds: offset + i)
    eval_pending: bool = True  # the evaluation due at `env_steps` has not run (at 0: the start)
    best: list[float] | None = None  # selection key of policy.pt: [SR, −collision rate, −DT]
    best_at: dict | None = None  # env steps, updates, episodes of policy.pt
    history: list[dict] = dc.field(default_factory=list)  # one entry per evaluation
    since: dict = dc.field(default_factory=new_stats)  # since the last evaluation
    collect_s: float = 0.0  # wall time per phase so far [s]
    update_s: float = 0.0
    eval_s: float = 0.0


def write_finetune_state(
    path: Path,
    cfg: FinetuneConfig,
    env_cfg: EmoNavConfig,
    init: dict,
    prog: Progress,
    agent: DiscreteSac,
    replay: FrameReplayBuffer,
    rng: np.random.Generator,
) -> None:
    """Write the run's state to `path` atomically (module docstring)."""
    rng_plain, rng_tensors = rng_state(rng)
    state = {
        "config": dc.asdict(cfg),
        "env_config": dc.asdict(env_cfg),
        "init": init,
        "progress": dc.asdict(prog),
        "updates": agent.updates,
        "replay": replay.state_dict(),
        "rng": rng_plain,
    }
    write_run_state(path, FINETUNE_FORMAT, state, {"agent": agent.state_dict()} | rng_tensors)


def read_finetune_state(path: str | Path) -> tuple[FinetuneConfig, dict, dict]:
    """A fine-tuning run's state file, read without running code and checked: (its
    configuration, its plain state, its tensors).

    `RunStateError` naming the file if it is missing, damaged, of another format, lacks
    part of the state (`STATE_KEYS`, the learner's `AGENT_KEYS`), or its configuration has
    fields this emonav does not know or values out of range.
    """
    path = Path(path)
    saved, tensors = read_run_state(path, FINETUNE_FORMAT)

    def check() -> FinetuneConfig:
        missing = [k for k in STATE_KEYS if k not in saved]
        agent = tensors.get("agent")
        if not missing and not isinstance(agent, dict):
            missing = ["agent"]
        if not missing:
            missing = [f"agent.{k}" for k in AGENT_KEYS if k not in agent]
        if missing:
            raise ValueError(f"no {', '.join(missing)} in it")
        for key in ("config", "init", "progress", "replay"):
            if not isinstance(saved[key], dict):
                raise ValueError(f"its {key} is not a mapping")
        known = {f.name for f in dc.fields(FinetuneConfig)}
        unknown = sorted(set(saved["config"]) - known)
        if unknown:
            raise ValueError(f"configuration fields this emonav does not know: {unknown}")
        try:
            return FinetuneConfig(**saved["config"]).validate()
        except ConfigError as e:
            raise ValueError(f"its configuration: {e}") from None

    return check_state(f"{path.name} in {path.parent}", check), saved, tensors


def restore_finetune_state(
    saved: dict,
    tensors: dict,
    agent: DiscreteSac,
    replay: FrameReplayBuffer,
    rng: np.random.Generator,
) -> Progress:
    """Back to a saved state (`read_finetune_state`'s plain state and tensors); an
    exception of `check_state`'s kinds if it does not fit."""
    agent.load_state_dict(tensors["agent"], saved["updates"])
    replay.load_state_dict(saved["replay"])
    set_rng_state(rng, saved["rng"], tensors)
    prog = Progress(**saved["progress"])
    if min(prog.env_steps, prog.episodes, agent.updates) < 0 or replay.size != min(
        prog.env_steps, replay.capacity
    ):
        raise ValueError(
            f"{prog.env_steps} environment steps do not fit {replay.size} stored transitions"
        )
    if set(prog.since) != set(new_stats()):
        raise ValueError(f"statistics {sorted(prog.since)} are not this emonav's")
    return prog


def history_entry(prog: Progress, agent: DiscreteSac, summary: dict, selected: bool) -> dict:
    """An evaluation's entry in the history (`summary`: `navigation.metrics.summarize` of the
    selection episodes; the keys ending in `_s` are cumulative wall times [s])."""
    s = prog.since

    def mean(key: str, count: str) -> float | None:
        return s[key] / s[count] if s[count] else None

    return {
        "env_steps": prog.env_steps,
        "episodes": prog.episodes,
        "updates": agent.updates,
        "alpha": agent.alpha,
        "eval": summary,
        "DT_per_episode": summary["DT"] / summary["episodes"],
        "selected": selected,
        "training": {  # the episodes and updates since the previous evaluation
            "episodes": s["episodes"],
            "rollout_SR": mean("successes", "episodes"),
            "rollout_collision_rate": mean("collisions", "episodes"),
            "updates": s["updates"],
            "critic_loss": mean("critic_loss", "updates"),
            "entropy": mean("entropy", "updates"),
            "actor_updates": s["actor_updates"],
            "actor_loss": mean("actor_loss", "actor_updates"),
            "kl_to_init": mean("kl", "actor_updates"),
        },
        "collect_s": prog.collect_s,
        "update_s": prog.update_s,
        "eval_s": prog.eval_s,
    }


def policy_meta(
    init: dict,
    cfg: FinetuneConfig,
    env_cfg: EmoNavConfig,
    prog: Progress,
    agent: DiscreteSac,
    command: str | None,
) -> dict:
    """The metadata of the policy file selected at the last evaluation of `prog.history`:
    the initial student's (`init`: its file and metadata), with this stage's provenance."""
    meta, last = init["meta"], prog.episodes - 1
    first_seed = cfg.train_seed_offset
    return {k: meta[k] for k in POLICY_FIELDS} | {
        "provenance": {
            "route": "finetune",
            "command": command,
            "seed": cfg.seed,
            "init_policy": init["path"],
            "init_provenance": meta.get("provenance"),
            "config": dc.asdict(cfg),
            "env_config": dc.asdict(env_cfg),
            "training_seeds": None if last < 0 else [first_seed, first_seed + last],
            "selection_seeds": [
                cfg.eval_seed_offset,
                cfg.eval_seed_offset + cfg.eval_episodes - 1,
            ],
            "env_steps": prog.env_steps,
            "updates": agent.updates,
            "episodes": prog.episodes,
            "wall_seconds": {
                "collect": round(prog.collect_s, 1),
                "update": round(prog.update_s, 1),
                "eval": round(prog.eval_s, 1),
            },
            "eval_SR": prog.history[-1]["eval"]["SR"],
            "eval": prog.history[-1]["eval"],
            "history": prog.history,
        }
    }
