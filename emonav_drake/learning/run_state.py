"""Run-directory state of the trainers, stored without pickle; atomic saves; Ctrl-C.

A run directory (`emonav train --out DIR`) holds one state file that `--resume DIR`
reads back: `checkpoint.pt` (SAC) or `dagger_state.pt` (DAgger). It is a `torch.save`
zip holding only a dict of

    "format": "emonav-sac-checkpoint/2" | "emonav-dagger-state/2",
    "state":  JSON text: every counter, the configuration, the numpy and python `random`
              generator states, the environment mid-episode (scenario, robot, crowd,
              tracker, frame stack), ...; a NumPy array appears in it as
              {"__ndarray__": "a<i>"} (a NumPy scalar: {"__ndarray__": ..., "scalar": true}),
    "arrays": {"a<i>": tensor}: those arrays as CPU tensors of the same dtype and shape,
    "torch":  torch-native state: network and optimiser state dicts, torch RNG states.

It is read with `torch.load(weights_only=True)`, whose unpickler builds only tensors and
plain containers (dict, list, tuple, str, numbers, None) and refuses any other Python
global, then `json.loads`: **loading a run directory never runs code**. A file of the
pickle-based format 1 (emonav before this format), a crafted file, a truncated file or
a file of another format is refused with a `RunStateError` naming the file.

Saves are atomic and durable (`atomic_io.atomic_write`): the file is written to a
temporary sibling `STEM.tmp-<pid>-<random>SUFFIX`, fsynced, then renamed over `NAME`,
and the directory is fsynced. A full disk during a save is an `OSError` naming the file
("No space left on device: …/checkpoint.pt not written"), the temp file removed and the
previous state kept. A save killed half-way (SIGKILL, power loss) leaves only such a temp
file; `clean_stale_temp_files` removes those of dead processes when the next
run starts (and those of the earlier writers: `NAME.emonav-<pid>.tmp`, pickle-era names).

`InterruptGuard` turns Ctrl-C (and SIGTERM) into a request that the trainer polls at
consistent points (between SAC steps, between DAgger episodes and updates); a second
Ctrl-C while the trainer finishes its step or saves is ignored.
"""

from __future__ import annotations

import contextlib
import json
import os
import random
import re
import signal
import threading
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
import torch

from emonav_drake.atomic_io import atomic_write, process_alive
from emonav_drake.errors import UserError
from emonav_drake.torch_load import CheckpointReadError, load_checked

SAC_FORMAT = "emonav-sac-checkpoint/2"
DAGGER_FORMAT = "emonav-dagger-state/2"
_ARRAY = "__ndarray__"
_TMP = re.compile(r"^.+\.tmp-(?P<pid>\d+)-[^.]*(\.[^.]+)?$")  # atomic_io.temp_sibling
_OLD_TMP = re.compile(r"^(?P<name>.+)\.emonav-(?P<pid>\d+)\.tmp$")  # the writer before it
# Temp files of the pickle-era writer (`tempfile.mkstemp(prefix=NAME, suffix=".tmp")`)
# for the files a run directory holds: also ours, also removed.
_LEGACY_TMP = re.compile(
    r"^(checkpoint\.pt|dagger_state\.pt|policy(_round\d+)?\.pt)[a-z0-9_]{8}\.tmp$"
)


class RunStateError(UserError, ValueError):
    """A run directory cannot be resumed: no state, or a damaged, foreign or old file."""


# ------------------------------------------------------------------------- plain data


def pack(tree: Any) -> tuple[str, dict[str, torch.Tensor]]:
    """Plain data → (JSON text, arrays as tensors).

    Accepts dicts with str keys, lists, tuples (read back as lists), str, bool, int,
    float (NaN and ±inf included), None, NumPy arrays and NumPy scalars (both read back
    with their dtype). Anything else raises `TypeError` at save time.
    """
    arrays: dict[str, torch.Tensor] = {}

    def enc(x: Any, where: str) -> Any:
        if x is None or type(x) in (bool, int, float, str):
            return x
        if isinstance(x, np.ndarray | np.generic):
            key = f"a{len(arrays)}"
            a = np.asarray(x)
            if a.dtype.kind not in "biuf" or a.dtype.byteorder == ">":
                raise TypeError(f"{where}: arrays of dtype {a.dtype} are not stored")
            if not _whole(a):
                a = a.copy()  # torch.save would write a view's whole storage
            arrays[key] = torch.from_numpy(a)
            return {_ARRAY: key, "scalar": True} if isinstance(x, np.generic) else {_ARRAY: key}
        if isinstance(x, dict):
            out = {}
            for k, v in x.items():
                if type(k) is not str or k == _ARRAY:
                    raise TypeError(f"{where}: key {k!r} is not a plain string key")
                out[k] = enc(v, f"{where}.{k}")
            return out
        if isinstance(x, list | tuple):
            return [enc(v, f"{where}[{i}]") for i, v in enumerate(x)]
        raise TypeError(f"{where}: {type(x).__name__} is not plain data")

    return json.dumps(enc(tree, "state")), arrays


