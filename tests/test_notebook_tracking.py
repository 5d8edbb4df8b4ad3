"""The tracking-error notebook runs headless in its short mode."""

import os
from pathlib import Path

import nbformat
from nbclient import NotebookClient

NOTEBOOK = Path(__file__).resolve().parent.parent / "notebooks" / "tracking_errors.ipynb"


def test_tracking_notebook_runs_in_short_mode(monkeypatch):
    monkeypatch.setenv("EMONAV_SHORT", "1")
    monkeypatch.setenv("MPLBACKEND", "Agg")
    nb = nbformat.read(NOTEBOOK, as_version=4)
    NotebookClient(
        nb, timeout=300, kernel_name="python3", resources={"metadata": {"path": NOTEBOOK.parent}}
    ).execute()
    outputs = "".join(
        o.get("text", "") for c in nb.cells if c.cell_type == "code" for o in c.get("outputs", [])
    )
    assert "fell: False" in outputs
    assert "tracking RMS per step" in outputs
    assert os.environ["EMONAV_SHORT"] == "1"
