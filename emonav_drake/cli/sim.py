"""`emonav sim`: one navigation episode in the Drake diagram (LIP or the full-order Digit).

emonav sim  --planner dwa --plant lip --seed S [--scenario F.yaml]
            [--config F.yaml | --setting NAME] [--meshcat [--no-wait] [--meshcat-host H]]
            [--record out.html] [--json out.json] [--steps-out F.csv] [--rays] [--rates]
            [--[no-]global-route] [--quiet]

A progress bar over simulated time (and the real-time factor) goes to stderr while the
episode runs, when stderr is a terminal and --quiet is not given.
"""

from __future__ import annotations

import argparse
import contextlib
import time
from pathlib import Path
from typing import Any

from emonav_drake.atomic_io import atomic_output, write_json
from emonav_drake.cli.common import (
    PLANNER_HELP,
    PLANT_HELP,
    SeedArg,
    add_episode_flags,
    add_meshcat_host,
    check_outputs,
    check_planner_flags,
    episode_steps_table,
    meshcat_host,
    run_spec_from_args,
    write_steps_csv,
)
from emonav_drake.cli.planners_cmd import DEFAULT_PLANNER
from emonav_drake.cli.resolve import add_spec, check_spec_flags, resolve_config
from emonav_drake.diagrams.episode import EpisodeRequest
from emonav_drake.diagrams.plants import DEFAULT_PLANT, PLANTS, Plant, plant_named
from emonav_drake.diagrams.run_spec import RunSpec, load_run_spec, run_spec_plain
from emonav_drake.navigation.metrics import format_idt
from emonav_drake.navigation.route_following import uses_route
from emonav_drake.params import ConfigError, is_deployable
from emonav_drake.planners import planner_names


def add_parser(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Register `emonav sim` on the CLI's sub-parsers."""
    s = subparsers.add_parser("sim", help="run one navigation episode in the Drake diagram")
    s.add_argument(
        "--planner",
        default=DEFAULT_PLANNER,
        choices=planner_names(),
        metavar="NAME",
        help=PLANNER_HELP,
    )
    s.add_argument("--plant", default=DEFAULT_PLANT, choices=list(PLANTS), help=PLANT_HELP)
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
        "--camera-gif",
        type=Path,
        help="with --emotion-source camera: write what the head camera classified "
        "(every 0.5 Hz image, faces boxed and labelled) as an animated GIF",
    )
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
    add_episode_flags(s)
    add_spec(s, "the --json of an earlier `emonav sim`")
    s.set_defaults(func=cmd_sim)
    return s


