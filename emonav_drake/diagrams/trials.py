"""Trials: one method (planner) on the scenario of one seed, on either plant.

The unit of work of every evaluation on many seeds (`emonav benchmark`, trace collection
for calibration, the Digit DAgger rounds):

* `MethodSpec` / `BenchmarkSpec`: what a worker needs to run any trial of a run — the
  methods (a planner kind and, for learned policies, the checkpoint and its hash), the
  plant ("lip" or "digit"), the configuration as YAML, the emotion estimate.
* `method_specs`: methods by name and NAME=PATH checkpoints → validated methods (its
  errors name its inputs; `cli.common.parse_methods` words them as `--planners` and
  `--checkpoint`).
* `TrialRunner`: runs trials in one process, each method's planner built once and
  reused (a planner's memory lives in the diagram's Context, so reuse changes no command).
* `TrialWorker` / `run_trials`: the same on Ray actors (`parallel.run_tasks`), or serially
  in this process with the same arithmetic (torch on one thread in both).
* `TrialRunner.try_run` / `BenchmarkTrialWorker`: a trial that raises comes back as its
  error line (`trial_error`: type, message, traceback) instead of stopping the run — what
  `emonav benchmark` records beside the run; Ctrl-C (KeyboardInterrupt, `RunInterrupted`)
  still stops it.
"""

from __future__ import annotations

import copy
import tempfile
import time
import traceback
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from emonav_drake.atomic_io import json_safe
from emonav_drake.diagrams.run_spec import BenchmarkSpec, MethodSpec
from emonav_drake.errors import RunInterrupted, did_you_mean
from emonav_drake.parallel import Worker, run_tasks
from emonav_drake.params import ConfigError, EmoNavConfig, load_config
from emonav_drake.planners import is_registered, planner_kind, planner_names
from emonav_drake.planners.legacy import planner_of
from emonav_drake.provenance import sha256_file

if TYPE_CHECKING:
    from emonav_drake.diagrams.episode import EpisodeRequest
    from emonav_drake.navigation.episode_trace import EpisodeTrace
    from emonav_drake.navigation.metrics import EpisodeRecord
    from emonav_drake.scenarios.scenario import Scenario

# --trials at most (per method): every scenario is sampled (~0.2 ms per seed, ~20 s at the
# maximum) and every (method, seed) task listed before the first trial.
MAX_TRIALS = 100_000


class MethodError(ConfigError):
    """A method list `method_specs` refuses. Its message names the inputs as
    `method_specs` calls them (`planners`, `checkpoint`); `worded(names)` is the same
    message with other names for them (the CLI's: `--planners`, `--checkpoint`)."""

    template: str = ""
    values: dict = {}  # set per instance by `_refused`

    def worded(self, names: Mapping[str, str]) -> str:
        """The message with `names["planners"]` and `names["checkpoint"]` for the inputs."""
        return self.template.format(**names, **self.values)


# what `method_specs`' errors call its inputs
INPUT_NAMES = {"planners": "planners", "checkpoint": "checkpoint"}


def _refused(template: str, **values: object) -> MethodError:
    """The `MethodError` of `template` ({planners}, {checkpoint} and `values` filled in)."""
    e = MethodError(template.format(**INPUT_NAMES, **values))
    e.template, e.values = template, values
    return e