def _whole(a: np.ndarray) -> bool:
    """Whether `a` is C-contiguous, writeable and spans all of its memory buffer."""
    if not (a.flags.c_contiguous and a.flags.writeable):
        return False
    root = a
    while isinstance(root, np.ndarray) and root.base is not None:
        root = root.base
    if isinstance(root, np.ndarray):
        return root.nbytes == a.nbytes
    if isinstance(root, torch.Tensor):  # an array read back by `unpack`
        return root.untyped_storage().nbytes() == a.nbytes
    return False


def unpack(text: str, arrays: dict[str, torch.Tensor]) -> Any:
    """Inverse of `pack`."""

    def dec(x: Any) -> Any:
        if isinstance(x, dict):
            if _ARRAY in x:
                a = arrays[x[_ARRAY]]
                if not isinstance(a, torch.Tensor):
                    raise TypeError(f"array {x[_ARRAY]!r} is not a tensor")
                a = a.numpy()
                return a[()] if x.get("scalar") else a
            return {k: dec(v) for k, v in x.items()}
        if isinstance(x, list):
            return [dec(v) for v in x]
        return x

    return dec(json.loads(text))


# ------------------------------------------------------------------------ files


def clean_stale_temp_files(directory: str | Path) -> list[Path]:
    """Remove the temp files that killed saves left in a run directory; returns them.

    Only our own names are touched: `STEM.tmp-<pid>-<random>SUFFIX` (and the earlier
    `NAME.emonav-<pid>.tmp`) of a process that is no longer running (or of this process:
    nothing is being saved yet), and the pickle-era writer's `checkpoint.pt*.tmp`,
    `dagger_state.pt*.tmp`, `policy*.pt*.tmp`.
    """
    removed = []
    directory = Path(directory)
    if not directory.is_dir():
        return removed
    for p in directory.iterdir():
        m = _TMP.match(p.name) or _OLD_TMP.match(p.name)
        writer = int(m["pid"]) if m is not None else None
        # ours and gone, or ours from this very process (it saves nothing yet)
        ours_stale = writer is not None and (writer == os.getpid() or not process_alive(writer))
        stale = ours_stale or bool(_LEGACY_TMP.match(p.name))
        if stale and p.is_file():
            with contextlib.suppress(FileNotFoundError):
                p.unlink()
                removed.append(p)
    return removed


def write_run_state(path: str | Path, fmt: str, state: Any, tensors: dict[str, Any]) -> None:
    """Save a run's state (`state`: plain data, `tensors`: torch-native) atomically."""
    text, arrays = pack(state)
    blob = {"format": fmt, "state": text, "arrays": arrays, "torch": tensors}
    atomic_write(path, lambda f: torch.save(blob, f))


def read_run_state(path: str | Path, fmt: str | None) -> tuple[Any, dict[str, Any]]:
    """Load what `write_run_state` wrote, without running code; `RunStateError` if the
    file is missing, damaged, of another format or not ours."""
    path = Path(path)
    where = f"{path.name} in {path.parent}"
    fresh = f"start a new run (--out DIR) or restore a copy of {path.name}"
    if not path.is_file():
        raise RunStateError(f"{where} does not exist: nothing to resume")
    try:
        blob = load_checked(path)
    except CheckpointReadError as e:
        if e.kind == "code" and (e.refused or "").startswith("numpy"):
            raise RunStateError(
                f"{where} was written by an older emonav (format 1, pickle-based) and "
                f"cannot be resumed safely; start a new run"
            ) from None
        if e.kind == "code":
            raise RunStateError(f"{where} is not an emonav run state: {e} — {fresh}") from None
        if e.kind == "damaged":
            raise RunStateError(f"{where} is damaged or truncated ({e}); {fresh}") from None
        raise RunStateError(f"{where}: {e}; {fresh}") from None
    if not isinstance(blob, dict):
        raise RunStateError(f"{where} is not an emonav run state; {fresh}")
    found = blob.get("format")
    if found is None:
        raise RunStateError(
            f"{where} was written by an older emonav (format 1) and cannot be resumed "
            f"safely; start a new run"
        )
    if fmt is not None and found != fmt:
        raise RunStateError(f"{where} has format {found!r}, this emonav reads {fmt!r}; {fresh}")
    try:
        state = unpack(blob["state"], blob["arrays"])
        tensors = blob["torch"]
        if not isinstance(state, dict) or not isinstance(tensors, dict):
            raise TypeError("unexpected layout")
    except (KeyError, TypeError, ValueError, AttributeError, RecursionError) as e:
        raise RunStateError(f"{where} is damaged ({e}); {fresh}") from None
    return state, tensors


def read_state_config(path: str | Path) -> dict[str, Any]:
    """The configuration a run state of any route records (its `config`), read as
    `read_run_state` reads the whole state; `RunStateError` if it has none."""
    state, _ = read_run_state(path, None)
    config = state.get("config")
    if not isinstance(config, dict):
        path = Path(path)
        raise RunStateError(f"{path.name} in {path.parent} records no configuration")
    return config