def cmd_sim(args: argparse.Namespace) -> int:
    """Run one episode; print its outcome and write --json / --record / --steps-out."""
    check_outputs(args, "--json", "--record", "--steps-out", "--camera-gif")
    meshcat_host(args)
    spec = _sim_spec(args)
    robot = plant_named(spec.plant)
    _check_plant_flags(args, robot)
    estimate = spec.emotion_estimate
    from emonav_drake.perception.noisy_emotions import CAMERA_MODES

    if args.camera_gif is not None and (estimate is None or estimate.mode not in CAMERA_MODES):
        raise ConfigError(
            "--camera-gif needs the camera as the emotion source: --emotion-source camera"
        )
    from emonav_drake.diagrams.trials import TrialRunner

    name = spec.methods[0].name
    runner = TrialRunner(spec.benchmark_spec(), device=args.device)
    planner, cfg, grid_kind = runner.planner(name)
    spec.methods[0].observation = runner.observation(name)  # as a benchmark records it
    scenario = spec.scenario_of(spec.first_seed)
    if hasattr(planner, "describe"):
        print(f"planner {name}: {planner.describe()}")
    meshcat, caption = _open_viewer(args, spec, robot, cfg, scenario)
    rates = None
    if args.rates:
        from emonav_drake.diagrams.rates import RateMeasurement

        rates = RateMeasurement()
    request = EpisodeRequest(  # at the evaluation goal radius
        scenario,
        cfg,
        planner,
        grid_kind,
        emotion_estimate=estimate,
        meshcat=meshcat,
        show_rays=args.rays,
        realtime_rate=1.0 if args.meshcat else 0.0,
        rates=rates,
        progress=True,  # drawn only where `emonav` allows bars: a terminal, no --quiet
        camera_frames=[] if args.camera_gif is not None else None,
        trace=bool(args.json or args.steps_out),
        scene=_scene_label(spec, scenario.seed, caption=True),
    )
    t0 = time.perf_counter()
    record, trace = _run_sim_episode(args, robot, request)
    wall = time.perf_counter() - t0
    out = record.to_json()
    out["seed"] = scenario.seed
    out["state_source"] = cfg.perception.state_source  # what the planner read of the crowd
    out["sensor"] = cfg.sensor.preset  # the LiDAR the scan came from (ideal: exact)
    out["deployable"] = is_deployable(cfg)
    out["emotion_source"] = "truth" if estimate is None else estimate.mode
    out["global_route"] = uses_route(scenario, cfg)
    if rates is not None and rates.report is not None:
        out.update(rates.report.to_json())
        print(_format_rates(rates.report))
    print(
        f"{_scene_label(spec, scenario.seed)}, {name} on {robot.caption_name}: "
        f"{outcome_words(record)} after {record.steps} steps "
        f"({record.nav_time:.1f} s simulated, {wall:.2f} s wall), path "
        f"{record.path_length:.2f} m, min pedestrian distance "
        f"{record.min_ped_distance:.2f} m, discomfort steps {record.discomfort_steps}, "
        f"{format_idt(record.idt)}"
    )
    if args.record:
        print(f"replay written to {Path(args.record).resolve()} (open it in a browser)")
    if args.camera_gif is not None:
        from emonav_drake.atomic_io import atomic_output
        from emonav_drake.diagrams.camera_perception import write_camera_gif

        with atomic_output(args.camera_gif) as path:
            n = write_camera_gif(request.camera_frames, path)
        print(f"camera: {n} classified images written to {Path(args.camera_gif).resolve()}")
    out["spec"] = run_spec_plain(spec)  # `emonav sim --spec` runs it again
    _write_sim_outputs(args, spec, request, record, trace, out)
    if caption is not None:  # live: the outcome in Meshcat, served until Ctrl-C
        from emonav_drake.diagrams.meshcat_viewing import finish_live_view

        caption.set_outcome(record)
        finish_live_view(meshcat, keep_serving=not args.no_wait, caption=caption)
    return 0


def _check_plant_flags(args: argparse.Namespace, robot: Plant) -> None:
    """Refuse the viewer and per-step flags on a plant without `viewers` (its `simulate`
    gives the record, and --json, only), and --rays on one that cannot draw them."""
    if not robot.viewers:
        viewer_flags = {"--meshcat": args.meshcat, "--record": args.record, "--rays": args.rays}
        viewer_flags |= {"--steps-out": args.steps_out, "--rates": args.rates}
        viewer_flags |= {"--camera-gif": args.camera_gif}
        given = [flag for flag, value in viewer_flags.items() if value]
        if given:
            able = " or ".join(p for p in PLANTS if PLANTS[p].viewers)
            raise ConfigError(f"--plant {args.plant}: {', '.join(given)} need --plant {able}")
    if args.rays and not robot.rays:
        able = [p for p in PLANTS if PLANTS[p].rays]
        raise ConfigError(
            f"--plant {robot.name}: --rays is available with --plant {' or '.join(able)} only"
        )


def _open_viewer(
    args: argparse.Namespace, spec: RunSpec, robot: Plant, cfg: Any, scenario: Any
) -> tuple[Any, Any]:
    """The Meshcat of --meshcat / --record (None without them) and, live, its caption
    (started, and waiting for a browser unless --no-wait); (None, None) without a viewer."""
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
            caption = ReplayCaption(
                spec.methods[0].name,
                robot.caption_name,
                scenario.seed,
                rays=args.rays,
                footsteps=robot.footsteps,
                tracks=cfg.perception.state_source == "lidar",
                route=uses_route(scenario, cfg),
                scene=_scene_label(spec, scenario.seed, caption=True),
            )
            start_live_view(meshcat, wait=not args.no_wait, caption=caption)
    return meshcat, caption


