"""Run a notebook of `notebooks/` headless in its short mode (EMONAV_SHORT=1)."""

from pathlib import Path

import nbformat
from nbclient import NotebookClient

NOTEBOOKS = Path(__file__).resolve().parent.parent / "notebooks"


def run_short(
    name: str, monkeypatch, timeout: int = 600, short: bool = True, cwd: Path | None = None
) -> tuple[str, list]:
    """Execute `notebooks/<name>` with EMONAV_SHORT=1 (unless `short` is False) and the Agg
    backend, its kernel in `cwd` (default: the notebooks' directory).

    Returns the concatenated text outputs of its code cells and the executed cells."""
    if short:
        monkeypatch.setenv("EMONAV_SHORT", "1")
    else:
        monkeypatch.delenv("EMONAV_SHORT", raising=False)
    monkeypatch.setenv("MPLBACKEND", "Agg")
    path = NOTEBOOKS / name
    nb = nbformat.read(path, as_version=4)
    where = path.parent if cwd is None else cwd
    NotebookClient(
        nb, timeout=timeout, kernel_name="python3", resources={"metadata": {"path": where}}
    ).execute()
    code = [c for c in nb.cells if c.cell_type == "code"]
    text = "".join(o.get("text", "") for c in code for o in c.get("outputs", []))
    return text, code