def method_specs(
    planners: str | Sequence[str], checkpoints: Sequence[str] = ()
) -> list[MethodSpec]:
    """Methods by name (a comma-separated string or a list) and "NAME=PATH" checkpoints →
    the validated methods; `MethodError` (a `ConfigError`) naming the input otherwise
    (`cli.common.parse_methods` words it as the flags `--planners`, `--checkpoint`).

    A method is any registered planner (`planners.planner_names()`): a model planner
    (`dwa`, `mpc`, …), a learned one with its default checkpoint unless one is given
    (`policy`: the shipped policy; a variant: its shipped policy; `sac`: a SAC-trained
    checkpoint must be given, sac=PATH), or any other name given a checkpoint NAME=PATH
    (another learned policy).
    """
    names = planners.split(",") if isinstance(planners, str) else list(planners)
    names = [n.strip() for n in names]
    listed = ",".join(names)
    if not names or any(not n for n in names):
        raise _refused(
            "{planners} {listed!r}: give a comma-separated list of methods", listed=listed
        )
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise _refused("{planners}: {name} is listed twice", name=dup[0])
    ckpt = _checkpoints(checkpoints, names)
    methods = []
    for n in names:
        kind = planner_kind(n) if is_registered(n) else None
        if kind is not None and not kind.learned:
            methods.append(MethodSpec(n, n))
        elif kind is not None or n in ckpt:
            path = ckpt.get(n)
            spec = kind.spec if kind is not None else None
            if path is None:
                if kind is None or kind.default_checkpoint is None:
                    hint = getattr(spec, "checkpoint_hint", "")
                    raise _refused(
                        "{planners} {n}: " + (hint or "give its checkpoint, {checkpoint} {n}=PATH"),
                        n=n,
                    )
                path = kind.default_checkpoint()
            if hasattr(spec, "checkpoint_problem"):
                _check_checkpoint(spec, n, path)
            runs_as = kind.runs_as if kind is not None else "policy"
            methods.append(MethodSpec(n, runs_as, str(path), sha256_file(path)))
        else:
            names = planner_names()
            raise _refused(
                "{planners}: unknown method {n!r}{hint}; the planners: {names}; or a "
                "policy of your own: {checkpoint} {n}=PATH",
                n=n,
                hint=did_you_mean(n, names),
                names=" ".join(names),
            )
    return methods


def _checkpoints(checkpoints: Sequence[str], names: list[str]) -> dict[str, Path]:
    """The "NAME=PATH" checkpoints of `method_specs` by method name, checked."""
    ckpt: dict[str, Path] = {}
    for item in checkpoints:
        name, sep, path = item.partition("=")
        name = name.strip()
        if not sep or not name or not path:
            raise _refused(
                "{checkpoint} {item!r}: expected NAME=PATH (e.g. policy=runs/x/policy.pt)",
                item=item,
            )
        if name in ckpt:
            raise _refused("{checkpoint} {name}: given twice", name=name)
        if name not in names:
            raise _refused(
                "{checkpoint} {name}=…: {name} is not among {planners} ({listed})",
                name=name,
                listed=",".join(names),
            )
        if is_registered(name) and not planner_kind(name).learned:
            raise _refused(
                "{checkpoint} {name}=…: only learned policies take a checkpoint", name=name
            )
        p = Path(path)
        if not p.is_file():
            raise _refused("{checkpoint} {name}={path}: no such file", name=name, path=path)
        ckpt[name] = p
    return ckpt


def _check_checkpoint(spec: object, n: str, path: str | Path) -> None:
    """A checkpoint its spec cannot run (`checkpoint_problem`, e.g. a DAgger student given
    as `sac`) is refused here, before any trial."""
    from emonav_drake.planners.policy import load_policy

    _, meta = load_policy(Path(path), "cpu")
    problem = spec.checkpoint_problem(meta)
    if problem:
        raise _refused("{checkpoint} {n}={path}: " + problem, n=n, path=path)


