"""`emonav eval`: a planner over many seeds (SR, NT, DT, IDT); Ctrl-C keeps finished episodes.

emonav eval --planner dwa --plant lip --episodes 100 --first-seed 0
            [--config F.yaml | --setting NAME] [--json out.json]
"""

from __future__ import annotations

import argparse
from pathlib import Path

from emonav_drake.atomic_io import write_json
from emonav_drake.cli.common import (
    PLANNER_HELP,
    PLANT_HELP,
    SeedArg,
    add_episode_flags,
    check_outputs,
    check_planner_flags,
    check_seed_range,
    run_spec_from_args,
)
from emonav_drake.cli.planners_cmd import DEFAULT_PLANNER
from emonav_drake.cli.resolve import (
    add_spec,
    check_spec_flags,
    resolve_config,
)
from emonav_drake.diagrams.plants import PLANTS
from emonav_drake.diagrams.run_spec import RunSpec, load_run_spec, run_spec_plain
from emonav_drake.errors import RunInterrupted
from emonav_drake.params import ConfigError, EmoNavConfig
from emonav_drake.planners import planner_names
from emonav_drake.scenarios.scenario import Scenario

# `eval --episodes` at most: every scenario is sampled before the first episode (a crowd
# that does not fit fails at once), ~0.2 ms per seed, ~20 s at the maximum; 100 000 DWA
# episodes already take ~8 h on one core.
MAX_EPISODES = 100_000


def add_parser(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Register `emonav eval` on the CLI's sub-parsers."""
    e = subparsers.add_parser("eval", help="evaluate a planner over many seeds (SR, NT, DT, IDT)")
    e.add_argument(
        "--planner",
        default=DEFAULT_PLANNER,
        choices=planner_names(),
        metavar="NAME",
        help=PLANNER_HELP,
    )
    e.add_argument("--plant", default="lip", choices=list(PLANTS), help=PLANT_HELP)
    e.add_argument(
        "--episodes",
        type=int,
        default=100,
        help=f"in [1, {MAX_EPISODES}]: every scenario is sampled before the first episode "
        "(a crowd that does not fit fails at once; ~0.2 ms per seed); split longer "
        "evaluations with --first-seed",
    )
    e.add_argument(
        "--first-seed", action=SeedArg, default=0, help="episode i runs seed first-seed + i (>= 0)"
    )
    e.add_argument(
        "--json",
        type=Path,
        help="write summary and episodes as JSON (after Ctrl-C: the finished ones, "
        "with interrupted: true and seeds_done)",
    )
    add_episode_flags(e)
    add_spec(e, "the --json of an earlier `emonav eval`")
    e.set_defaults(func=cmd_eval)
    return e


def cmd_eval(args: argparse.Namespace) -> int:
    """Evaluate over seeds; on Ctrl-C keep the finished episodes (summary, --json, exit 130)."""
    check_outputs(args, "--json")
    spec = _eval_spec(args)
    from emonav_drake.diagrams.episode import EpisodeRequest
    from emonav_drake.diagrams.evaluation_episode import run_evaluation_episode
    from emonav_drake.diagrams.trials import TrialRunner
    from emonav_drake.navigation.metrics import format_summary, summarize
    from emonav_drake.progress import progress_bar

    seeds = range(spec.first_seed, spec.first_seed + spec.episodes)
    # Every scenario first (cheap): a crowd that does not fit fails now, not at episode k;
    # none is kept (each is drawn again for its episode), so memory does not grow with N.
    for seed in seeds:
        _scene(spec, seed, args)
    name = spec.methods[0].name
    runner = TrialRunner(spec.benchmark_spec(), device=args.device)
    planner, cfg, grid_kind = runner.planner(name)
    spec.methods[0].observation = runner.observation(name)  # as a benchmark records it
    if hasattr(planner, "describe"):
        print(f"planner {name}: {planner.describe()}")
    setting = spec.setting_name or "default"
    sensed = _sensed(cfg, setting, spec.emotion_estimate)
    print(f"sensed: {sensed['setting_label']}; emotions: {sensed['emotion_source']}")
    estimate = spec.emotion_estimate
    records = []
    interrupted = False
    with progress_bar(total=len(seeds), desc=f"{name}/{spec.plant}", unit="ep") as bar:
        try:
            for seed in seeds:
                scenario = _scene(spec, seed, args)
                request = EpisodeRequest(
                    scenario, cfg, planner, grid_kind, emotion_estimate=estimate
                )
                rec = run_evaluation_episode(spec.plant, request)
                records.append(rec)
                bar.update(1)
        except KeyboardInterrupt:
            interrupted = True
    if not records:
        raise RunInterrupted("interrupted before the first episode finished; nothing written")
    summary = summarize(records)
    done = list(seeds[: len(records)])
    print(format_summary(summary))
    if args.json:
        out = {
            "planner": name,
            "plant": spec.plant,
            "seeds": [seeds.start, seeds.stop],
            "interrupted": interrupted,
            "seeds_done": done,
            **sensed,
            "summary": summary,
            "episodes": [r.to_json() for r in records],
            "spec": run_spec_plain(spec),  # `emonav eval --spec` runs it again
        }
        write_json(args.json, out)
    if interrupted:
        where = f"; written to {args.json} (interrupted: true)" if args.json else ""
        raise RunInterrupted(
            f"interrupted after {len(records)} of {len(seeds)} episodes (seeds "
            f"{done[0]}-{done[-1]}); the summary above covers them{where}"
        )
    return 0


def _eval_spec(args: argparse.Namespace) -> RunSpec:
    """The run spec of `--spec FILE` (one method), else of the flags (checked first:
    --episodes, the seed range, the planner's flags)."""
    if args.spec is not None:
        check_spec_flags(args)
        spec = load_run_spec(args.spec)
        if len(spec.methods) != 1:
            raise ConfigError(
                f"--spec {args.spec}: records {len(spec.methods)} methods; eval runs one "
                "(benchmark --spec runs them all)"
            )
        return spec
    if not 1 <= args.episodes <= MAX_EPISODES:
        raise ConfigError(
            f"--episodes {args.episodes}: must be in [1, {MAX_EPISODES}] (split a longer "
            "evaluation with --first-seed)"
        )
    check_seed_range(args.first_seed, args.episodes, "--first-seed")
    check_planner_flags(args)
    resolved = resolve_config(args)
    return run_spec_from_args(args, resolved, episodes=args.episodes, first_seed=args.first_seed)


def _scene(spec: RunSpec, seed: int, args: argparse.Namespace) -> Scenario:
    """The scene of `seed`, a sampling error naming where the configuration came from."""
    from emonav_drake.scenarios.scenario import ScenarioSamplingError

    try:
        return spec.scenario_of(seed)
    except ScenarioSamplingError as e:
        where = f"--spec {args.spec}" if args.spec else resolve_config(args).origin
        raise ScenarioSamplingError(f"{where}: {e}") from None


def _sensed(cfg: EmoNavConfig, setting: str | None, estimate: object | None) -> dict:
    """What the robot sensed to get the numbers: the setting's label (state source,
    sensor, deployable), the sensor preset and the emotions' source."""
    from emonav_drake.evaluation.run_settings import setting_label
    from emonav_drake.params import is_deployable

    return {
        "setting_label": setting_label(cfg, setting),
        "state_source": cfg.perception.state_source,
        "sensor": cfg.sensor.preset,
        "deployable": is_deployable(cfg),
        "emotion_source": "ground truth" if estimate is None else str(estimate.mode),
    }
