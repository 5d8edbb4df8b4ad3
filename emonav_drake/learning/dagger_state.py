"""The state of a DAgger run: what `dagger_state.pt` holds, and its saving and restoring.

`dagger_state.pt` (`STATE_FILE`, in the run directory) is what `--resume DIR`
continues from — format `emonav-dagger-state/2` (`learning/run_state.py`): the student
and its optimiser (tensors), the aggregated demonstrations (frames, windows, states,
labels as arrays), every random state, the round's progress (`RoundProgress`: phase,
episodes collected, gradient steps done, recent losses) and the history as JSON; read
with `torch.load(weights_only=True)`, so loading it never runs code. `DaggerRunState`
is the state in memory, which `learning/dagger.py`'s `train_dagger` advances and which
writes and restores the file; `read_dagger_state` reads and checks one.
"""

from __future__ import annotations

import dataclasses as dc
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from emonav_drake.learning.config import DaggerConfig
from emonav_drake.learning.dagger_student import Student
from emonav_drake.learning.demonstrations import Demonstrations
from emonav_drake.learning.run_state import (
    DAGGER_FORMAT,
    check_state,
    read_run_state,
    rng_state,
    set_rng_state,
    write_run_state,
)
from emonav_drake.params import ConfigError, EmoNavConfig
from emonav_drake.planners.legacy import LEGACY_EXPERT_FIELDS
from emonav_drake.typed_yaml import to_plain

STATE_FILE = "dagger_state.pt"
# What a DAgger state holds (`DaggerRunState.save`).
STATE_KEYS = ("config", "env_config", "progress", "episodes", "best_sr", "history", "rng")
DEMO_KEYS = ("frames", "windows", "states", "labels")


def read_dagger_state(
    path: str | Path, command_line: Sequence[str] | None = None
) -> tuple[DaggerConfig, dict, dict]:
    """A DAgger run's state file, read without running code and checked: (its
    configuration, its plain state, its tensors).

    `RunStateError` naming the file if it is missing, damaged, of another format, lacks
    part of the state (`STATE_KEYS`, the demonstrations' `DEMO_KEYS`), or its
    configuration has fields this emonav does not know or values out of range.

    `command_line`: the `--planner-module` values of a command that reads a state file it
    was handed (`train --resume`, `digit-rounds --from`): the configuration's
    `planner_modules` must be among them (`ConfigError` naming the file otherwise), checked
    before the configuration is validated, which imports them. None (the Python API): no
    such check.
    """
    path = Path(path)
    saved, tensors = read_run_state(path, DAGGER_FORMAT)
    if command_line is not None and isinstance(saved.get("config"), dict):
        from emonav_drake.planners.plugins import require_named_on_command_line

        require_named_on_command_line(
            saved["config"].get("planner_modules"), command_line, f"{path} (config)"
        )

    def check() -> DaggerConfig:
        missing = [k for k in (*STATE_KEYS, "demos") if k not in saved]
        if not missing and isinstance(saved["demos"], dict):
            missing = [f"demos.{k}" for k in DEMO_KEYS if k not in saved["demos"]]
        if missing:
            raise ValueError(f"no {', '.join(missing)} in it")
        keys = (*DEMO_KEYS, *(("targets",) if "targets" in saved["demos"] else ()))
        bad = [k for k in keys if not isinstance(saved["demos"][k], np.ndarray)]
        if bad:
            raise ValueError(f"demos.{bad[0]} is not an array")
        for key in ("model", "optim"):
            if not isinstance(tensors.get(key), dict):
                raise ValueError(f"no {key} state in it")
        if not isinstance(saved["config"], dict):
            raise ValueError("its configuration is not a mapping")
        known = {f.name for f in dc.fields(DaggerConfig)} | set(LEGACY_EXPERT_FIELDS)
        unknown = sorted(set(saved["config"]) - known)
        if unknown:
            raise ValueError(f"configuration fields this emonav does not know: {unknown}")
        try:
            return DaggerConfig.from_saved(saved["config"]).validate()
        except ConfigError as e:
            raise ValueError(f"its configuration: {e}") from None

    return check_state(f"{path.name} in {path.parent}", check), saved, tensors


@dc.dataclass
class RoundProgress:
    """Where a run is inside a round (saved with the state; plain data)."""

    round: int = 0
    phase: str = "collect"  # collect → train → eval, then the next round
    episode: int = 0  # episodes collected in this round
    grad_step: int = 0  # gradient steps done in this round
    outcomes: list[str] = dc.field(default_factory=list)  # of the episodes collected
    losses: list[float] = dc.field(default_factory=list)  # the last 100 training losses
    collect_s: float = 0.0  # wall time so far [s]
    train_s: float = 0.0


@dc.dataclass
class DaggerRunState:
    """A DAgger run's state in memory: what `save` writes to `STATE_FILE` and `restore`
    reads back. `n_frames` is the observation's stack depth (the samples' window);
    `episode_counter` counts the training episodes of all rounds (their scenario seeds)."""

    cfg: DaggerConfig
    env_cfg: EmoNavConfig
    student: Student
    demos: Demonstrations
    rng: np.random.Generator
    n_frames: int
    prog: RoundProgress = dc.field(default_factory=RoundProgress)
    episode_counter: int = 0
    best_sr: float = -1.0
    history: list = dc.field(default_factory=list)

    def save(self, path: Path) -> None:
        """Write the state to `path` atomically (`write_run_state`)."""
        rng_plain, rng_tensors = rng_state(self.rng)
        state = {
            "config": to_plain(self.cfg),
            "env_config": dc.asdict(self.env_cfg),
            "progress": dc.asdict(self.prog) | {"losses": self.prog.losses[-100:]},
            "episodes": self.episode_counter,
            "best_sr": self.best_sr,
            "history": self.history,
            "rng": rng_plain,
            "demos": self.demos.to_plain(self.n_frames),
        }
        tensors = {
            "model": self.student.model.state_dict(),
            "optim": self.student.optim.state_dict(),
        }
        write_run_state(path, DAGGER_FORMAT, state, tensors | rng_tensors)

    def restore(self, saved: dict, tensors: dict) -> None:
        """Back to a saved state (`read_dagger_state`'s plain state and tensors); an
        exception of `check_state`'s kinds if it does not fit."""
        student, demos = self.student, self.demos
        student.model.load_state_dict(tensors["model"])
        student.optim.load_state_dict(tensors["optim"])
        demos.load_plain(saved["demos"], self.n_frames)
        set_rng_state(self.rng, saved["rng"], tensors)
        progress = RoundProgress(**saved["progress"])
        if (
            progress.phase not in ("collect", "train", "eval")
            or min(progress.round, progress.episode, progress.grad_step) < 0
        ):
            raise ValueError(f"progress {saved['progress']} is invalid")
        self.prog, self.episode_counter, self.best_sr, self.history = (
            progress,
            int(saved["episodes"]),
            float(saved["best_sr"]),
            list(saved["history"]),
        )
