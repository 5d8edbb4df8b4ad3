"""The `emonav` command line.

emonav sim  --planner dwa --plant lip --seed S [--scenario F.yaml] [--config F.yaml]
            [--meshcat [--no-wait] [--meshcat-host H]]
            [--record out.html] [--json out.json] [--rays]
emonav eval --planner dwa --plant lip --episodes 100 --first-seed 0 [--json out.json]
emonav lgm  --seed S --png out.png [--steps K] [--time-varying]
emonav plot RUN.json --png out.png [--times 0,5,10] [--gif out.gif]   (cli_plot.py)

Errors: a bad flag, file or field is one line `emonav: error: ...` naming it, exit code 2
(`--debug` shows the traceback instead). Ctrl-C: one line, exit code 130; `eval` keeps
the finished episodes, `train` saves a checkpoint. Output files are checked before any
work and written atomically (never half-written). See docs/reliability.md.
"""

from __future__ import annotations

import argparse
import contextlib
import logging
import signal
import sys
import threading
import time
import traceback
from collections.abc import Iterator
from pathlib import Path

from emonav_drake.atomic_io import (
    atomic_output,
    check_distinct,
    check_output_file,
    write_json,
)
from emonav_drake.errors import RunInterrupted
from emonav_drake.params import ConfigError, EmoNavConfig, load_config
from emonav_drake.planners import PLANNERS
from emonav_drake.planners.variants import is_learned

PLANNER_CHOICES = list(PLANNERS)

# Exit codes.
EXIT_USAGE = 2  # a user error: bad flag, file, field or output path
EXIT_INTERRUPTED = 130  # Ctrl-C (128 + SIGINT)
EXIT_INTERNAL = 1  # an unexpected exception: a bug

# Exceptions that are the user's to fix: the ValueError family (ConfigError, PolicyError,
# CommandError, ImageReadError, OutputPathError, DeviceError, …) and the file system's.
USER_ERRORS = (ValueError, OSError, NotImplementedError)

# `eval --episodes` at most: every scenario is sampled before the first episode (a crowd
# that does not fit fails at once), ~0.2 ms per seed, ~20 s at the maximum; 100 000 DWA
# episodes already take ~8 h on one core.
MAX_EPISODES = 100_000


def parse_seed(text: str, flag: str) -> int:
    """A seed flag's value: an integer in [0, 2**64 - 1]; else `ConfigError` naming `flag`."""
    from emonav_drake.core.scenario import MAX_SEED

    try:
        value = int(text)
    except ValueError:
        raise ConfigError(f"{flag} {text!r}: must be an integer in [0, 2**64 - 1]") from None
    if value < 0:
        raise ConfigError(f"{flag} {value}: must be >= 0")
    if value > MAX_SEED:
        raise ConfigError(
            f"{flag} {value}: beyond 64 bits; seeds are in [0, 2**64 - 1] = [0, {MAX_SEED}]"
        )
    return value


class SeedArg(argparse.Action):
    """The argparse action shared by every seed flag (`--seed`, `--first-seed`): the value
    is an integer in [0, 2**64 - 1] (`parse_seed`). Unlike a `type`, an action knows the
    flag, so a bad value is a `ConfigError` naming it: one line, exit 2 (`main`)."""

    def __call__(
        self,
        parser: argparse.ArgumentParser,
        namespace: argparse.Namespace,
        values: object,
        option_string: str | None = None,
    ) -> None:
        setattr(namespace, self.dest, parse_seed(str(values), option_string or self.dest))


def check_seed_range(first: int, count: int, flag: str) -> None:
    """Seeds `first` … `first + count - 1` must all fit in 64 bits (`ConfigError` naming `flag`)."""
    from emonav_drake.core.scenario import MAX_SEED

    if first + count - 1 > MAX_SEED:
        raise ConfigError(
            f"{flag} {first}: with {count} seeds the last one, {first + count - 1}, is beyond "
            "64 bits (2**64 - 1)"
        )


def add_meshcat_host(p: argparse.ArgumentParser) -> None:
    """`--meshcat-host`: where a live Meshcat listens (loopback unless asked)."""
    p.add_argument(
        "--meshcat-host",
        default=None,
        metavar="HOST",
        help="with --meshcat: the interface Meshcat listens on (default localhost: this "
        "machine only); '*' = every interface, or one address of this machine. Meshcat has "
        "no authentication: anyone who reaches it can watch and change the scene (a warning "
        "is printed); prefer `ssh -L 7000:localhost:7000` to watch from another machine",
    )