def _run_sim_episode(
    args: argparse.Namespace, robot: Plant, request: EpisodeRequest
) -> tuple[Any, Any]:
    """Run the episode with the plant's `simulate`, the replay (--record) going to a
    temporary sibling renamed when complete; (its record, its trace or None)."""
    with contextlib.ExitStack() as stack:
        if args.record:
            request.record_html = stack.enter_context(atomic_output(args.record))
        return robot.simulate(request)


def _write_sim_outputs(
    args: argparse.Namespace,
    spec: RunSpec,
    request: EpisodeRequest,
    record: Any,
    trace: Any,
    out: dict,
) -> None:
    """Write --json (`out`, with the trajectory when the plant gave the trace) and
    --steps-out of a finished episode, from its `EpisodeTrace` on either plant."""
    cfg, scenario = request.config, request.scenario
    if args.json:  # the episode step by step, drawn by `emonav plot`
        from emonav_drake.evaluation.trajectory import trajectory_from_trace

        if trace is not None:
            out["trajectory"] = trajectory_from_trace(
                scenario, cfg, record, trace, spec.methods[0].name, spec.plant, request.goal_radius
            ).to_json()
        write_json(args.json, out)
    if args.steps_out:  # per planner step: the planner's LIP step vs the robot
        if trace is None:
            raise ConfigError(f"--steps-out: --plant {spec.plant} gave no per-step trace")
        n = write_steps_csv(args.steps_out, episode_steps_table(cfg, trace))
        print(f"{n} steps written to {args.steps_out}")


def outcome_words(record: Any) -> str:
    """The outcome in words, with what was hit: "collision with a static disc", "collision
    with a negative pedestrian", "fall (reason)", "no route left", "success", "timeout"."""
    if record.outcome == "collision":
        hit = record.collided_with
        what = {"static": "a static disc", "wall": "a wall"}.get(hit, f"a {hit} pedestrian")
        return f"collision with {what}" if hit else "collision"
    if record.outcome == "fall":
        return f"fall ({record.fall_reason})" if record.fall_reason else "fall"
    if record.outcome == "no_route":
        return "no route left"
    return record.outcome


def _scene_label(spec: RunSpec, seed: int, caption: bool = False) -> str:
    """Which scene ran, for the summary line: "scenario crossing (seed 0)" for a fixed
    scene (for a replay's `caption`: "scenario crossing", its seed only with time-varying
    emotions, which it picks the changing pedestrian by), "family blocker, seed 3" for a
    family, else "seed 7" (the paper's arena)."""
    if spec.scenario is not None:
        name = f"scenario {spec.scene_name or 'file'}"
        if caption and not spec.config.crowd.time_varying_emotions:
            return name
        return f"{name} (seed {seed})"
    family = spec.config.crowd.family
    return f"seed {seed}" if family == "paper" else f"family {family}, seed {seed}"


def _sim_spec(args: argparse.Namespace) -> RunSpec:
    """The run spec of `--spec FILE` (one episode of one method), else of the flags."""
    if args.spec is None:
        check_planner_flags(args)
        return run_spec_from_args(args, resolve_config(args))
    check_spec_flags(args)
    spec = load_run_spec(args.spec)
    if len(spec.methods) != 1 or spec.episodes != 1:
        raise ConfigError(
            f"--spec {args.spec}: records {len(spec.methods)} method(s) over {spec.episodes} "
            "episode(s); sim runs one episode of one method (eval or benchmark --spec run "
            "more)"
        )
    return spec


def _format_rates(report: Any) -> str:
    """The measured rates and wall-time shares (`--rates`) as a small table."""
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