def check_state(where: str, fn: Callable[[], Any], changes: list[str] | None = None) -> Any:
    """Run `fn` (restoring from loaded state); a malformed state → `RunStateError`.

    `changes` (`config_changes`): the configuration fields that differ from the saved
    run's, named in the error as a likely cause.
    """
    try:
        return fn()
    except (KeyError, TypeError, ValueError, IndexError, AttributeError, RuntimeError) as e:
        if isinstance(e, RunStateError):
            raise
        reason = f"no {e} in it" if isinstance(e, KeyError) else str(e) or type(e).__name__
        cause = f"; the configuration differs from the saved one: {', '.join(changes or [])}"
        raise RunStateError(
            f"{where} is damaged or does not fit this run ({reason}){cause if changes else ''}"
        ) from None


def config_changes(saved: Any, current: Any, prefix: str = "") -> list[str]:
    """The fields in which two configurations (plain dicts, nested by section) differ, as
    "name: saved → current" (a field on one side only: "(absent)"), in field order."""
    if saved is None:
        return [f"{prefix or 'configuration'}: not saved"]
    if not (isinstance(saved, dict) and isinstance(current, dict)):
        return [] if saved == current else [f"{prefix or 'config'}: {saved!r} → {current!r}"]
    out: list[str] = []
    for key in list(saved) + [k for k in current if k not in saved]:
        name = f"{prefix}{key}"
        if key not in current:
            out.append(f"{name}: {saved[key]!r} → (absent)")
        elif key not in saved:
            out.append(f"{name}: (absent) → {current[key]!r}")
        elif isinstance(saved[key], dict) and isinstance(current[key], dict):
            out += config_changes(saved[key], current[key], f"{name}.")
        elif saved[key] != current[key]:
            out.append(f"{name}: {saved[key]!r} → {current[key]!r}")
    return out


# ------------------------------------------------------------------------ random states


def rng_state(rng: np.random.Generator) -> tuple[dict, dict]:
    """Every random state of a run: (plain data, tensors)."""
    plain = {"numpy": rng.bit_generator.state, "python": random.getstate()}
    tensors: dict[str, Any] = {"torch_rng": torch.get_rng_state()}
    if torch.cuda.is_available():
        tensors["cuda_rng"] = torch.cuda.get_rng_state_all()
    return plain, tensors


def set_rng_state(rng: np.random.Generator, plain: dict, tensors: dict) -> None:
    """Inverse of `rng_state`."""
    rng.bit_generator.state = plain["numpy"]
    version, internal, gauss = plain["python"]
    random.setstate((version, tuple(internal), gauss))
    torch.set_rng_state(tensors["torch_rng"])
    if torch.cuda.is_available() and "cuda_rng" in tensors:
        torch.cuda.set_rng_state_all(tensors["cuda_rng"])


# ------------------------------------------------------------------------ Ctrl-C


class InterruptGuard:
    """Ctrl-C → a stop request the trainer polls (`requested`) at a consistent point.

    While installed (a `with` block, main thread only) the first SIGINT — or SIGTERM, as
    a scheduler or `kill` sends — sets `requested`; inside `abortable()` it also raises
    `KeyboardInterrupt` at once, for work the caller can roll back (an evaluation, an
    episode being collected). Later signals are counted in `extra` and otherwise ignored,
    so a second Ctrl-C during the save cannot corrupt it or print a traceback. A SIGINT
    that was ignored on entry (a background job) stays ignored. The previous handlers are
    restored on exit.
    """

    def __init__(self) -> None:
        self.requested = False
        self.extra = 0
        self._raise = False
        self._previous: dict[int, Any] = {}

    def __enter__(self) -> InterruptGuard:
        if threading.current_thread() is threading.main_thread():
            for sig in (signal.SIGINT, signal.SIGTERM):
                if sig == signal.SIGINT and signal.getsignal(sig) == signal.SIG_IGN:
                    continue
                self._previous[sig] = signal.signal(sig, self._handle)
        return self

    def __exit__(self, *exc: object) -> None:
        for sig, previous in self._previous.items():
            if previous is None:  # a handler not set from Python: back to the default
                previous = signal.default_int_handler if sig == signal.SIGINT else signal.SIG_DFL
            signal.signal(sig, previous)
        self._previous.clear()

    def _handle(self, signum: int, frame: object) -> None:
        # No I/O here: the handler may run in the middle of a write to the terminal.
        if self.requested:
            self.extra += 1
            return
        self.requested = True
        if self._raise:
            self._raise = False
            raise KeyboardInterrupt

    @contextlib.contextmanager
    def abortable(self) -> Iterator[None]:
        """A block that a Ctrl-C interrupts at once (`KeyboardInterrupt`)."""
        if self.requested:
            raise KeyboardInterrupt
        self._raise = True
        try:
            yield
        finally:
            self._raise = False