def meshcat_host(args: argparse.Namespace) -> str:
    """The Meshcat host of `--meshcat-host` (checked: only with `--meshcat`, not empty)."""
    from emonav_drake.diagrams.meshcat_viewing import LOOPBACK_HOST

    if args.meshcat_host is None:
        return LOOPBACK_HOST
    if not args.meshcat:
        raise ConfigError("--meshcat-host is used with --meshcat only")
    if not args.meshcat_host.strip():
        raise ConfigError("--meshcat-host '': give a host name or address, or '*'")
    return args.meshcat_host.strip()


def _add_common(p: argparse.ArgumentParser) -> None:
    p.add_argument("--config", type=Path, help="YAML configuration overriding the defaults")
    p.add_argument(
        "--checkpoint",
        type=Path,
        help="policy checkpoint for a learned planner (default: the one shipped under its name)",
    )
    p.add_argument(
        "--device", default="cpu", help="torch device for a learned planner (cpu, cuda, cuda:N)"
    )
    p.add_argument(
        "--emotion-estimate",
        type=Path,
        help="YAML EmotionEstimateParams: perceive emotions through a confusion "
        "matrix (mode: confusion) instead of the ground truth",
    )
    p.add_argument(
        "--time-varying",
        action="store_true",
        help="one pedestrian's emotion changes every 2 s (paper §IV-F); with --scenario, "
        "a pedestrian of the file chosen by --seed",
    )


def _config(args: argparse.Namespace) -> EmoNavConfig:
    cfg = load_config(args.config) if args.config else load_config()
    if getattr(args, "time_varying", False):
        cfg.crowd.time_varying_emotions = True
    return cfg


def _scenario(args: argparse.Namespace, cfg: EmoNavConfig):
    from emonav_drake.core.scenario import add_time_varying_emotion, load_scenario

    if getattr(args, "scenario", None):
        from emonav_drake.scenarios import scenario_path

        sc = load_scenario(scenario_path(args.scenario), cfg)
        sc.seed = args.seed if sc.seed < 0 else sc.seed
        if getattr(args, "time_varying", False):
            add_time_varying_emotion(sc, sc.seed, cfg)
        return sc
    return _sample(args, args.seed, cfg)


def _sample(args: argparse.Namespace, seed: int, cfg: EmoNavConfig):
    """`sample_scenario`, its error naming the configuration file the crowd came from."""
    from emonav_drake.core.scenario import ScenarioSamplingError, sample_scenario

    try:
        return sample_scenario(seed, cfg)
    except ScenarioSamplingError as e:
        where = f"--config {args.config}" if args.config else "the default configuration"
        raise ScenarioSamplingError(f"{where}: {e}") from None


def _emotion_estimate(args: argparse.Namespace):
    if not getattr(args, "emotion_estimate", None):
        return None
    from emonav_drake.params import load_typed_yaml
    from emonav_drake.perception.noisy_emotions import EmotionEstimateParams

    return load_typed_yaml(EmotionEstimateParams, path=args.emotion_estimate).validate()


def _check_planner_flags(args: argparse.Namespace) -> None:
    """--checkpoint / --device only mean something with a learned planner; check them early."""
    if not is_learned(args.planner):
        if args.checkpoint is not None:
            raise ConfigError(
                f"--checkpoint applies to a learned planner (--planner policy, sac or a variant), "
                f"not {args.planner}"
            )
        if args.device != "cpu":
            raise ConfigError(
                f"--device applies to a learned planner (--planner policy, sac or a variant), "
                f"not {args.planner}"
            )
        return
    from emonav_drake.planners.policy import resolve_device

    resolve_device(args.device)


def _check_outputs(args: argparse.Namespace, *flags: str) -> None:
    """Every output flag given: a writable file path (checked before any work), all distinct."""
    outputs = {}
    for flag in flags:
        path = getattr(args, flag.removeprefix("--").replace("-", "_"), None)
        if path is not None:
            outputs[flag] = check_output_file(path, flag)
    check_distinct(outputs)


