"""What code produced a result: the package's version, git commit and code hash.

Every run directory and checkpoint that records provenance uses these: a benchmark
refuses to continue a run with other code (`code_hash`), Ray pools refuse a worker that
runs other code than its driver, and checkpoints carry the file hashes of what they were
trained from.
"""

from __future__ import annotations

import hashlib
import os
import subprocess
from pathlib import Path
from typing import Any


def sha256_bytes(data: bytes) -> str:
    """Hex sha256 of `data`."""
    return hashlib.sha256(data).hexdigest()


def sha256_file(path: str | Path) -> str:
    """Hex sha256 of the file at `path`, read in 1 MiB chunks."""
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


_PACKAGE_DIR = Path(__file__).resolve().parent  # the emonav_drake package


def code_hash() -> str:
    """sha256 over the package's Python sources (relative path and bytes, sorted)."""
    h = hashlib.sha256()
    for p in sorted(_PACKAGE_DIR.rglob("*.py")):
        if "__pycache__" in p.parts:
            continue
        h.update(str(p.relative_to(_PACKAGE_DIR)).encode() + b"\0")
        h.update(p.read_bytes() + b"\0")
    return h.hexdigest()


def _git(*args: str) -> str | None:
    root = _PACKAGE_DIR.parent
    if not (root / ".git").exists():
        return None
    try:
        out = subprocess.run(
            ["git", "-C", str(root), *args], capture_output=True, text=True, timeout=10
        )
    except (OSError, subprocess.SubprocessError):
        return None
    return out.stdout.strip() if out.returncode == 0 else None


def package_identity(with_commit: bool = True) -> dict:
    """Version, git commit (if a checkout) and whether the package differs from it, code hash."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        ver = version("emonav_drake")
    except PackageNotFoundError:
        ver = "unknown"
    out: dict[str, Any] = {"version": ver}
    if with_commit:
        out["commit"] = _git("rev-parse", "HEAD")
        status = _git("status", "--porcelain", "--", "emonav_drake")
        out["dirty"] = None if status is None else bool(status)
    out["code_sha256"] = code_hash()
    return out


def numeric_kernels() -> dict:
    """The kernel sets this process's numerics run on: every BLAS library numpy and SciPy
    loaded, with its version and the architecture its kernels were chosen for
    (OpenBLAS picks them by the processor at import, e.g. `Haswell` or `SkylakeX`, unless
    `OPENBLAS_CORETYPE` names them), and that variable itself. Two machines whose BLAS
    kernels differ give records that differ in their last bits (docs/reliability.md,
    "OpenBLAS chooses its kernels …")."""
    import numpy  # noqa: F401  (loads numpy's BLAS)
    import scipy.linalg  # noqa: F401  (and SciPy's)
    from threadpoolctl import threadpool_info

    blas = sorted(
        {
            (str(i.get("internal_api")), str(i.get("version")), str(i.get("architecture")))
            for i in threadpool_info()
            if i.get("user_api") == "blas"
        }
    )
    return {
        "blas": [{"library": a, "version": v, "architecture": k} for a, v, k in blas],
        "OPENBLAS_CORETYPE": os.environ.get("OPENBLAS_CORETYPE"),
    }


def kernels_words(numerics: dict | None) -> str:
    """The BLAS kernels a `numeric_kernels` record names, as "library architecture" words
    (each kind once, sorted; '' when it names none)."""
    blas = (numerics or {}).get("blas") or []
    return ", ".join(sorted({f"{b['library']} {b['architecture']}" for b in blas}))


def kernels_difference(old: dict | None, new: dict) -> str | None:
    """How the BLAS kernels of `new` (`numeric_kernels`) differ from a run's recorded
    `old`, as words with the variable that would match them; None when they agree or the
    run recorded none."""
    there, here = kernels_words(old), kernels_words(new)
    if not old or there == here:  # the same kernel sets (library versions aside)
        return None
    hint = ""
    arch = {b["architecture"] for b in old.get("blas", []) if b["library"] == "openblas"}
    if len(arch) == 1:
        hint = f"; OPENBLAS_CORETYPE={arch.pop()} before Python starts runs its kernels"
    return f"the BLAS kernels are {there or 'none'} there, {here or 'none'} here{hint}"


# --------------------------------------------------------------------------- settings
