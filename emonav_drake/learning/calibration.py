"""Calibrating the reduced robot to Digit: traces of Digit episodes → step-response model.

    emonav calibrate collect --planners dwa,policy --episodes 20 --first-seed 3000000 \\
        --explore 0.3 --workers 2 --out runs/calib/traces.jsonl
    emonav calibrate fit runs/calib/traces.jsonl --held-out 0.25 --out runs/calib/response.json

`collect` runs Digit navigation episodes (the full diagram: Digit station, crowd, grid
maps, planner) on training seeds, each planner's command replaced by a uniformly random
one on a fraction `explore` of the steps (seeded) so that the fit sees every command,
and appends one JSON line per episode: the planner, seed, outcome, wall time and the trace
of the episode (`navigation.episode_trace.EpisodeTrace.rows`: robot state and held command at
every planner instant).
Episodes run one per Ray task (`--workers`), each worker simulating its own diagrams; the
file is resumable (episodes already in it are not run again) and its lines are sorted
by (planner, seed) whatever the order they finished in, so a parallel run writes the same
file as a serial one. `fit` splits the episodes (the last fraction `held_out`, by seed
order, is held out), fits `robot.step_response`, and writes the model with its report:
the residual σ on the fitting data and the RMS errors on the held-out episodes of the
model and of the LIP driven by u_k, u_{k−1}, u_{k−2}.

The shipped model is `emonav_drake/data/digit_response.json` (`response: digit` in a
`DaggerConfig`).
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from emonav_drake.json_input import JsonInputError, parse_json
from emonav_drake.params import ConfigError, EmoNavConfig

if TYPE_CHECKING:
    from emonav_drake.diagrams.trials import MethodSpec


# ------------------------------------------------------------------------ collection
class ExploringPlanner:
    """A planner whose command is replaced, on a fraction of the steps, by a uniformly
    random one (seeded per episode; the base planner still plans every step, so its
    memory follows the episode). Pure, as the diagram wants: the draw of step k is a
    function of (seed, k)."""

    name = "exploring"

    def __init__(self, base, explore: float, seed: int, config) -> None:
        self.base, self.explore, self.seed = base, explore, seed
        self.bounds = (config.robot.max_speed, config.robot.max_heading_change)
        for attr in ("grid_kind", "expected_shape", "expected_dtype"):
            if hasattr(base, attr):
                setattr(self, attr, getattr(base, attr))

    def initial_memory(self):
        return self.base.initial_memory()

    def plan_with_memory(self, obs, memory):
        import numpy as np

        command, memory = self.base.plan_with_memory(obs, memory)
        rng = np.random.default_rng([EXPLORE_SALT, self.seed, obs.step])
        if rng.random() < self.explore:
            v, turn = self.bounds
            command = np.array([rng.uniform(0.0, v), rng.uniform(-turn, turn)])
        return command, memory


EXPLORE_SALT = 0xCA1


def _trace_episode(runner, method: str, seed: int, explore: float) -> dict:
    """One traced Digit episode of `method` on the scenario of `seed` (a JSON line)."""
    import time

    from emonav_drake.diagrams.navigation_digit import run_digit_episode
    from emonav_drake.scenarios.scenario import sample_scenario

    planner, cfg, grid_kind = runner.planner(method)
    t0 = time.perf_counter()
    record, trace = run_digit_episode(
        sample_scenario(seed, runner.config),
        cfg,
        ExploringPlanner(planner, explore, seed, cfg),
        grid_kind=grid_kind,
        goal_radius=cfg.episode.eval_goal_radius,
        trace=True,
    )
    wall = time.perf_counter() - t0
    return {
        "method": method,
        "seed": seed,
        "explore": explore,
        "outcome": record.outcome,
        "steps": trace.steps,
        "wall_seconds": round(wall, 3),
        "trace": trace.rows(),  # the file's format: `EpisodeTrace.rows`
    }


def _trace_worker(explore: float) -> type:
    """The Ray actor class of `collect_traces`: one traced episode per task."""
    from emonav_drake.diagrams.trials import TrialWorker

    class TraceWorker(TrialWorker):
        def run(self, method: str, seed: int) -> dict:
            return _trace_episode(self.runner, method, seed, explore)

    return TraceWorker


def collect_traces(
    out: str | Path,
    planners: str | Sequence[MethodSpec],
    episodes: int,
    first_seed: int,
    explore: float = 0.3,
    workers: int = 1,
    ray_address: str | None = None,
    progress: bool = True,
    config: EmoNavConfig | None = None,
) -> dict:
    """Traced, exploring Digit episodes into the JSONL file `out` (module docstring) of
    `planners` (methods by name, comma-separated, or validated `MethodSpec`s:
    `diagrams.trials.method_specs`); `config` (default: the defaults) is the navigation
    configuration of the episodes.

    Returns {"episodes", "steps", "wall_seconds", "steps_per_second_per_worker"} of the
    episodes run now (the throughput of the Digit simulation, per worker).
    """
    from emonav_drake.atomic_io import write_text_atomic
    from emonav_drake.diagrams.trials import (
        MAX_TRIALS,
        BenchmarkSpec,
        TrialRunner,
        method_specs,
        run_trials,
    )
    from emonav_drake.params import dump_config
    from emonav_drake.progress import progress_bar
    from emonav_drake.scenarios.scenario import MAX_SEED

    if not 0.0 <= explore <= 1.0:
        raise ConfigError(f"--explore {explore}: must be in [0, 1]")
    if not 1 <= episodes <= MAX_TRIALS:
        raise ConfigError(f"--episodes {episodes}: must be in [1, {MAX_TRIALS}] (per planner)")
    if not 0 <= first_seed <= MAX_SEED - episodes + 1:
        raise ConfigError(
            f"--first-seed {first_seed}: the seeds {first_seed} … {first_seed + episodes - 1} "
            "must be in [0, 2**64 - 1]"
        )
    out = Path(out)
    methods = method_specs(planners) if isinstance(planners, str) else list(planners)
    spec = BenchmarkSpec(methods, "digit", dump_config(config or EmoNavConfig()))
    have = read_trace_lines(out) if out.is_file() else []
    if any(h.get("explore") != explore for h in have):
        raise ConfigError(f"{out} holds episodes of another --explore; use another --out")
    done = {(h["method"], h["seed"]) for h in have}
    seeds = range(first_seed, first_seed + episodes)
    tasks = [(m.name, s) for s in seeds for m in methods if (m.name, s) not in done]
    new: list[dict] = []
    bar = progress_bar(total=len(tasks), desc="Digit episodes", unit="ep", enabled=progress)

    def keep(line: dict) -> None:  # appended as it finishes; sorted once at the end
        new.append(line)
        bar.update(1)
        with out.open("a") as f:
            f.write(json.dumps(line) + "\n")

    import time

    t0 = time.perf_counter()
    if workers <= 1 and ray_address is None:
        runner = TrialRunner(spec)
        for method, seed in tasks:
            keep(_trace_episode(runner, method, seed, explore))
    elif tasks:
        run_trials(spec, tasks, keep, workers, ray_address, worker_cls=_trace_worker(explore))
    bar.close()
    lines = sorted(have + new, key=lambda h: (h["method"], h["seed"]))
    write_text_atomic(out, "".join(json.dumps(h) + "\n" for h in lines))
    wall = time.perf_counter() - t0
    steps = sum(h["steps"] for h in new)
    sim = sum(h["wall_seconds"] for h in new)
    return {
        "episodes": len(new),
        "steps": steps,
        "wall_seconds": round(wall, 1),
        "steps_per_second_per_worker": round(steps / sim, 3) if sim else None,
    }


# ------------------------------------------------------------------------------- fit
TRACE_KEYS = {"method": str, "seed": int, "trace": list}  # what every trace line has


def read_trace_lines(path: str | Path) -> list[dict]:
    """The episodes of a trace file, one JSON object per line, each with `TRACE_KEYS`;
    `ConfigError` naming the file and line of anything else (a torn or edited line)."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except UnicodeDecodeError as e:
        raise ConfigError(f"{path}: not a trace file (not UTF-8 text: {e})") from None
    lines = []
    for i, line in enumerate(text.splitlines(), 1):
        try:
            h = parse_json(line, f"{path}:{i}", "not a JSON trace line")
        except JsonInputError as e:
            raise ConfigError(f"{e}; damaged file?") from None
        if not isinstance(h, dict):
            raise ConfigError(f"{path}:{i}: not a trace line (a JSON {type(h).__name__})")
        for key, kind in TRACE_KEYS.items():
            if key not in h:
                raise ConfigError(f"{path}:{i}: the trace line has no {key!r}")
            if not isinstance(h[key], kind) or isinstance(h[key], bool):
                raise ConfigError(f"{path}:{i}: the trace line's {key!r} is not a {kind.__name__}")
        lines.append(h)
    return lines


