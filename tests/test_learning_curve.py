"""The learning curve across benchmark runs: paired seeds, intervals, tests, the figure.

Real LIP benchmark runs (DWA, MPC; a few trials each) stand in for training rounds.
"""

from pathlib import Path

import pytest

from emonav_drake.diagrams.trials import method_specs
from emonav_drake.evaluation import tables
from emonav_drake.evaluation.benchmark import run_benchmark
from emonav_drake.evaluation.learning_curve import (
    CurveError,
    curve_markdown,
    measure,
    parse_point,
    plot_curve,
    route_success_rates,
)
from emonav_drake.evaluation.run_directory import load_run


@pytest.fixture(scope="module")
def runs(tmp_path_factory) -> tuple[Path, Path, Path]:
    root = tmp_path_factory.mktemp("curve")

    def bench(name: str, planners: str, first: int, trials: int, setting: str = "var_dd"):
        from emonav_drake.configs import load_setting

        run_benchmark(
            root / name, method_specs(planners), "lip", trials, first,
            load_setting(setting), setting=setting, progress=False,
        )  # fmt: skip
        return root / name

    return (
        bench("a", "dwa,mpc", 30, 5),
        bench("b", "dwa", 32, 5),
        bench("c", "dwa", 30, 2, setting="no_emotion"),
    )


@pytest.mark.slow
def test_points_are_summarised_on_their_common_seeds(runs):
    a, b, _ = runs
    points = [parse_point(f"first={a}:mpc"), parse_point(f"second={b}:dwa")]
    curve = measure(points)
    assert curve.seeds == [32, 33, 34] and curve.plant == "lip"
    _, trials_a = load_run(a)
    mpc = [t for t in trials_a if t["method"] == "mpc" and t["seed"] in (32, 33, 34)]
    direct = tables.summarize_methods(mpc)["mpc"]
    assert curve.summary["first"]["SR"] == direct["SR"]
    assert curve.summary["first"]["DT"] == direct["DT"]
    assert curve.summary["first"]["episodes"] == 3
    step = curve.steps[0]
    assert (step["a"], step["b"], step["paired_trials"]) == ("first", "second", 3)
    text = curve_markdown(curve, "Curve")
    assert text.startswith("## Curve") and "seeds 32–34" in text
    assert text.count("(n=3)") == 2
    assert f"p = {tables.format_p(step['p_value'])}" in text

    only = measure(points, seeds=[33])
    assert only.seeds == [33] and only.summary["second"]["episodes"] == 1


def test_bad_points_are_named(runs, tmp_path):
    a, b, c = runs
    with pytest.raises(CurveError, match="LABEL=RUN_DIRECTORY:METHOD"):
        parse_point("no-equals-sign")
    with pytest.raises(CurveError, match="has no method 'sac'.*dwa, mpc"):
        measure([parse_point(f"x={a}:sac")])
    with pytest.raises(CurveError, match="mix plants or settings"):
        measure([parse_point(f"x={a}:dwa"), parse_point(f"y={c}:dwa")])
    with pytest.raises(CurveError, match="given twice"):
        measure([parse_point(f"x={a}:dwa"), parse_point(f"x={b}:dwa")])
    with pytest.raises(CurveError, match="no seed is common"):
        measure([parse_point(f"x={a}:dwa")], seeds=[999])
    with pytest.raises(CurveError, match="nowhere"):
        measure([parse_point(f"x={tmp_path / 'nowhere'}:dwa")])
    bad = tmp_path / "history.json"
    bad.write_text('[{"round": 0}]')
    with pytest.raises(CurveError, match="not a DAgger history"):
        route_success_rates(bad)


def test_the_figure_is_written(runs, tmp_path):
    a, b, _ = runs
    curve = measure([parse_point(f"round 0={a}:mpc"), parse_point(f"round 1={b}:dwa")])
    hist = tmp_path / "history.json"
    hist.write_text('[{"round": 0, "eval": {"SR": 0.5}}, {"round": 1, "eval": {"SR": 0.75}}]')
    assert route_success_rates(hist) == {0: 0.5, 1: 0.75}
    png = tmp_path / "curve.png"
    plot_curve(curve, png, {"round 0": 0.5, "round 1": 0.75}, title="t")
    assert png.stat().st_size > 10_000 and png.read_bytes()[:4] == b"\x89PNG"
