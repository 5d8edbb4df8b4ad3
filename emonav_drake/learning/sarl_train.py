"""Training SARL by CrowdNav's route (`emonav train --algo sarl`).

1. **Imitation**: `il_episodes` episodes of the expert (`SarlConfig.expert`: the MPC by
   default) in the LIP world; every visited joint state is stored with its discounted
   return Σ_t γ̄^t r_t (γ̄ = γ^(T·v_pref), r the paper's reward, Eq. 6–9); the value
   network regresses on them for `il_epochs` epochs (SGD, momentum 0.9, MSE).
2. **Value learning**: `rl_episodes` episodes of the ε-greedy SARL planner (ε decays
   linearly from `epsilon_start` to `epsilon_end` over `epsilon_decay` episodes); after
   each, its states enter the replay memory with the targets r_t + γ̄ V_target(s_{t+1})
   (r_t alone at a collision or the goal; a timeout bootstraps), then `train_batches`
   minibatches of `batch_size` update the network; the target network is copied every
   `target_update` episodes. The imitation states stay in the memory until overwritten.
3. **Selection that cannot peek**: after imitation, every `eval_every` RL episodes and at
   the end, the greedy planner runs the selection seeds `eval_seed_offset + i`; the best
   (highest SR; ties: lower collision rate, then lower DT; an exact tie keeps the earlier)
   is `policy.pt` (a SARL checkpoint, `planners/sarl.py`) with its provenance.

Training scenarios are seeds `train_seed_offset + i` (4 000 000 … by default: disjoint from
the DAgger routes', fine-tuning's, the selection and the evaluation seeds).

The run directory: `policy.pt`, `history.json` (one entry per selection) and
`sarl_state.pt` (`--resume DIR`), written after imitation, after every selection, at the end
and on Ctrl-C (an episode being collected is undone and collected again on resume; an
update or epoch finishes first). A resumed run may raise `rl_episodes` (a longer value
learning phase); every other setting must be the run's. Everything is seeded by
`cfg.seed`: a resumed run ends bit for bit where an uninterrupted one does.
"""

from __future__ import annotations

import copy
import json
import logging
import time
from pathlib import Path

import torch
from tqdm import tqdm

from emonav_drake.atomic_io import write_text_atomic
from emonav_drake.errors import RunInterrupted
from emonav_drake.learning.config import SarlConfig
from emonav_drake.learning.config_common import with_run_world
from emonav_drake.learning.run_state import (
    InterruptGuard,
    check_state,
    clean_stale_temp_files,
    config_changes,
    read_run_state,
    rng_state,
    set_rng_state,
)
from emonav_drake.learning.sarl_run import SARL_STATE_FORMAT, STATE_FILE, SarlRun
from emonav_drake.navigation.metrics import format_summary
from emonav_drake.params import ConfigError, EmoNavConfig
from emonav_drake.planners.sarl import save_sarl
from emonav_drake.progress import progress_bar
from emonav_drake.typed_yaml import to_plain

log = logging.getLogger(__name__)


def _expert(cfg: SarlConfig, env_cfg: EmoNavConfig):
    """The imitation stage's expert: `SarlConfig.expert`, a planner spec, built."""
    return cfg.expert.build(env_cfg)


def _selection_key(s: dict) -> list:
    return [s["SR"], -s["collision_rate"], -s["DT"]]


# SarlConfig fields added after runs were saved, with the value those runs used.
FIELDS_ADDED_LATER = {"network": "sarl", "planner_modules": [], "sensor": "ideal"}