def read_traces(paths: list[str | Path], step_time: float):
    """All episodes of trace files as `Transitions` (episode ids in file order);
    `ConfigError` naming the file and line of a malformed episode."""
    from emonav_drake.robot.step_response import Transitions, transitions_from_trace

    parts, names = [], []
    for path in paths:
        for i, h in enumerate(read_trace_lines(path), 1):
            try:
                parts.append(transitions_from_trace(h["trace"], step_time, episode=len(parts)))
            except (KeyError, TypeError, ValueError, IndexError) as e:
                raise ConfigError(f"{path}:{i}: the trace is malformed ({e!r})") from None
            names.append((h["method"], h["seed"]))
    if not parts:
        raise ConfigError("no episodes in the trace files")
    return Transitions.concatenate(parts), names


def fit_response(
    paths: list[str | Path], held_out: float = 0.25, out: str | Path | None = None
) -> dict:
    """Fit the step-response model on the trace files; hold out the last `held_out`
    fraction of each method's episodes (by seed). Returns (and writes to `out`) the model
    with its report."""
    import numpy as np

    from emonav_drake.atomic_io import write_json
    from emonav_drake.robot.step_response import (
        OUTPUTS,
        UNITS,
        evaluate,
        fit_step_response,
        lip_errors,
        rms,
        split_by_episode,
    )

    if not 0.0 < held_out < 1.0:
        raise ConfigError(f"--held-out {held_out}: must be in (0, 1)")
    r = EmoNavConfig().robot
    data, names = read_traces(paths, r.step_time)
    test_ids = []
    for method in sorted({m for m, _ in names}):
        ids = [i for i, (m, _) in enumerate(names) if m == method]
        ids.sort(key=lambda i: names[i][1])
        k = max(1, round(held_out * len(ids)))
        test_ids += ids[-k:]
    fit, test = split_by_episode(data, test_ids)
    source = ", ".join(sorted({f"{m}" for m, _ in names})) + f"; {len(names)} Digit episodes"
    model = fit_step_response(fit, source=source)

    def table(err: np.ndarray) -> dict:
        return {f"{o} [{u}]": float(v) for o, u, v in zip(OUTPUTS, UNITS, rms(err), strict=True)}

    report = {
        "model": model.to_plain(),
        "fit": {"episodes": len(names) - len(test_ids), "transitions": len(fit)},
        "held_out": {
            "episodes": len(test_ids),
            "transitions": len(test),
            "seeds": sorted(names[i][1] for i in test_ids),
            "rms_model": table(evaluate(model, test)),
            "rms_lip": table(lip_errors(test, r.omega, r.step_time, 0)),
            "rms_lip_delay1": table(lip_errors(test, r.omega, r.step_time, 1)),
            "rms_lip_delay2": table(lip_errors(test, r.omega, r.step_time, 2)),
        },
        "residual_std": {
            f"{o} [{u}]": float(v)
            for o, u, v in zip(OUTPUTS, UNITS, model.residual_std, strict=True)
        },
    }
    if out is not None:
        write_json(out, report)
    return report