def cmd_sim(args: argparse.Namespace) -> int:
    _check_outputs(args, "--json", "--record", "--steps-out")
    meshcat_host(args)
    if args.plant == "digit" and (args.emotion_estimate or args.rays):
        raise ConfigError(
            "--plant digit: --rays and --emotion-estimate are available "
            "with --plant lip only in this version"
        )
    _check_planner_flags(args)
    cfg = _config(args)
    scenario = _scenario(args, cfg)
    estimate = _emotion_estimate(args)
    from emonav_drake.diagrams.navigation import run_episode
    from emonav_drake.diagrams.navigation_digit import run_digit_episode
    from emonav_drake.planners import configure_for, make_planner

    planner = make_planner(args.planner, cfg, checkpoint=args.checkpoint, device=args.device)
    grid_kind = configure_for(planner, cfg)
    if hasattr(planner, "describe"):
        print(f"planner {args.planner}: {planner.describe()}")
    meshcat = caption = None
    if args.meshcat or args.record:
        from emonav_drake.diagrams.meshcat_viewing import (
            ReplayCaption,
            make_meshcat,
            start_live_view,
        )
        from emonav_drake.systems.navigation_meshcat import set_overview_camera

        # record only: no "listening at" line
        meshcat = make_meshcat(live=args.meshcat, host=meshcat_host(args))
        set_overview_camera(meshcat, cfg)
        if args.meshcat:
            plant = "Digit" if args.plant == "digit" else "LIP"
            caption = ReplayCaption(args.planner, plant, scenario.seed, rays=args.rays)
            start_live_view(meshcat, wait=not args.no_wait, caption=caption)
    rates = None
    if args.rates:
        from emonav_drake.diagrams.rates import RateMeasurement

        rates = RateMeasurement()
    trace: list[dict] = []  # Digit's per-step log: the trajectory of --json
    t0 = time.perf_counter()
    with contextlib.ExitStack() as stack:
        # the replay goes to a temporary sibling, renamed when complete
        record_html = stack.enter_context(atomic_output(args.record)) if args.record else None
        if args.plant == "digit":
            record = run_digit_episode(
                scenario,
                cfg,
                planner,
                meshcat=meshcat,
                grid_kind=grid_kind,
                goal_radius=cfg.episode.eval_goal_radius,
                realtime_rate=1.0 if args.meshcat else 0.0,
                record_html=record_html,
                rates=rates,
                trace=trace if args.json or args.steps_out else None,
            )
        else:
            record, step_log = run_episode(
                scenario,
                cfg,
                planner,
                meshcat=meshcat,
                record_html=record_html,
                show_rays=args.rays,
                goal_radius=cfg.episode.eval_goal_radius,
                realtime_rate=1.0 if args.meshcat else 0.0,
                grid_kind=grid_kind,
                emotion_estimate=estimate,
                rates=rates,
            )
    wall = time.perf_counter() - t0
    out = record.to_json()
    out["seed"] = scenario.seed
    if rates is not None and rates.report is not None:
        out.update(rates.report.to_json())
        print(_format_rates(rates.report))
    print(
        f"seed {scenario.seed}: {record.outcome} after {record.steps} steps "
        f"({record.nav_time:.1f} s simulated, {wall:.2f} s wall), path "
        f"{record.path_length:.2f} m, min pedestrian distance "
        f"{record.min_ped_distance:.2f} m, discomfort steps {record.discomfort_steps}, "
        f"IDT {record.idt}"
    )
    if args.record:
        print(f"replay written to {Path(args.record).resolve()} (open it in a browser)")
    if args.json:  # the episode step by step, drawn by `emonav plot`
        from emonav_drake.evaluation import trajectory as tj

        goal_r = cfg.episode.eval_goal_radius
        out["trajectory"] = (
            tj.trajectory_from_digit_trace(scenario, cfg, record, trace, args.planner, goal_r)
            if args.plant == "digit"
            else tj.trajectory_from_step_log(scenario, cfg, record, step_log, args.planner, goal_r)
        ).to_json()
        write_json(args.json, out)
    if args.steps_out:  # per planner step: the planner's LIP step vs the robot
        from emonav_drake.cli_walk import episode_steps_table, write_steps_csv

        table = (
            episode_steps_table(cfg, trace=trace)
            if args.plant == "digit"
            else episode_steps_table(cfg, robot=step_log.robot, commands=step_log.commands)
        )
        n = write_steps_csv(args.steps_out, table)
        print(f"{n} steps written to {args.steps_out}")
    if caption is not None:  # live: the outcome in Meshcat, served until Ctrl-C
        from emonav_drake.diagrams.meshcat_viewing import finish_live_view

        caption.set_outcome(record)
        finish_live_view(meshcat, keep_serving=not args.no_wait, caption=caption)
    return 0