class TrialRunner:
    """Runs trials in one process; each method's planner is built once and reused.

    Args:
        spec: the benchmark (methods, plant, configuration YAML, emotion estimate).
        blobs: checkpoint bytes by method name, used where the checkpoint's path does not
            exist here (a worker on another machine) or holds another file.
        device: the torch device of the learned planners ("cpu", "cuda", "cuda:N").
    """

    def __init__(
        self, spec: BenchmarkSpec, blobs: dict[str, bytes] | None = None, device: str = "cpu"
    ) -> None:
        from emonav_drake.planners.plugins import import_planner_modules

        self.spec = spec
        import_planner_modules(spec.planner_modules)  # a user's planners, in this worker too
        self.config = load_config(data=spec.config_yaml)
        self.estimate = None
        if spec.emotion_estimate_yaml is not None:
            from emonav_drake.perception.noisy_emotions import EmotionEstimateParams
            from emonav_drake.typed_yaml import load_typed_yaml

            self.estimate = load_typed_yaml(
                EmotionEstimateParams, data=spec.emotion_estimate_yaml
            ).validate()
        self._blobs = blobs or {}
        self.device = device
        self._tmp: tempfile.TemporaryDirectory | None = None
        self._planners: dict[str, tuple[Any, EmoNavConfig, str]] = {}

    def _checkpoint_path(self, m: MethodSpec) -> str | None:
        if m.checkpoint is None:
            return None
        p = Path(m.checkpoint)
        if p.is_file() and (m.checkpoint_sha256 is None or sha256_file(p) == m.checkpoint_sha256):
            return str(p)
        if m.name not in self._blobs:
            raise ConfigError(f"checkpoint of {m.name}: {p} is missing or differs on this worker")
        if self._tmp is None:
            self._tmp = tempfile.TemporaryDirectory(prefix="emonav-bench-")
        q = Path(self._tmp.name) / f"{m.name}-{p.name}"
        q.write_bytes(self._blobs[m.name])
        return str(q)

    def planner(self, name: str) -> tuple[Any, EmoNavConfig, str]:
        """(planner, its configuration, grid kind) of a method, built on first use."""
        if name not in self._planners:
            from emonav_drake.planners import configure_for, make_planner

            m = self.spec.method(name)
            cfg = copy.deepcopy(self.config)  # a policy adapts the grid-map settings
            kind = planner_of(m.planner)
            planner = make_planner(
                kind, cfg, checkpoint=self._checkpoint_path(m), device=self.device
            )
            cfg, grid_kind = configure_for(planner, cfg)
            self._planners[name] = (planner, cfg, grid_kind)
        return self._planners[name]

    def observation(self, name: str) -> str:
        """What the method observes: "state" (privileged crowd state) or its grid kind."""
        planner, _, kind = self.planner(name)
        return kind.upper() if hasattr(planner, "expected_shape") else "state"

    def request(self, method: str, seed: int, trace: bool = False) -> EpisodeRequest:
        """The `EpisodeRequest` of one trial: method `method` (its planner, configuration
        and observation) on the scenario of `seed`, with the run's emotion estimate, at
        the evaluation goal radius; `trace`: keep the per-step trace."""
        from emonav_drake.diagrams.episode import EpisodeRequest
        from emonav_drake.scenarios.scenario import sample_scenario

        planner, cfg, grid_kind = self.planner(method)
        scenario = sample_scenario(seed, self.config)
        return EpisodeRequest(
            scenario, cfg, planner, grid_kind, emotion_estimate=self.estimate, trace=trace
        )

    def replay(self, method: str, seed: int) -> tuple[Scenario, EpisodeRecord, EpisodeTrace | None]:
        """Re-simulate one trial on the run's plant with its per-step trace: (scenario,
        `EpisodeRecord`, `EpisodeTrace`; None from a plant that keeps no trace) — for
        plots, diagnoses."""
        from emonav_drake.diagrams.plants import plant_named

        request = self.request(method, seed, trace=True)
        record, trace = plant_named(self.spec.plant, "plant =").simulate(request)
        return request.scenario, record, trace

    def run(self, method: str, seed: int) -> dict:
        """One trial: method `method` on the scenario of `seed`; the `trials.jsonl` line."""
        from emonav_drake.diagrams.evaluation_episode import run_evaluation_episode

        request = self.request(method, seed)
        t0 = time.perf_counter()
        record = run_evaluation_episode(self.spec.plant, request)
        wall = time.perf_counter() - t0
        rec = record.to_json()
        rec["seed"] = seed
        return {
            "method": method,
            "seed": seed,
            "plant": self.spec.plant,
            "record": json_safe(rec),
            "wall_seconds": round(wall, 4),
        }

    def try_run(self, method: str, seed: int) -> dict:
        """`run`, or if the trial raised an `Exception`, its error line (`trial_error`).
        KeyboardInterrupt and `RunInterrupted` are not caught: they stop the run."""
        t0 = time.perf_counter()
        try:
            return self.run(method, seed)
        except RunInterrupted:
            raise
        except Exception as e:  # noqa: BLE001 — any error of one trial is that trial's
            return trial_error(method, seed, self.spec.plant, e, time.perf_counter() - t0)


