"""Why a `torch.load(weights_only=True)` failed, in words a user can act on.

Checkpoints and run states are read with `weights_only=True`: nothing in a file runs
code. When such a load fails, these helpers tell a refused Python global (a pickle that
would run code, or an older file format) from a damaged file.
"""

from __future__ import annotations

import pickle  # only for its exception class: nothing is unpickled with it
import re

_UNSAFE_GLOBAL = re.compile(r"\bGLOBAL ([\w.]+)")  # in weights_only errors


def refused_global(e: BaseException) -> str | None:
    """The Python global (e.g. "posix.system") whose loading made
    `torch.load(weights_only=True)` fail, or None if it failed for another reason."""
    if not isinstance(e, pickle.UnpicklingError):
        return None
    m = _UNSAFE_GLOBAL.search(str(e))
    return m[1] if m else None


def load_failure(e: BaseException) -> str:
    """Why a `torch.load` failed, in one short line (its message's first line)."""
    text = str(e).strip()
    return text.splitlines()[0][:200] if text else type(e).__name__