def _format_rates(report) -> str:
    """The measured rates and wall-time shares as a small table."""
    shares = report.wall_time_share
    rates = report.rates()
    # the plant's wall time is the C++ remainder, listed as "<plant> + framework"
    rows = {n.removesuffix(" + framework"): n for n in shares}
    names = sorted(set(rates) | set(rows), key=lambda n: -shares.get(rows.get(n, n), 0.0))
    lines = [f"{'system':32s} {'rate [1/s sim]':>15s} {'wall share':>11s}"]
    for n in names:
        r = f"{rates[n]:.1f}" if n in rates else "-"
        label = rows.get(n, n)
        lines.append(f"{label:32s} {r:>15s} {100 * shares.get(label, 0.0):10.1f}%")
    lines.append(
        f"(profiled: {report.sim_seconds:.1f} s simulated in {report.wall_seconds:.1f} s wall)"
    )
    return "\n".join(lines)


def cmd_eval(args: argparse.Namespace) -> int:
    """Evaluate over seeds; on Ctrl-C keep the finished episodes (summary, --json, exit 130)."""
    if not 1 <= args.episodes <= MAX_EPISODES:
        raise ConfigError(
            f"--episodes {args.episodes}: must be in [1, {MAX_EPISODES}] (split a longer "
            "evaluation with --first-seed)"
        )
    check_seed_range(args.first_seed, args.episodes, "--first-seed")
    _check_outputs(args, "--json")
    _check_planner_flags(args)
    cfg = _config(args)
    estimate = _emotion_estimate(args)
    if args.plant == "digit" and estimate is not None:
        raise ConfigError("--emotion-estimate is available with --plant lip only")
    from tqdm import tqdm

    from emonav_drake.core.metrics import format_summary, summarize
    from emonav_drake.diagrams.evaluation_episode import run_evaluation_episode
    from emonav_drake.planners import configure_for, make_planner

    seeds = range(args.first_seed, args.first_seed + args.episodes)
    # Every scenario first (cheap): a crowd that does not fit fails now, not at episode k;
    # none is kept (each is drawn again for its episode), so memory does not grow with N.
    for seed in seeds:
        _sample(args, seed, cfg)
    planner = make_planner(args.planner, cfg, checkpoint=args.checkpoint, device=args.device)
    grid_kind = configure_for(planner, cfg)
    if hasattr(planner, "describe"):
        print(f"planner {args.planner}: {planner.describe()}")
    records = []
    interrupted = False
    with tqdm(total=len(seeds), desc=f"{args.planner}/{args.plant}", unit="ep") as bar:
        try:
            for seed in seeds:
                scenario = _sample(args, seed, cfg)
                rec = run_evaluation_episode(
                    args.plant, scenario, cfg, planner, grid_kind, estimate
                )
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
            "planner": args.planner,
            "plant": args.plant,
            "seeds": [seeds.start, seeds.stop],
            "interrupted": interrupted,
            "seeds_done": done,
            "summary": summary,
            "episodes": [r.to_json() for r in records],
        }
        write_json(args.json, out)
    if interrupted:
        where = f"; written to {args.json} (interrupted: true)" if args.json else ""
        raise RunInterrupted(
            f"interrupted after {len(records)} of {len(seeds)} episodes (seeds "
            f"{done[0]}-{done[-1]}); the summary above covers them{where}"
        )
    return 0


