"""Output files of the command line: checked before any work, written atomically.

Two rules (docs/reliability.md):

1. **Validate first.** `check_output_file` / `check_output_dir` are called before a
   sub-command starts its long work: a path that is a directory, whose folder does not
   exist or is not writable fails at once with `OutputPathError` naming the flag.
2. **Never a half file.** Every file is written to a temporary sibling named
   `<stem>.tmp-<pid>-<random><suffix>` (same folder, so the final `os.replace` is
   atomic; the real suffix is kept so writers that pick a format from the name still
   work) and renamed onto the target only when complete. On any exception — including
   Ctrl-C — the temporary file is removed. A process killed with SIGKILL can leave only
   such a recognisable `*.tmp-*` file, never a truncated target, and the next write of
   the same target removes it (its process is gone).

JSON is strict: `write_json` turns NaN and ±inf into `null` and serialises with
`allow_nan=False`, so every file written is valid JSON for any parser.

A full disk (ENOSPC, a quota or a file size limit) while writing is an `OSError` naming
the target file (the OS names none), and the target keeps its previous content — also
for torch files (`atomic_write`: the file's own `OSError`, not the error torch makes of it).
"""

from __future__ import annotations

import errno
import json
import math
import os
import tempfile
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager, suppress
from pathlib import Path
from typing import Any, BinaryIO

from emonav_drake.errors import UserError

TMP_MARK = ".tmp-"
# The errors of a storage that is full: no space, a quota, a file size limit.
FULL_DISK_ERRNOS = (errno.ENOSPC, errno.EDQUOT, errno.EFBIG)


class OutputPathError(UserError, ValueError):
    """An output path cannot be written (a directory, a missing or read-only folder…)."""


def _where(flag: str | None, path: Path) -> str:
    return f"{flag} {path}" if flag else str(path)


SYMLINK_LOOP = "a symlink loop (a link that leads back to itself); give another path"


def is_symlink_loop(path: str | Path) -> bool:
    """Whether `path` (or a folder on the way to it) is a chain of symbolic links that
    leads back to itself: `exists()` is False for it, yet nothing can be created there."""
    try:
        os.stat(path)
    except OSError as e:
        return e.errno == errno.ELOOP
    return False


def missing_file(path: str | Path) -> str:
    """Why an input file that is not there cannot be read: "no such file", or that the
    path is a symlink loop (which `is_file()` also reports as absent)."""
    return SYMLINK_LOOP if is_symlink_loop(path) else "no such file"


def check_output_file(path: str | Path, flag: str | None = None) -> Path:
    """`path` as a `Path` if a file can be written there; else `OutputPathError`.

    The target may exist (it is replaced) but must not be a directory or a special file;
    its folder must exist and be writable. Nothing is created.
    """
    p = Path(path)
    where = _where(flag, p)
    if str(path).strip() == "":
        raise OutputPathError(f"{flag or 'output'}: empty path")
    if is_symlink_loop(p):
        raise OutputPathError(f"{where}: {SYMLINK_LOOP}")
    if p.is_dir():
        raise OutputPathError(f"{where}: is a directory; give a file name inside it")
    if p.exists() and not p.is_file():
        raise OutputPathError(f"{where}: exists and is not a regular file")
    parent = p.parent
    if not parent.exists():
        raise OutputPathError(f"{where}: folder {parent} does not exist (create it first)")
    if not parent.is_dir():
        raise OutputPathError(f"{where}: {parent} is not a folder")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise OutputPathError(f"{where}: folder {parent} is not writable")
    return p


def check_output_dir(path: str | Path, flag: str | None = None) -> Path:
    """`path` as a `Path` if it is (or can be created as) a writable directory.

    Missing folders are allowed (a run directory is created with its parents); the
    nearest existing ancestor must be a writable directory.
    """
    p = Path(path)
    where = _where(flag, p)
    if str(path).strip() == "":
        raise OutputPathError(f"{flag or 'output'}: empty path")
    if is_symlink_loop(p):
        raise OutputPathError(f"{where}: {SYMLINK_LOOP}")
    if p.exists() and not p.is_dir():
        raise OutputPathError(f"{where}: exists and is not a directory")
    probe = p
    while not probe.exists():
        probe = probe.parent
    if not probe.is_dir():
        raise OutputPathError(f"{where}: {probe} is not a folder")
    if not os.access(probe, os.W_OK | os.X_OK):
        raise OutputPathError(f"{where}: {probe} is not writable")
    return p


def _same_file(a: Path, b: Path) -> bool:
    """Whether two paths name one file: the same path once links are resolved, or the
    same inode (a hard link)."""
    if a.resolve() == b.resolve():
        return True
    try:
        return os.path.samefile(a, b)
    except OSError:  # one does not exist (yet): not the same file
        return False


def check_distinct(outputs: Mapping[str, Path | None]) -> None:
    """`OutputPathError` if two flags name the same file (one would overwrite the other),
    also by another path: a symbolic link to it, `..` or a hard link."""
    seen: list[tuple[Path, str]] = []
    for flag, path in outputs.items():
        if path is None:
            continue
        p = Path(path)
        for other, other_flag in seen:
            if _same_file(p, other):
                same = "the same file as" if p == other else f"the same file ({other}) as"
                raise OutputPathError(f"{flag} {path}: {same} {other_flag}")
        seen.append((p, flag))