def train_sarl(
    out: str | Path,
    cfg: SarlConfig | None = None,
    env_cfg: EmoNavConfig | None = None,
    resume: bool = False,
    command: str | None = None,
    progress: bool = True,
) -> Path:
    """Train SARL into `out` (or continue the run there: `resume`); returns
    `out/policy.pt`. Raises `RunInterrupted` after Ctrl-C (state saved), `RunStateError`
    for a damaged or foreign state file, `ConfigError` for a bad configuration."""
    out = Path(out)
    cfg = (cfg or SarlConfig()).validate()
    env_cfg = with_run_world(copy.deepcopy(env_cfg or EmoNavConfig()), cfg)
    if resume:
        state, tensors = read_run_state(out / STATE_FILE, SARL_STATE_FORMAT)
        # a run saved before a field existed ran with that field's value here
        saved = FIELDS_ADDED_LATER | dict(state.get("config") or {})
        try:  # as this version writes it: an earlier version's expert name converted
            saved = to_plain(SarlConfig.from_saved(saved))
        except ConfigError as e:
            raise ConfigError(f"--resume {out}: the run's configuration: {e}") from None
        changes = config_changes(saved | {"rl_episodes": cfg.rl_episodes}, to_plain(cfg))
        if changes:
            raise ConfigError(
                f"--resume {out}: the configuration differs from the run's (only rl_episodes "
                f"may grow): {', '.join(changes)}"
            )
        if cfg.rl_episodes < saved.get("rl_episodes", 0):
            raise ConfigError(
                f"--resume {out}: rl_episodes {cfg.rl_episodes} is below the run's "
                f"{saved['rl_episodes']}"
            )
        run = SarlRun(cfg, env_cfg)
        check_state(f"{STATE_FILE} in {out}", lambda: run.restore(state, tensors))
        if run.prog.phase == "done" and run.prog.rl_episode < cfg.rl_episodes:
            run.prog.phase = "rl"  # a longer value-learning phase
    else:
        if (out / STATE_FILE).exists():
            raise ConfigError(f"{out} already holds a SARL run: continue it with --resume {out}")
        out.mkdir(parents=True, exist_ok=True)
        run = SarlRun(cfg, env_cfg)
    clean_stale_temp_files(out)
    torch.set_num_threads(cfg.threads)
    with InterruptGuard() as guard:
        _imitate(run, out, guard, progress, command)
        if not guard.requested:
            _learn(run, out, guard, progress, command)
        run.save(out)
    if guard.requested:
        raise RunInterrupted(
            f"interrupted in phase {run.prog.phase}; state saved in {out}; continue with "
            f"`emonav train --algo sarl --resume {out}`"
        )
    return out / "policy.pt"


