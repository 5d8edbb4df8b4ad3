"""Emotion known when it matters, measured: per family and per emotion source.

Each task is one LIP episode (the MPC on the LiDAR tracks, the exact scan) of one scenario
family and one emotion source (`VARIANTS`), traced; `navigation/emotion_timing.py` turns the
trace into one sample per approached pedestrian (what the planner believed of them when the
robot first came within their discomfort distance + 1 m, and whether their face could have
been seen before). The episode's steps inside a true negative zone (IDT negative) come from
its record. Tasks run on Ray (`parallel.run_tasks`) or serially in this process
(`workers=1`): the same results either way.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any

from emonav_drake.parallel import Worker
from emonav_drake.params import EmoNavConfig

# The emotion sources compared: the simulator's emotions; the paper's per-frame camera
# (the Haar cascade, 0.5 Hz); emotions kept per track with the cascade and with BlazeFace
# at 0.5 Hz, and with BlazeFace at 2.5 Hz (`--emotion-source camera_tracks`).
VARIANTS = (
    "truth",
    "camera",
    "camera_tracks_haar",
    "camera_tracks_blazeface",
    "camera_tracks_blazeface_0.4s",
)
FAMILIES = ("paper", "dense_12", "group_approach", "robot_crowding")
RECYCLE_AFTER = 20  # episodes per Ray worker process (≈ 1.5 GB of leaked camera diagrams)


def variant_estimate(variant: str) -> Any:
    """The `EmotionEstimateParams` of a variant (None: the simulator's emotions)."""
    from emonav_drake.perception.noisy_emotions import EmotionEstimateParams

    if variant == "truth":
        return None
    if variant == "camera":
        return EmotionEstimateParams(mode="camera").validate()
    if variant.startswith("camera_tracks_"):
        params = EmotionEstimateParams(mode="camera_tracks")
        detector, _, period = variant.removeprefix("camera_tracks_").partition("_")
        params.camera.face_detector = detector
        if period:  # e.g. camera_tracks_blazeface_0.4s: a classification every 0.4 s
            try:
                params.period = float(period.removesuffix("s"))
            except ValueError:
                raise ValueError(f"variant {variant!r}: a period is written like _0.4s") from None
        try:
            return params.validate()
        except ValueError as e:  # ConfigError: a detector or period out of range
            raise ValueError(f"variant {variant!r}: {e}") from None
    raise ValueError(
        f"variant {variant!r}: one of {VARIANTS}, or camera_tracks_<detector>_<period>s"
    )


def episode(seed: int, family: str, variant: str) -> dict:
    """One traced LIP episode: {family, variant, seed, outcome, steps, negative_zone_steps,
    samples}."""
    from emonav_drake.diagrams.episode import EpisodeRequest
    from emonav_drake.diagrams.plants import plant_named
    from emonav_drake.evaluation.perception_study import half_fov_x_deg
    from emonav_drake.navigation.emotion_timing import CameraView, approach_samples
    from emonav_drake.perception.noisy_emotions import EmotionEstimateParams
    from emonav_drake.planners import make_planner
    from emonav_drake.scenarios.scenario import sample_scenario

    cfg = EmoNavConfig()
    cfg.crowd.family = family
    cfg.perception.state_source = "lidar"
    estimate = variant_estimate(variant)
    seen_by = estimate or EmotionEstimateParams(mode="camera")  # truth: the default camera
    view = CameraView(
        half_fov=math.radians(half_fov_x_deg(seen_by)),
        max_range=seen_by.camera.max_range,
        period=seen_by.period,
    )
    request = EpisodeRequest(
        sample_scenario(seed, cfg),
        cfg,
        make_planner("mpc", cfg),
        emotion_estimate=estimate,
        trace=True,
    )
    record, trace = plant_named("lip").simulate(request)
    samples = approach_samples(
        trace,
        cfg.reward.emotion_distances(),
        cfg.crowd.pedestrian_radius,
        cfg.robot.radius,
        view,
    )
    return {
        "family": family,
        "variant": variant,
        "seed": seed,
        "outcome": record.outcome,
        "steps": record.steps,
        "negative_zone_steps": int(record.idt[3]),
        "samples": samples,
    }


class EmotionTimingWorker(Worker):
    """The Ray actor of `study`: one episode per task."""

    def run(self, seed: int, family: str, variant: str) -> dict:
        return episode(seed, family, variant)


def study(
    seeds: Sequence[int],
    families: Sequence[str] = FAMILIES,
    variants: Sequence[str] = VARIANTS,
    workers: int = 1,
    ray_address: str | None = None,
    on_result: Callable[[dict], None] | None = None,
    done: Sequence[dict] = (),
) -> list[dict]:
    """Every (family, variant, seed) episode; the results sorted by family, variant and
    seed (the order does not depend on the workers). `done`: results of an earlier,
    interrupted run, kept and not run again."""
    for v in variants:
        variant_estimate(v)  # an unknown variant fails before anything runs
    have = {(r["seed"], r["family"], r["variant"]) for r in done}
    tasks = [(s, f, v) for f in families for v in variants for s in seeds if (s, f, v) not in have]
    wanted = {(s, f, v) for f in families for v in variants for s in seeds}
    results: list[dict] = [r for r in done if (r["seed"], r["family"], r["variant"]) in wanted]

    def take(result: dict) -> None:
        results.append(result)
        if on_result is not None:
            on_result(result)

    if tasks and workers == 1 and ray_address is None:
        for task in tasks:
            take(episode(*task))
    elif tasks:
        from emonav_drake.parallel import run_tasks

        # camera diagrams leak (pydrake keeps them alive): a fresh worker every 20 episodes
        run_tasks(
            EmotionTimingWorker,
            tasks,
            take,
            workers,
            ray_address,
            lambda remote: (),
            recycle_after=RECYCLE_AFTER,
        )
    rank = {(f, v): i for i, (f, v) in enumerate((f, v) for f in families for v in variants)}
    return sorted(results, key=lambda r: (rank[(r["family"], r["variant"])], r["seed"]))