def process_alive(pid: int) -> bool:
    """Whether a process with this id runs (another user's counts; a bad id does not)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # exists, owned by someone else
        return True
    except (OverflowError, ValueError, OSError):  # not a valid pid
        return False
    return True


def clean_stale_temps(path: Path) -> list[Path]:
    """Remove the temporary siblings of `path` left by writers that no longer run (a
    SIGKILL during a save): `<stem>.tmp-<pid>-…<suffix>` whose process is gone."""
    parent = path.parent if str(path.parent) else Path(".")
    removed = []
    for tmp in parent.glob(f"{path.stem}{TMP_MARK}*{path.suffix}"):
        pid = tmp.name[len(path.stem) + len(TMP_MARK) :].split("-", 1)[0]
        if pid.isdigit() and int(pid) != os.getpid() and not process_alive(int(pid)):
            tmp.unlink(missing_ok=True)
            removed.append(tmp)
    return removed


def temp_sibling(path: Path) -> Path:
    """A new empty temporary file next to `path`: `<stem>.tmp-<pid>-<random><suffix>`
    (stale ones of dead writers are removed first)."""
    parent = path.parent if str(path.parent) else Path(".")
    clean_stale_temps(path)
    fd, tmp = tempfile.mkstemp(
        dir=parent, prefix=f"{path.stem}{TMP_MARK}{os.getpid()}-", suffix=path.suffix
    )
    os.close(fd)
    return Path(tmp)


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


@contextmanager
def naming_full_disk(path: str | Path, what: str = "not written") -> Iterator[None]:
    """Re-raise a full-disk `OSError` (`FULL_DISK_ERRNOS`) as one naming `path`:
    "[Errno 28] No space left on device: <path> <what>"."""
    try:
        yield
    except OSError as e:
        if e.errno not in FULL_DISK_ERRNOS:
            raise
        raise OSError(e.errno, f"{os.strerror(e.errno)}: {path} {what}") from e


@contextmanager
def atomic_output(path: str | Path, durable: bool = False) -> Iterator[Path]:
    """Yield a temporary path to write; on success it replaces `path`, on failure it goes.

    `durable`: fsync the file before the rename and the folder after it, so the new
    content survives a power loss (run states and checkpoints); the rename is atomic
    either way.

    Example:
        with atomic_output("fig.png") as tmp:
            fig.savefig(tmp)
    """
    path = Path(path)
    with naming_full_disk(path, "not written (its previous content, if any, is kept)"):
        tmp = temp_sibling(path)
        try:
            yield tmp
            os.chmod(tmp, 0o666 & ~_umask())  # mkstemp creates 0600; give the usual mode
            if durable:
                fd = os.open(tmp, os.O_RDONLY)
                try:
                    os.fsync(fd)
                finally:
                    os.close(fd)
            os.replace(tmp, path)
        except BaseException:
            tmp.unlink(missing_ok=True)
            raise
    if durable:
        _fsync_folder(path.parent)


def _fsync_folder(folder: Path) -> None:
    """Make a rename in `folder` durable (not every OS or file system can)."""
    with suppress(OSError):
        fd = os.open(folder if str(folder) else ".", os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)


def write_text_atomic(path: str | Path, text: str, durable: bool = False) -> None:
    """Write `text` to `path` atomically (never half-written); `durable` as `atomic_output`."""
    with atomic_output(path, durable) as tmp:
        tmp.write_text(text)


def write_bytes_atomic(path: str | Path, data: bytes) -> None:
    """Write `data` to `path` atomically (never half-written)."""
    with atomic_output(path) as tmp:
        tmp.write_bytes(data)


def json_safe(obj: Any) -> Any:
    """`obj` with NaN/±inf as None, numpy scalars and arrays as Python numbers and lists."""
    if isinstance(obj, bool) or obj is None or isinstance(obj, (str, int)):
        return obj
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, Mapping):
        return {str(k): json_safe(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [json_safe(v) for v in obj]
    if isinstance(obj, Path):
        return str(obj)
    tolist = getattr(obj, "tolist", None)  # numpy scalars and arrays
    if callable(tolist):
        return json_safe(tolist())
    return obj


def write_json(path: str | Path, data: Any) -> None:
    """Write `data` as strict JSON (NaN → null, `allow_nan=False`), atomically."""
    text = json.dumps(json_safe(data), indent=2, allow_nan=False) + "\n"
    write_text_atomic(path, text)


class _WriteErrorKeeper:
    """A binary file that remembers the first `OSError` its `write`/`flush` raised.

    Serialisers written in C++ (`torch.save`'s zip writer) call `write` and, when it
    raises, throw an error of their own ("[enforce fail at inline_container.cc …] unexpected
    pos") with the `OSError` only as its context; the kept error is the true cause.
    """

    def __init__(self, file: BinaryIO) -> None:
        self._file = file
        self.error: OSError | None = None

    def write(self, data: Any) -> int:
        try:
            return self._file.write(data)
        except OSError as e:
            self.error = self.error or e
            raise

    def flush(self) -> None:
        try:
            self._file.flush()
        except OSError as e:
            self.error = self.error or e
            raise


def atomic_write(path: str | Path, write: Callable[[BinaryIO], None], durable: bool = True) -> None:
    """Atomic write through a file object: `write(file)` into a temporary sibling, renamed
    over `path` when complete (`atomic_output`; `durable` by default: state files).

    Every `torch.save` / `torch.jit.save` of the package goes through here with a file
    object, never a file name: torch's own file writer aborts the whole process (C++
    `terminate`) when the disk fills. When the disk fills during `write`, the `OSError`
    raised by the file is re-raised (naming `path`, `naming_full_disk`) whatever error the
    serialiser made of it; the temporary is removed and `path` keeps its previous content.
    """
    with atomic_output(path, durable=durable) as tmp, open(tmp, "wb") as f:
        kept = _WriteErrorKeeper(f)
        try:
            write(kept)  # type: ignore[arg-type]  # a file object with write and flush
        except Exception as e:
            if kept.error is None or e is kept.error:
                raise
            raise kept.error from e
