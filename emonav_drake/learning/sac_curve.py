"""The SAC trainer's learning curve: `learning_curve.csv` (one row per evaluation) and the
TensorBoard scalars beside it.

`check_curve` refuses a damaged or short file before a resume, `truncate_curve` cuts it back
to the rows the checkpoint knows, `append_curve_row` adds an evaluation's row (writing the
header first), `open_tensorboard` opens the run's event writer (None without tensorboard).
"""

from __future__ import annotations

import csv
import io
import logging
import os
from pathlib import Path

from emonav_drake.atomic_io import naming_full_disk, write_text_atomic
from emonav_drake.learning.run_state import RunStateError
from emonav_drake.learning.sac import SacAgent

# the trainer's logger: its messages keep their name
log = logging.getLogger("emonav_drake.learning.sac_trainer")

CHECKPOINT = "checkpoint.pt"  # the trainer's state, beside the curve

CURVE = "learning_curve.csv"
_CURVE_HEADER = [
    "step",
    "episodes",
    "SR",
    "collision_rate",
    "timeout_rate",
    "NT_mean",
    "DT",
    "return_mean",
    "alpha",
]


def check_curve(path: Path, rows: int) -> None:
    """A resumed run's learning curve: UTF-8 CSV, our header and at least the `rows`
    evaluations the checkpoint counts; else `RunStateError` naming the file."""
    if not path.exists():
        return
    where = f"{path.name} in {path.parent}"
    try:
        lines = path.read_text(encoding="utf-8").splitlines()
        table = list(csv.reader(lines))
    except (UnicodeDecodeError, csv.Error) as e:
        raise RunStateError(f"{where} is damaged ({e}); remove it or restore a copy") from None
    if table[:1] != [_CURVE_HEADER]:
        raise RunStateError(
            f"{where} is damaged: its first line is not the header {','.join(_CURVE_HEADER)}"
            "; remove it or restore a copy"
        )
    if len(table) - 1 < rows:
        raise RunStateError(
            f"{where} has {len(table) - 1} evaluations, {CHECKPOINT} counts {rows}: damaged "
            "or cut; remove it or restore a copy"
        )


def truncate_curve(path: Path, rows: int) -> None:
    """Keep the header and the first `rows` rows of a CSV (none: remove the file)."""
    if not path.exists():
        return
    lines = path.read_text().splitlines(keepends=True)
    keep = lines[: rows + 1] if rows > 0 else []
    if keep == lines:
        return
    if keep:
        write_text_atomic(path, "".join(keep), durable=True)
    else:
        path.unlink()


def append_curve_row(path: Path, step: int, episodes: int, s: dict, agent: SacAgent) -> None:
    """Append one evaluation row (and the header, for a new file) in one write; on a full
    disk the file is cut back to its previous rows and the error names it."""
    buf = io.StringIO()
    w = csv.writer(buf)
    if not path.exists():
        w.writerow(_CURVE_HEADER)
    w.writerow(
        [
            step,
            episodes,
            s["SR"],
            s["collision_rate"],
            s["timeout_rate"],
            s["NT_mean"],
            s["DT"],
            s["return_mean"],
            agent.alpha.item(),
        ]
    )
    data = buf.getvalue().encode()
    with naming_full_disk(path, "could not be appended to (its earlier rows are kept)"):
        fd = os.open(path, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o666)
        try:
            size = os.fstat(fd).st_size
            try:
                done = 0
                while done < len(data):
                    done += os.write(fd, data[done:])
            except OSError:
                os.ftruncate(fd, size)  # no torn row
                raise
        finally:
            os.close(fd)


def open_tensorboard(out: Path):
    try:
        from torch.utils.tensorboard import SummaryWriter
    except ImportError:  # tensorboard is optional: the CSV has the learning curve
        log.warning("tensorboard is not installed: logging to learning_curve.csv only")
        return None
    return SummaryWriter(str(out / "tensorboard"))
