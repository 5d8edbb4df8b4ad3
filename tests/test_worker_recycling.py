"""Ray workers replaced after a number of tasks (`parallel.run_tasks(recycle_after=)`):
the results are those of the serial run, every task once, and fresh worker processes
are really started (pydrake keeps every diagram alive, so long camera runs need them)."""

from __future__ import annotations

import pytest

import emonav_drake.evaluation.emotion_timing_study as ets
import emonav_drake.parallel as parallel


@pytest.mark.slow
def test_recycled_workers_give_the_serial_results(monkeypatch):
    started = []
    real = parallel.start_actors

    def counting(ray, worker_cls, n, args, restartable=False):
        started.append(n)
        return real(ray, worker_cls, n, args, restartable)

    monkeypatch.setattr(parallel, "start_actors", counting)
    monkeypatch.setattr(ets, "RECYCLE_AFTER", 2)
    seeds = range(800_010, 800_015)
    serial = ets.study(seeds, ["paper"], ["truth"], workers=1)
    recycled = ets.study(seeds, ["paper"], ["truth"], workers=2)
    assert recycled == serial and len(serial) == 5
    # 2 actors at the start, then one for each that finished 2 tasks while work was left
    assert started[0] == 2 and sum(started) >= 3


def test_benchmark_workers_are_recycled_exactly_when_the_camera_renders_faces():
    """`run_trials` replaces its workers every `CAMERA_RECYCLE_AFTER` trials when the
    emotions come from the head camera (each trial leaks its camera diagram), not otherwise."""
    from emonav_drake.diagrams.trials import BenchmarkSpec, renders_faces
    from emonav_drake.perception.noisy_emotions import EmotionEstimateParams
    from emonav_drake.typed_yaml import dump_typed_yaml

    def spec(mode: str | None) -> BenchmarkSpec:
        yaml = None if mode is None else dump_typed_yaml(EmotionEstimateParams(mode=mode))
        return BenchmarkSpec([], "lip", "", yaml)

    assert [renders_faces(spec(m)) for m in (None, "confusion", "camera", "camera_tracks")] == [
        False,
        False,
        True,
        True,
    ]
