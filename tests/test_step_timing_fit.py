"""The per-step regression of `evaluation/step_timing.py` on known and on committed traces."""

from pathlib import Path

import numpy as np
import pytest

from emonav_drake.evaluation.step_timing import fit_step_timing, read_traces

ROOT = Path(__file__).resolve().parent.parent


def _trace(gain_now: float, gain_before: float, seed: int) -> list[dict]:
    """A synthetic episode whose heading turns in step k (t_k to t_{k+1}) by gain_now u_k +
    gain_before u_{k-1}; entry j holds the command held since t_{j-1}, u_{j-1}."""
    rng = np.random.default_rng(seed)
    held = rng.uniform([0.0, -0.3], [0.5, 0.3], (40, 2))
    heading = np.zeros(40)
    for k in range(1, 39):
        heading[k + 1] = heading[k] + gain_now * held[k + 1][1] + gain_before * held[k][1]
    return [{"robot": [0.0, 0.0, heading[j], held[j][0]], "held": list(held[j])} for j in range(40)]


@pytest.mark.parametrize(("now", "before"), [(1.0, 0.0), (0.2, 0.8)])
def test_the_fit_recovers_the_gains_of_a_known_walk(now, before):
    fit = fit_step_timing([_trace(now, before, s) for s in range(3)])
    assert fit.episodes == 3 and fit.steps == 3 * 37
    assert fit.turn == pytest.approx((now, before), abs=1e-9)
    if before == 0:  # every turn walked in its own step: no heading error
        assert fit.heading_rms == pytest.approx(0.0, abs=1e-12)
    else:  # most of the turn a step late
        assert fit.heading_rms > 0.01


def test_the_committed_default_traces_give_the_documented_in_step_gain():
    traces = read_traces([ROOT / "benchmarks/results/digit_step_timing/dwa_in_step_kd40.jsonl"])
    fit = fit_step_timing(traces)
    assert (fit.episodes, fit.steps) == (20, 1077)
    assert round(fit.turn[0], 3) == 1.002 and round(1000 * fit.heading_rms, 1) == 5.3


def test_too_few_steps_are_refused():
    with pytest.raises(ValueError, match="too few"):
        fit_step_timing([_trace(1.0, 0.0, 0)[:3]])
