"""Reading `torch.save` files without running code, and refusing damaged ones.

Checkpoints, policies and run states are read by `load_checked`, in three checks:

1. **The archive.** `torch.save` writes a zip archive whose members carry a CRC-32 of
   their bytes; `torch.load` does not compare them, so a file with flipped bytes loads
   and drives differently. Every member's CRC is checked first (`zipfile.testzip`), and a
   file that is not a zip archive at all (random bytes, a truncated file, torch's legacy
   format) is refused before torch sees it.
2. **No code.** The file is unpickled with `weights_only=True`, whose unpickler builds
   only tensors and plain containers and refuses any other Python global.
3. **Finite numbers.** Every floating-point tensor in the file must hold finite values:
   a NaN or an infinity in the weights makes a policy stand still or a resumed run diverge.

A failure is a `CheckpointReadError` whose message says why in a few words without the
file's name (each caller puts its own file and flag in front), and without torch's advice
to switch its safe unpickler off.
"""

from __future__ import annotations

import io
import pickle  # only for its exception class: nothing is unpickled with it
import re
import zipfile
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from emonav_drake.errors import UserError

_UNSAFE_GLOBAL = re.compile(r"\bGLOBAL ([\w.]+)")  # in weights_only errors
# torch's weights_only failure: the reason sits between these two sentences
_WEIGHTS_ONLY_REASON = re.compile(
    r"WeightsUnpickler error:\s*(?P<reason>.*?)\s*(Check the documentation|$)", re.S
)


class CheckpointReadError(UserError, ValueError):
    """A `torch.save` file that `load_checked` refuses.

    `kind` is "code" (loading it would run code: `refused` names the Python global),
    "damaged" (not a zip archive, a CRC mismatch, an unreadable pickle) or "nonfinite"
    (a tensor holds NaN or ±inf; `tensor` names it).
    """

    def __init__(self, reason: str, kind: str, refused: str | None = None) -> None:
        super().__init__(reason)
        self.kind = kind
        self.refused = refused


def refused_global(e: BaseException) -> str | None:
    """The Python global (e.g. "posix.system") whose loading made
    `torch.load(weights_only=True)` fail, or None if it failed for another reason."""
    if not isinstance(e, pickle.UnpicklingError):
        return None
    m = _UNSAFE_GLOBAL.search(str(e))
    return m[1] if m else None


def load_failure(e: BaseException) -> str:
    """Why a `torch.load` failed, in one short line: torch's own reason without its advice
    to retry with the safe unpickler switched off (which would run the file's code)."""
    text = str(e).strip()
    m = _WEIGHTS_ONLY_REASON.search(text)
    if m and m["reason"]:
        text = m["reason"]
    line = " ".join(text.split())
    if not line:
        return type(e).__name__
    return line if len(line) <= 200 else line[:200] + " …"


def archive_problem(data: bytes) -> str | None:
    """What is wrong with the zip archive of a `torch.save` file, or None if every member
    is intact (its CRC-32 matches its bytes)."""
    try:
        with zipfile.ZipFile(io.BytesIO(data)) as z:
            bad = z.testzip()
    except zipfile.BadZipFile:
        return "not the zip archive torch.save writes: truncated, or another kind of file"
    except (OSError, EOFError, ValueError, RuntimeError) as e:  # zlib, truncated member
        return f"its zip archive cannot be read: {load_failure(e)}"
    if bad is not None:
        return (
            f"the bytes of its member {bad!r} do not match their CRC-32 checksum: the file "
            "changed after it was written"
        )
    return None


def tensors_of(tree: Any, where: str = "") -> Iterator[tuple[str, Any]]:
    """Every tensor in a loaded checkpoint (nested dicts, lists, tuples), with its path."""
    import torch

    if isinstance(tree, torch.Tensor):
        yield where or "tensor", tree
    elif isinstance(tree, dict):
        for k, v in tree.items():
            yield from tensors_of(v, f"{where}.{k}" if where else str(k))
    elif isinstance(tree, list | tuple):
        for i, v in enumerate(tree):
            yield from tensors_of(v, f"{where}[{i}]")


def nonfinite_tensor(tree: Any) -> str | None:
    """The path of the first floating-point tensor holding NaN or ±inf, or None."""
    import torch

    for where, t in tensors_of(tree):
        if (t.is_floating_point() or t.is_complex()) and not bool(torch.isfinite(t).all()):
            return where
    return None


def load_checked(path: str | Path, map_location: Any = "cpu") -> Any:
    """`torch.load(path, weights_only=True)` after checking the archive, then checking that
    every floating-point tensor is finite (module docstring); `CheckpointReadError` says
    why a file is refused, `OSError` if it cannot be read at all."""
    import torch

    data = Path(path).read_bytes()
    problem = archive_problem(data)
    if problem is not None:
        raise CheckpointReadError(problem, "damaged")
    try:
        blob = torch.load(io.BytesIO(data), map_location=map_location, weights_only=True)
    except Exception as e:  # noqa: BLE001 — every failure is reported the same way
        refused = refused_global(e)
        if refused is not None:
            raise CheckpointReadError(
                f"loading it would run code ({refused}); refused", "code", refused
            ) from None
        raise CheckpointReadError(load_failure(e), "damaged") from None
    where = nonfinite_tensor(blob)
    if where is not None:
        raise CheckpointReadError(
            f"the tensor {where} holds NaN or infinite values (a diverged run or a damaged file)",
            "nonfinite",
        )
    return blob