def _imitate(run: SarlRun, out: Path, guard: InterruptGuard, progress: bool, command) -> None:
    cfg, prog = run.cfg, run.prog
    if prog.phase == "il_collect":
        expert = _expert(cfg, run.env_cfg)
        t0 = time.perf_counter()
        bar = progress_bar(
            total=cfg.il_episodes,
            initial=prog.il_episode,
            desc="SARL imitation",
            unit="ep",
            enabled=progress,
        )
        while prog.il_episode < cfg.il_episodes and not guard.requested:
            undo = rng_state(run.rng)
            try:
                with guard.abortable():
                    expert.reset()
                    w = run.world(cfg.train_seed_offset + prog.il_episode)
                    states, rewards, _, _ = run.episode(
                        w, lambda world: expert.plan(world.planner_input())
                    )
            except KeyboardInterrupt:
                set_rng_state(run.rng, *undo)
                break
            ret = 0.0
            for rows, r in zip(reversed(states), reversed(rewards), strict=True):
                ret = r + run.gamma_bar * ret
                run.memory.push(rows, ret)
            prog.il_episode += 1
            bar.update(1)
        bar.close()
        prog.il_s += time.perf_counter() - t0
        if prog.il_episode >= cfg.il_episodes:
            prog.phase = "il_train"
    if prog.phase == "il_train" and not guard.requested:
        t0 = time.perf_counter()
        per_epoch = max(1, run.memory.size // cfg.batch_size)
        bar = progress_bar(
            total=cfg.il_epochs,
            initial=prog.il_epoch,
            desc="SARL imitation training",
            unit="epoch",
            enabled=progress,
        )
        while prog.il_epoch < cfg.il_epochs and not guard.requested:
            loss = run.train_batches(per_epoch)
            prog.il_epoch += 1
            bar.set_postfix(loss=f"{loss:.4f}")
            bar.update(1)
        bar.close()
        prog.il_s += time.perf_counter() - t0
        if prog.il_epoch >= cfg.il_epochs:
            run.target.load_state_dict(run.model.state_dict())
            run._rl_optimiser()
            prog.phase = "rl"
            _select(run, out, progress, command)
            run.save(out)


def _learn(run: SarlRun, out: Path, guard: InterruptGuard, progress: bool, command) -> None:
    cfg, prog = run.cfg, run.prog
    if prog.phase != "rl":
        return
    bar = progress_bar(
        total=cfg.rl_episodes,
        initial=prog.rl_episode,
        desc="SARL value learning",
        unit="ep",
        enabled=progress,
    )
    while prog.rl_episode < cfg.rl_episodes and not guard.requested:
        t0 = time.perf_counter()
        undo = rng_state(run.rng)
        eps = run.epsilon()
        try:
            with guard.abortable():
                w = run.world(cfg.train_seed_offset + cfg.il_episodes + prog.rl_episode)
                states, rewards, outcome, terminal = run.episode(
                    w, lambda world, eps=eps: run.act(world, eps)
                )
        except KeyboardInterrupt:
            set_rng_state(run.rng, *undo)
            break
        for i, (rows, r) in enumerate(zip(states, rewards, strict=True)):
            last = i == len(states) - 1
            if last and terminal:
                target = r
            else:
                nxt = states[i + 1] if not last else run.rows_now(w)
                target = r + run.gamma_bar * run.value(nxt)
            run.memory.push(rows, target)
        loss = run.train_batches(cfg.train_batches)
        prog.rl_episode += 1
        if prog.rl_episode % cfg.target_update == 0:
            run.target.load_state_dict(run.model.state_dict())
        prog.rl_s += time.perf_counter() - t0
        bar.set_postfix(eps=f"{eps:.2f}", loss=f"{loss:.4f}", last=outcome)
        bar.update(1)
        if prog.rl_episode % cfg.eval_every == 0 or prog.rl_episode == cfg.rl_episodes:
            _select(run, out, progress, command)
            run.save(out)
    bar.close()
    if prog.rl_episode >= cfg.rl_episodes:
        prog.phase = "done"


def _select(run: SarlRun, out: Path, progress: bool, command) -> None:
    """Evaluate the greedy planner on the selection seeds; keep it if it is the best."""
    prog, cfg = run.prog, run.cfg
    if prog.evaluated_at == prog.rl_episode:
        return
    t0 = time.perf_counter()
    summary = run.evaluate()
    prog.eval_s += time.perf_counter() - t0
    prog.evaluated_at = prog.rl_episode
    key = _selection_key(summary)
    kept = prog.best is None or key > prog.best
    prog.history.append(
        {"rl_episode": prog.rl_episode, "epsilon": run.epsilon(), "eval": summary, "kept": kept}
    )
    if kept:
        prog.best = key
        save_sarl(
            out / "policy.pt",
            run.model,
            run.commands,
            cfg.gamma,
            _provenance(run, summary, command),
            network=cfg.network,
        )
    write_text_atomic(out / "history.json", json.dumps(prog.history, indent=1, default=float))
    msg = f"SARL after {prog.rl_episode} RL episodes: {format_summary(summary)}"
    (tqdm.write if progress else log.info)(msg + ("  [kept]" if kept else ""))


def _provenance(run: SarlRun, summary: dict, command) -> dict:
    cfg, prog = run.cfg, run.prog
    last_train = cfg.train_seed_offset + cfg.il_episodes + prog.rl_episode - 1
    return {
        "route": "sarl",
        "network": cfg.network,
        "command": command,
        "seed": cfg.seed,
        "config": to_plain(cfg),
        "episode": prog.rl_episode,
        "training_seeds": [cfg.train_seed_offset, last_train],
        "selection_seeds": [cfg.eval_seed_offset, cfg.eval_seed_offset + cfg.eval_episodes - 1],
        "samples": int(run.memory.size),
        "wall_seconds": {
            "imitation": round(prog.il_s, 1),
            "value_learning": round(prog.rl_s, 1),
            "selection": round(prog.eval_s, 1),
        },
        "eval_SR": summary["SR"],
        "eval": summary,
    }