def cmd_lgm(args: argparse.Namespace) -> int:
    if args.steps < 0:
        raise ConfigError(f"--steps {args.steps}: must be >= 0")
    _check_outputs(args, "--png")
    if args.png.suffix.lower() != ".png":
        raise ConfigError(f"--png {args.png}: the file name must end in .png")
    import numpy as np

    from emonav_drake.core.crowd import obstacle_discs
    from emonav_drake.core.dwa import DwaPlanner
    from emonav_drake.core.navigation import NavigationWorld
    from emonav_drake.evaluation.grid_map_figure import render_grid_map_figure

    cfg = _config(args)
    world = NavigationWorld(_scenario(args, cfg), cfg, grid_kind=None)
    planner = DwaPlanner(cfg)
    for _ in range(args.steps):  # walk a little so the crowd comes close
        _, outcome = world.step(planner.plan(world.planner_input()))
        if outcome is not None:
            break
    obs = world.planner_input()
    centers, radii, margins = obstacle_discs(obs.crowd)
    kinds = np.concatenate(
        [np.ones(len(obs.crowd.positions), int), np.zeros(len(obs.crowd.static_radii), int)]
    )
    emotions = np.concatenate([obs.crowd.emotions, np.full(len(obs.crowd.static_radii), -1)])
    with atomic_output(args.png) as tmp:
        render_grid_map_figure(
            tmp,
            np.array([obs.robot.x, obs.robot.y]),
            obs.robot.heading,
            centers,
            radii,
            margins,
            kinds,
            goal_xy=obs.goal_xy,
            grid_size=cfg.lidar.grid_size,
            num_beams=cfg.lidar.num_beams,
            max_range=cfg.lidar.max_range,
            min_range=cfg.lidar.min_range,
            robot_radius=cfg.robot.radius,
            title=f"seed {world.scenario.seed}: t = {world.step_count * cfg.robot.step_time:.1f} s "
            f"(after {world.step_count} DWA steps)",
            emotions=emotions,
        )
    print(f"wrote {args.png} (seed {args.seed}, after {world.step_count} steps)")
    return 0


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="emonav", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    p.add_argument("-v", "--verbose", action="store_true")
    p.add_argument(
        "--debug",
        action="store_true",
        help="on an error, show the Python traceback instead of the one-line message",
    )
    # accepted after the sub-command too (`emonav sim --debug`); SUPPRESS keeps the
    # sub-parser from overwriting a --debug given before the sub-command
    debug = argparse.ArgumentParser(add_help=False)
    debug.add_argument(
        "--debug", action="store_true", default=argparse.SUPPRESS, help=argparse.SUPPRESS
    )
    sub = p.add_subparsers(dest="command", required=True)

    s = sub.add_parser(
        "sim", parents=[debug], help="run one navigation episode in the Drake diagram"
    )
    s.add_argument("--planner", default="dwa", choices=PLANNER_CHOICES)
    s.add_argument("--plant", default="lip", choices=["lip", "digit"])
    s.add_argument("--seed", action=SeedArg, default=0, help="scenario seed, in [0, 2**64 - 1]")
    s.add_argument(
        "--scenario",
        help="YAML scenario file instead of a sampled one, or the name of a shipped "
        "example (head_on, crossing, mood_swing; `emonav config --list`)",
    )
    s.add_argument(
        "--meshcat",
        action="store_true",
        help="draw live in Meshcat (real time): prints the URL, waits for a browser to "
        "connect, and keeps serving after the episode until Ctrl-C",
    )
    s.add_argument(
        "--no-wait",
        action="store_true",
        help="with --meshcat: start without waiting for a browser and exit when the "
        "episode ends (scripts, tests)",
    )
    add_meshcat_host(s)
    s.add_argument("--record", type=Path, help="write a self-contained HTML replay")
    s.add_argument(
        "--rays", action="store_true", help="draw the LiDAR rays (per walking step) in Meshcat"
    )
    s.add_argument(
        "--json",
        type=Path,
        help="write the outcome and the trajectory as JSON (drawn by `emonav plot`)",
    )
    s.add_argument(
        "--steps-out",
        type=Path,
        metavar="FILE.csv",
        help="write one CSV row per planner step: the command held, the planner's LIP step "
        "(paper Eq. 1) from the robot at t_k vs the robot at t_k+1, the errors "
        "(docs/walking.md; with --plant lip the errors are zero up to rounding)",
    )
    s.add_argument(
        "--rates",
        action="store_true",
        help="profile the run: events per simulated second and wall-time share of every "
        "system (printed, and added to --json as 'rates' and 'wall_time_share')",
    )
    _add_common(s)
    s.set_defaults(func=cmd_sim)

    e = sub.add_parser(
        "eval", parents=[debug], help="evaluate a planner over many seeds (SR, NT, DT, IDT)"
    )
    e.add_argument("--planner", default="dwa", choices=PLANNER_CHOICES)
    e.add_argument("--plant", default="lip", choices=["lip", "digit"])
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
    _add_common(e)
    e.set_defaults(func=cmd_eval)

    g = sub.add_parser(
        "lgm", parents=[debug], help="render a scenario's LiDAR grid map and OGM as a PNG"
    )
    g.add_argument("--seed", action=SeedArg, default=0, help="scenario seed, in [0, 2**64 - 1]")
    g.add_argument(
        "--scenario",
        help="YAML scenario file instead of a sampled one, or the name of a shipped example",
    )
    g.add_argument("--steps", type=int, default=8, help="DWA steps to walk before the snapshot")
    g.add_argument("--png", type=Path, required=True, help="output image (a .png file)")
    g.add_argument("--config", type=Path, help="YAML configuration overriding the defaults")
    g.add_argument(
        "--time-varying",
        action="store_true",
        help="one pedestrian's emotion changes every 2 s (as in `sim --time-varying`)",
    )
    g.set_defaults(func=cmd_lgm)

    from emonav_drake.cli_train import add_export_parser, add_train_parser

    add_train_parser(sub)
    add_export_parser(sub)
    from emonav_drake.cli_emotion import add_emotion_parser

    add_emotion_parser(sub)
    from emonav_drake.cli_walk import add_walk_parser

    add_walk_parser(sub)
    from emonav_drake.cli_plot import add_plot_parser

    add_plot_parser(sub)
    from emonav_drake.cli_benchmark import add_benchmark_parser

    add_benchmark_parser(sub)
    from emonav_drake.cli_calibrate import add_calibrate_parser

    add_calibrate_parser(sub)  # also `emonav digit-rounds`
    for name, parser in sub.choices.items():
        if name not in ("sim", "eval", "lgm"):
            parser.add_argument(
                "--debug", action="store_true", default=argparse.SUPPRESS, help=argparse.SUPPRESS
            )
    return p


