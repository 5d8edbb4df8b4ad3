"""`emonav benchmark` (methods × seeded trials, resumable, on Ray) and `emonav config`.

emonav benchmark --planners policy,mpc,dwa --plant lip --trials 500 --first-seed 0
                 [--workers W] [--ray-address ADDR] [--config F | --setting NAME]
                 [--time-varying] [--emotion-estimate F] [--checkpoint NAME=PATH …] --out DIR
emonav config [--dump] [--setting NAME | --config F] [--time-varying]
emonav config --list

The run directory keeps `settings.json`, `trials.jsonl` (one line per finished trial) and
the tables (`tables.md`, CSVs); the same command again continues an interrupted run, a
larger --trials extends it, other settings are refused (exit 2). See
`emonav_drake/evaluation/benchmark.py` and docs/results.md.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from emonav_drake.cli import SeedArg
from emonav_drake.diagrams.trials import MAX_TRIALS
from emonav_drake.params import ConfigError, EmoNavConfig


def resolve_config(args: argparse.Namespace) -> tuple[EmoNavConfig, str | None, str]:
    """(configuration, setting name, where it came from) from --config / --setting /
    --time-varying."""
    from emonav_drake.configs import load_setting
    from emonav_drake.params import load_config

    setting = getattr(args, "setting", None)
    if setting is not None:
        cfg, source = load_setting(setting), f"--setting {setting}"
    elif getattr(args, "config", None) is not None:
        cfg, source = load_config(args.config), f"--config {args.config}"
    else:
        cfg, source = load_config(), "the default configuration"
    if getattr(args, "time_varying", False):
        cfg.crowd.time_varying_emotions = True
        source += " --time-varying"
    return cfg, setting, source


def _emotion_estimate_yaml(path: Path | None) -> str | None:
    """The validated emotion estimate of --emotion-estimate as canonical YAML."""
    if path is None:
        return None
    from emonav_drake.params import dump_typed_yaml, load_typed_yaml
    from emonav_drake.perception.noisy_emotions import EmotionEstimateParams

    params = load_typed_yaml(EmotionEstimateParams, path=path).validate()
    return dump_typed_yaml(params)


def cmd_benchmark(args: argparse.Namespace) -> int:
    """Run or continue a benchmark; print where the tables are."""
    from emonav_drake.atomic_io import check_output_dir
    from emonav_drake.diagrams.trials import parse_methods
    from emonav_drake.evaluation.benchmark import run_benchmark

    # every flag checked before the first trial (planners are built in run_benchmark)
    check_output_dir(args.out, "--out")
    if args.workers is not None and args.workers < 1:
        raise ConfigError(f"--workers {args.workers}: must be >= 1")
    if args.plant == "digit" and args.emotion_estimate is not None:
        raise ConfigError("--emotion-estimate is available with --plant lip only")
    methods = parse_methods(args.planners, args.checkpoint or [])
    cfg, setting, source = resolve_config(args)
    workers = args.workers
    if workers is None and not args.ray_address:
        import os

        workers = os.cpu_count() or 1
    result = run_benchmark(
        args.out,
        methods,
        args.plant,
        args.trials,
        args.first_seed,
        cfg,
        workers=workers,
        ray_address=args.ray_address,
        setting=setting,
        config_source=source,
        emotion_estimate_yaml=_emotion_estimate_yaml(args.emotion_estimate),
        progress=not args.quiet,
    )
    from emonav_drake.evaluation import tables

    summary = tables.summarize_methods(result.trials, result.settings["planners"])
    for m, s in summary.items():
        lo, hi = s["SR_ci"]
        print(
            f"{m:>8s}: SR {s['SR']:.3f} [{lo:.3f}, {hi:.3f}] (n={s['episodes']})  NT "
            f"{tables.format_nt(s)} s  DT {s['DT']}  IDT {tables.format_idt(s)}"
        )
    for row in tables.pairwise_comparisons(result.trials, result.settings["planners"]):
        print(tables.pairwise_statement(row))
    print(
        f"{result.ran} trials run in {result.wall_seconds:.1f} s; "
        f"{len(result.trials)} in {result.path}; tables: {result.path / 'tables.md'}"
    )
    return 0


def cmd_config(args: argparse.Namespace) -> int:
    """Print the resolved configuration as YAML (loadable with --config)."""
    from emonav_drake.params import dump_config

    if args.list:
        given = [
            flag
            for flag, value in (
                ("--dump", args.show),
                ("--setting", args.setting),
                ("--config", args.config),
                ("--time-varying", args.time_varying),
            )
            if value
        ]
        if given:
            raise ConfigError(
                f"--list prints the shipped settings and scenarios; it takes no {given[0]} "
                "(drop --list to print a configuration)"
            )
        sys.stdout.write(_list_examples())
        return 0
    cfg, _, source = resolve_config(args)
    sys.stdout.write(f"# emonav configuration: {source}\n{dump_config(cfg)}")
    return 0


def _list_examples() -> str:
    """The named settings and example scenarios shipped with the package, one per line."""
    from emonav_drake.configs import SETTINGS, setting_path
    from emonav_drake.scenarios import EXAMPLES, SCENARIO_DIR

    def first_comment(path: Path) -> str:
        for line in path.read_text().splitlines():
            if line.startswith("#"):
                return line.lstrip("# ").strip()
        return ""

    lines = ["settings (--setting NAME):"]
    lines += [f"  {n:14s} {first_comment(setting_path(n))}" for n in SETTINGS]
    lines.append("example scenarios (emonav sim --scenario NAME):")
    lines += [f"  {n:14s} {first_comment(SCENARIO_DIR / f'{n}.yaml')}" for n in EXAMPLES]
    return "\n".join(lines) + "\n"


def _add_config_choice(p: argparse.ArgumentParser) -> None:
    from emonav_drake.configs import SETTINGS

    g = p.add_mutually_exclusive_group()
    g.add_argument("--config", type=Path, help="YAML configuration overriding the defaults")
    g.add_argument(
        "--setting",
        choices=SETTINGS,
        help="a named setting of the paper shipped with the package: no_emotion (0.2 m for "
        "every emotion), constant_0.5, var_dd (happy 0.2, neutral 0.35, negative 0.5 m: the "
        "defaults), time_varying (var_dd + one emotion changing every 2 s)",
    )
    p.add_argument(
        "--time-varying",
        action="store_true",
        help="one pedestrian's emotion changes every 2 s (paper §IV-F)",
    )


def add_benchmark_parser(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Register `emonav benchmark` and `emonav config` on the CLI's sub-parsers."""
    b = subparsers.add_parser(
        "benchmark",
        help="compare methods on the same seeded trials (paper Tables II-III); resumable, Ray",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    b.add_argument(
        "--planners",
        default="policy,mpc,dwa",
        help="comma-separated methods: dwa, mpc, dwa_digit (DWA planning with Digit's "
        "step-response model: the Digit/Digit route's expert), policy (the shipped policy), "
        "a variant, or a name given a --checkpoint (sac: a SAC-trained one)",
    )
    b.add_argument("--plant", default="lip", choices=["lip", "digit"])
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
    b.add_argument("--ray-address", help="run on this Ray cluster (e.g. auto or HOST:6379)")
    _add_config_choice(b)
    b.add_argument(
        "--emotion-estimate",
        type=Path,
        help="YAML EmotionEstimateParams: perceive emotions through a confusion matrix "
        "(--plant lip)",
    )
    b.add_argument(
        "--checkpoint",
        action="append",
        metavar="NAME=PATH",
        help="policy checkpoint of a learned method (repeatable); policy defaults to the "
        "shipped policy, a variant to its shipped policy",
    )
    b.add_argument("--out", type=Path, required=True, help="run directory (created if missing)")
    b.add_argument("--quiet", action="store_true", help="no progress bar")
    b.set_defaults(func=cmd_benchmark)

    d = subparsers.add_parser(
        "diagnose",
        help="why Digit trials failed: cause and tracking errors (re-simulates failures)",
    )
    d.add_argument("run", type=Path, help="a Digit benchmark run directory")
    d.add_argument("--methods", help="comma-separated methods (default: all of the run)")
    d.add_argument("--last", type=int, default=5, help="walking steps before the end (>= 1)")
    d.add_argument(
        "--reference", type=int, default=10, help="successful trials per method to compare"
    )
    d.add_argument("--out", type=Path, required=True, help="output directory")
    d.set_defaults(func=cmd_diagnose)

    c = subparsers.add_parser(
        "config",
        help="print the resolved configuration as YAML (the defaults unless a setting or "
        "file is given), or list the shipped settings and example scenarios",
    )
    c.add_argument(
        "--dump",
        "--show",
        dest="show",
        action="store_true",
        help="print the whole configuration, loadable with --config (the default action)",
    )
    c.add_argument(
        "--list", action="store_true", help="list the named settings and example scenarios"
    )
    _add_config_choice(c)
    c.set_defaults(func=cmd_config)
    return b


def cmd_diagnose(args: argparse.Namespace) -> int:
    from emonav_drake.evaluation.diagnosis import diagnose_run, diagnosis_table

    if args.last < 1 or args.reference < 0:
        raise ConfigError("--last must be >= 1 and --reference >= 0")
    if not (args.run / "settings.json").is_file():
        raise ConfigError(f"{args.run}: not a benchmark run directory (no settings.json)")
    methods = args.methods.split(",") if args.methods else None
    rows = diagnose_run(args.run, args.out, methods, args.last, args.reference)
    print(diagnosis_table(rows))
    print(f"written: {args.out}/diagnosis.json, diagnosis.md, diagnosis.png")
    return 0
