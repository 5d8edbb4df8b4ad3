"""The rates notebook runs headless in its short mode and measures the configured rates."""

from pathlib import Path

import nbformat
from nbclient import NotebookClient

NOTEBOOK = Path(__file__).resolve().parent.parent / "notebooks" / "rates.ipynb"


def test_rates_notebook_runs_in_short_mode(monkeypatch):
    monkeypatch.setenv("EMONAV_SHORT", "1")
    monkeypatch.setenv("MPLBACKEND", "Agg")
    nb = nbformat.read(NOTEBOOK, as_version=4)
    NotebookClient(
        nb, timeout=600, kernel_name="python3", resources={"metadata": {"path": NOTEBOOK.parent}}
    ).execute()
    outputs = "".join(
        o.get("text", "") for c in nb.cells if c.cell_type == "code" for o in c.get("outputs", [])
    )
    assert "measured rates match the configuration" in outputs
    assert "digit/controller" in outputs and "digit/plant + framework" in outputs
    assert "| 1000 Hz | 200 Hz |" in outputs  # the sweep table
