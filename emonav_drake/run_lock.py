"""Run directories: one writer at a time, and a finished run never replaced silently.

A run directory (`emonav train --out DIR`, `emonav digit-rounds --out DIR`, `emonav
benchmark --out DIR`) is written by one process at a time: `locked_directory` takes an
exclusive `flock` on the directory itself (no lock file to leave behind; the kernel drops
the lock when the process ends, however it ends), and a second writer is refused at once.

A new training run goes into an empty or new directory only (`claim_new_run`): a directory
that holds anything is refused, naming what it holds and the two ways on — `--resume` to
continue the run there, or `--overwrite` to start a new one in its place. `--overwrite`
removes only the files a training run writes (`TRAINING_RUN_FILES`) and keeps every
other file.
"""

from __future__ import annotations

import contextlib
import fnmatch
import os
import shutil
from collections.abc import Iterator
from pathlib import Path

from emonav_drake.atomic_io import OutputPathError

# What the trainers write into their run directory (and their atomic writers' temporaries).
TRAINING_RUN_FILES = (
    "checkpoint.pt",  # SAC
    "dagger_state.pt",
    "finetune_state.pt",
    "sarl_state.pt",
    "digit_rounds.pt",
    "policy.pt",
    "policy_round*.pt",
    "history.json",
    "learning_curve.csv",
    "tensorboard",
    "*.tmp-*",
    "*.emonav-*.tmp",
)


class RunDirectoryBusy(OutputPathError):
    """Another emonav process writes into this run directory."""


@contextlib.contextmanager
def locked_directory(path: str | Path, flag: str = "--out", what: str = "run") -> Iterator[Path]:
    """Exclusive use of the directory `path` (created with its parents) while the block
    runs; `RunDirectoryBusy` at once if another process holds it. `what` names the kind
    of run in the message ("benchmark", "training run")."""
    import fcntl

    path = Path(path)
    path.mkdir(parents=True, exist_ok=True)
    fd = os.open(path, os.O_RDONLY)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        os.close(fd)
        raise RunDirectoryBusy(
            f"{flag} {path}: another emonav {what} is running in this directory"
        ) from None
    try:
        yield path
    finally:
        fcntl.flock(fd, fcntl.LOCK_UN)
        os.close(fd)


def run_files(path: Path) -> list[Path]:
    """The entries of `path` that a training run writes (`TRAINING_RUN_FILES`)."""
    return sorted(
        p
        for p in path.iterdir()
        if any(fnmatch.fnmatch(p.name, pattern) for pattern in TRAINING_RUN_FILES)
    )


def claim_new_run(path: Path, overwrite: bool, flag: str = "--out") -> list[Path]:
    """Make `path` (an existing, locked directory) ready for a new training run.

    An empty directory is taken as it is. A directory with entries is refused
    (`OutputPathError` naming a few of them) unless `overwrite`: then the entries a
    training run writes are removed (returned) and every other entry is kept.
    """
    entries = sorted(path.iterdir())
    if not entries:
        return []
    if not overwrite:
        shown = ", ".join(p.name for p in entries[:4]) + (", …" if len(entries) > 4 else "")
        return_hint = (
            f"continue the run with --resume {path}, " if run_files(path) else ""
        ) + "choose a new --out, or give --overwrite to replace the run's files"
        raise OutputPathError(f"{flag} {path}: is not empty (it holds {shown}); {return_hint}")
    removed = run_files(path)
    for p in removed:
        if p.is_dir() and not p.is_symlink():
            shutil.rmtree(p)
        else:
            p.unlink()
    return removed


@contextlib.contextmanager
def training_run_directory(
    path: Path, resume: bool, overwrite: bool = False, flag: str = "--out"
) -> Iterator[Path]:
    """The run directory of a training command, locked for the block: a new run
    (`resume` False) claims it (`claim_new_run`: empty, or `overwrite`); the removed files
    are named on stderr. A directory this call created and left empty (a refusal before
    any work) is removed again."""
    import sys

    created = not path.exists()
    try:
        with locked_directory(path, flag, "training run"):
            if not resume:
                for p in claim_new_run(path, overwrite, flag):
                    print(f"--overwrite: removed {p}", file=sys.stderr)
            yield path
    finally:
        if created and path.is_dir() and not any(path.iterdir()):
            path.rmdir()
