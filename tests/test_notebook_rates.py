"""The rates notebook runs headless in its short mode and measures the configured rates."""

import pytest

from tests.notebook_runner import run_short


@pytest.mark.slow
def test_rates_notebook_runs_in_short_mode(monkeypatch):
    outputs, _ = run_short("rates.ipynb", monkeypatch)
    assert "measured rates match the configuration" in outputs
    assert "digit/controller" in outputs and "digit/plant + framework" in outputs
    assert "| 1000 Hz | 200 Hz |" in outputs  # the sweep table