def trial_error(method: str, seed: int, plant: str, error: BaseException, wall: float) -> dict:
    """The line of a trial that raised `error` after `wall` seconds: method, seed, plant,
    ``error`` = {type (the class's name), message, traceback (as Python prints it)}."""
    return {
        "method": method,
        "seed": seed,
        "plant": plant,
        "error": {
            "type": type(error).__qualname__,
            "message": str(error),
            "traceback": "".join(traceback.format_exception(error)),
        },
        "wall_seconds": round(wall, 4),
    }


class TrialWorker(Worker):
    """The Ray actor: one `TrialRunner` per worker process (planners built once). Other
    per-episode jobs on Digit subclass it and override `run` (`learning/calibration.py`,
    `learning/digit_dagger.py`)."""

    def __init__(self, spec: BenchmarkSpec, blobs: dict[str, bytes]) -> None:
        super().__init__()
        self.runner = TrialRunner(spec, blobs)

    def run(self, method: str, seed: int) -> dict:
        return self.runner.run(method, seed)


class BenchmarkTrialWorker(TrialWorker):
    """The benchmark's Ray actor: a trial that raises comes back as its error line
    (`TrialRunner.try_run`), so the other trials go on."""

    def run(self, method: str, seed: int) -> dict:
        return self.runner.try_run(method, seed)


def run_serial(
    spec: BenchmarkSpec,
    tasks: Sequence[tuple[str, int]],
    on_result: Callable[[dict], None],
    episode: Callable[[TrialRunner, str, int], dict] | None = None,
) -> None:
    """Every (method, seed) task in this process, in order, with a Ray worker's arithmetic:
    `episode(runner, method, seed)` (default `runner.run`, as `TrialWorker.run`; a worker
    class of `run_trials` that runs something else passes the same function here)."""
    import torch

    threads = torch.get_num_threads()
    torch.set_num_threads(1)  # as in a Ray worker: identical arithmetic, no oversubscription
    try:
        runner = TrialRunner(spec)
        for method, seed in tasks:
            if episode is None:
                on_result(runner.run(method, seed))
            else:
                on_result(episode(runner, method, seed))
    finally:
        torch.set_num_threads(threads)


def run_trials(
    spec: BenchmarkSpec,
    tasks: Sequence[tuple[str, int]],
    on_result: Callable[[dict], None],
    workers: int | None,
    address: str | None,
    worker_cls: type | None = None,
) -> None:
    """Run `worker.run(method, seed)` for every task on Ray actors (`parallel.run_tasks`),
    `on_result` in the order they finish. `worker_cls(spec, blobs)` (default: the trial
    worker) is a `TrialWorker`; the checkpoints of learned methods reach workers on other
    machines as bytes (local workers read them from their paths, hashes checked)."""

    def args(remote: bool) -> tuple[BenchmarkSpec, dict[str, bytes]]:
        if not remote:
            return spec, {}
        blobs = {m.name: Path(m.checkpoint).read_bytes() for m in spec.methods if m.checkpoint}
        return spec, blobs

    run_tasks(
        worker_cls or TrialWorker,
        tasks,
        on_result,
        workers,
        address,
        args,
        recycle_after=CAMERA_RECYCLE_AFTER if renders_faces(spec) else None,
    )


# trials per worker process when the head camera renders faces: pydrake keeps every diagram
# with Python systems alive (Drake issue #22515), and a camera diagram holds 27-75 MB
CAMERA_RECYCLE_AFTER = 20


def renders_faces(spec: BenchmarkSpec) -> bool:
    """Whether the benchmark's emotions come from the head camera (a camera mode)."""
    if spec.emotion_estimate_yaml is None:
        return False
    from emonav_drake.perception.noisy_emotions import CAMERA_MODES, EmotionEstimateParams
    from emonav_drake.typed_yaml import load_typed_yaml

    mode = load_typed_yaml(EmotionEstimateParams, data=spec.emotion_estimate_yaml).mode
    return mode in CAMERA_MODES
