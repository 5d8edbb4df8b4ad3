"""`emonav benchmark`: methods × seeded trials, resumable, on Ray (paper Tables II-III).

`DESCRIPTION` is its `--help` text (it also names `emonav config`, in config.py).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

from emonav_drake.cli.common import (
    PLANT_HELP,
    SeedArg,
    add_emotion_flags,
    check_workers,
    parse_methods,
    run_spec_from_args,
)
from emonav_drake.cli.resolve import (
    add_config_choice,
    add_deployable,
    add_family,
    add_global_route,
    add_sensor,
    add_spec,
    add_state_source,
    check_spec_flags,
    resolve_config,
)
from emonav_drake.diagrams.plants import PLANTS
from emonav_drake.diagrams.trials import MAX_TRIALS
from emonav_drake.navigation.metrics import format_idt

if TYPE_CHECKING:
    from emonav_drake.diagrams.run_spec import RunSpec
    from emonav_drake.evaluation.benchmark import BenchmarkResult

DESCRIPTION = """\
Compare planners on the same seeded trials (the paper's Tables II and III).

  emonav benchmark --planners policy,mpc,dwa --plant lip --trials 500 --out runs/t2

Every planner runs trial i on seed first-seed + i, in parallel on Ray (a local Ray by
default, a cluster with --ray-address). The run directory keeps settings.json,
trials.jsonl (one line per finished trial) and the tables (tables.md, CSV files): the
same command again continues an interrupted run, a larger --trials extends it, and
other settings are refused. Success rates come with their 95 % intervals. A trial that
raises an error (a planner of your own that raises, returns no command or hangs) goes to
errors.jsonl with its traceback, in no table; the others go on, the run ends with exit
code 1 naming the failed trials and the `emonav sim` command that replays one, and the
same command again runs them again.
"""

TIME_VARYING_HELP = "one pedestrian's emotion changes every 2 s (paper §IV-F)"


def add_parser(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Register `emonav benchmark` on the CLI's sub-parsers."""
    b = subparsers.add_parser(
        "benchmark",
        help="compare methods on the same seeded trials (paper Tables II-III); resumable, Ray",
        description=DESCRIPTION,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    b.add_argument(
        "--planners",
        default="policy,mpc,dwa",
        help="comma-separated planner names (`emonav planners` lists them), or any name "
        "given a --checkpoint NAME=FILE",
    )
    b.add_argument("--plant", default="lip", choices=list(PLANTS), help=PLANT_HELP)
    b.add_argument(
        "--trials",
        type=int,
        default=500,
        help=f"trials per method, in [1, {MAX_TRIALS}]: every scenario is sampled and every "
        "task listed before the first trial (a crowd that does not fit fails at once; ~0.2 ms "
        "per seed)",
    )
    b.add_argument(
        "--first-seed",
        action=SeedArg,
        default=0,
        help="trial i runs seed first-seed + i (>= 0)",
    )
    b.add_argument(
        "--workers",
        type=int,
        help="parallel workers (default: the CPU count, or the cluster's CPUs with "
        "--ray-address); 1 runs serially in this process without Ray",
    )
    b.add_argument(
        "--ray-address",
        help="run on this Ray cluster: HOST:PORT (the GCS port of `ray start --head`, 6379 by "
        "default) or auto (the cluster started on this machine); checked before the run "
        "starts (nothing is written if no cluster answers)",
    )
    add_config_choice(b)
    b.add_argument("--time-varying", action="store_true", help=TIME_VARYING_HELP)
    add_emotion_flags(b)
    add_deployable(b)
    add_state_source(b)
    add_family(b)
    add_global_route(b)
    add_sensor(b)
    b.add_argument(
        "--checkpoint",
        action="append",
        metavar="NAME=PATH",
        help="policy checkpoint of a learned method (repeatable); policy defaults to the "
        "shipped policy, a variant to its shipped policy",
    )
    b.add_argument("--out", type=Path, required=True, help="run directory (created if missing)")
    add_spec(b, "a run's settings.json")
    b.set_defaults(func=cmd_benchmark)
    return b


def estimate_yaml(params: Any) -> str | None:
    """An emotion estimate (`EmotionEstimateParams`, None: the ground truth) as the
    canonical YAML a run records (None for the ground truth)."""
    if params is None:
        return None
    from emonav_drake.perception.noisy_emotions import CAMERA_MODES
    from emonav_drake.typed_yaml import dump_typed_yaml

    text = dump_typed_yaml(params)
    # as written before these fields existed, so old runs resume: the camera's section
    # only with a camera, the tracks' decay only with camera_tracks
    if params.mode not in CAMERA_MODES:
        text = text[: text.index("camera:\n")]
    elif params.mode == "camera":
        text = text[: text.index("track_decay:")]
    if params.mode in CAMERA_MODES and params.camera.face_detector == "haar":
        text = text.replace("  face_detector: haar\n", "")
    return text


def cmd_benchmark(args: argparse.Namespace) -> int:
    """Run or continue a benchmark; print the summary and where the tables are. Trials
    that raised (`TrialsFailed`): the summary of the others, then one line `emonav:
    error: …` naming them, exit code 1."""
    from emonav_drake.atomic_io import check_output_dir
    from emonav_drake.evaluation.benchmark import TrialsFailed, run_benchmark

    # every flag checked before the first trial (planners are built in run_benchmark)
    check_output_dir(args.out, "--out")
    if args.workers is not None:
        check_workers(args.workers, args.ray_address)
    spec, setting, config_source = _benchmark_spec(args)
    workers = args.workers
    if workers is None and not args.ray_address:
        import os

        workers = os.cpu_count() or 1
    try:
        result = run_benchmark(
            args.out,
            spec.methods,
            spec.plant,
            spec.episodes,
            spec.first_seed,
            spec.config,
            workers=workers,
            ray_address=args.ray_address,
            setting=setting,
            config_source=config_source,
            emotion_estimate_yaml=estimate_yaml(spec.emotion_estimate),
            progress=True,  # drawn only where `emonav` allows bars (cli.main)
            planner_modules=spec.planner_modules,
        )
    except TrialsFailed as e:  # the others ran: their summary, then the error line
        _print_summary(e.result)
        print(f"emonav: error: {e}", file=sys.stderr)
        return 1
    _print_summary(result)
    return 0


def _benchmark_spec(args: argparse.Namespace) -> tuple[RunSpec, str | None, str]:
    """The run spec of `--spec FILE` (a `settings.json` or a spec), else of the flags;
    with the `--setting` name and where the configuration came from, as the run records
    them."""
    if args.spec is not None:
        from emonav_drake.evaluation.run_settings import read_run_spec

        check_spec_flags(args)
        spec = read_run_spec(args.spec)
        return spec, spec.setting_name or None, f"--spec {args.spec}"
    methods = parse_methods(args.planners, args.checkpoint or [])
    resolved = resolve_config(args)
    spec = run_spec_from_args(
        args, resolved, methods, episodes=args.trials, first_seed=args.first_seed
    )
    return spec, resolved.setting, resolved.source


def _print_summary(result: BenchmarkResult) -> None:
    """Per method: SR with its interval, NT, DT, IDT and the other fields; the pairwise
    comparisons; how many trials ran and where the tables are."""
    from emonav_drake.evaluation import tables

    summary = tables.summarize_methods(result.trials, result.settings["planners"])
    for m, s in summary.items():
        lo, hi = s["SR_ci"]
        print(
            f"{m:>8s}: SR {s['SR']:.3f} [{lo:.3f}, {hi:.3f}] (n={s['episodes']})  NT "
            f"{tables.format_nt(s)} s  DT {s['DT']}  {format_idt(s['IDT'])}"
        )
        field = "  ".join(
            f"{header} {tables.format_mean_ci(s, name, digits)}"
            for name, (header, digits) in tables.FIELD_COLUMNS.items()
        )
        print(f"{'':>8s}  {field}")
    for row in tables.pairwise_comparisons(result.trials, result.settings["planners"]):
        print(tables.pairwise_statement(row))
    print(
        f"{result.ran} trials run in {result.wall_seconds:.1f} s; "
        f"{len(result.trials)} in {result.path}; tables: {result.path / 'tables.md'}"
    )