def _one_line(e: BaseException) -> str:
    """The exception's message on one line (YAML and torch messages can span several)."""
    lines = [line.strip() for line in str(e).splitlines() if line.strip()]
    return "; ".join(lines) or type(e).__name__


@contextlib.contextmanager
def _sigterm_as_interrupt() -> Iterator[None]:
    """SIGTERM handled like Ctrl-C while a command runs (temporary files removed, runs saved).

    The signal is passed to whatever SIGINT handler is installed at that moment — the
    trainers' graceful stop-request guard during training, else Python's default, which
    raises `KeyboardInterrupt` (also when SIGINT is ignored, as in a background job:
    `kill` must still stop the run).
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def as_sigint(signum: int, frame: object) -> None:
        handler = signal.getsignal(signal.SIGINT)
        if callable(handler):
            handler(signal.SIGINT, frame)
        else:
            raise KeyboardInterrupt

    previous = signal.signal(signal.SIGTERM, as_sigint)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


def main(argv: list[str] | None = None) -> int:
    """Run a sub-command; the one place where exceptions become messages and exit codes.

    0: done. 2: a user error (bad flag, file, field or output path), one line
    `emonav: error: ...`. 130: interrupted (Ctrl-C or SIGTERM), one line. 1: an
    unexpected exception (a bug), one line. `--debug` re-raises instead, with the
    traceback. Argument-syntax errors are argparse's (usage and exit code 2).
    """
    argv = sys.argv[1:] if argv is None else [str(a) for a in argv]
    try:
        args = build_parser().parse_args(argv)
    except USER_ERRORS as e:  # a flag value refused while parsing (the seed flags)
        if "--debug" in argv:
            raise
        print(f"emonav: error: {_one_line(e)}", file=sys.stderr)
        return EXIT_USAGE
    debug = getattr(args, "debug", False)
    logging.basicConfig(
        level=logging.INFO if args.verbose else logging.WARNING,
        format="%(levelname)s %(name)s: %(message)s",
    )
    try:
        with _sigterm_as_interrupt():
            return args.func(args)
    except RunInterrupted as e:
        if debug:
            traceback.print_exc()
        print(f"emonav: {_one_line(e)}", file=sys.stderr)
        return EXIT_INTERRUPTED
    except KeyboardInterrupt:
        if debug:
            traceback.print_exc()
        saved = "" if args.command == "train" else "; no output file was written"
        print(f"emonav: interrupted{saved}", file=sys.stderr)
        return EXIT_INTERRUPTED
    except USER_ERRORS as e:
        if debug:
            raise
        print(f"emonav: error: {_one_line(e)}", file=sys.stderr)
        return EXIT_USAGE
    except Exception as e:
        if debug:
            raise
        print(
            f"emonav: internal error: {type(e).__name__}: {_one_line(e)} "
            "(a bug: rerun with --debug for the traceback and report it)",
            file=sys.stderr,
        )
        return EXIT_INTERNAL


if __name__ == "__main__":
    sys.exit(main())
