"""The `emonav` command line.

emonav sim  --planner dwa --plant lip --seed S [--scenario F.yaml]
            [--config F.yaml | --setting NAME] [--meshcat [--no-wait] [--meshcat-host H]]
            [--record out.html] [--json out.json] [--rays]
emonav eval --planner dwa --plant lip --episodes 100 --first-seed 0
            [--config F.yaml | --setting NAME] [--json out.json]
emonav lgm  --seed S --png out.png [--steps K] [--time-varying]
emonav plot RUN.json --png out.png [--times 0,5,10] [--gif out.gif]
emonav planners   every planner: what it reads (privileged or deployable), its checkpoint
emonav SUB-COMMAND --help   for every other one

One module per sub-command in emonav_drake/cli/ (sim.py, eval.py, lgm.py, plot.py, walk.py,
emotion.py, train.py, export.py, benchmark.py, compare.py, report.py, diagnose.py, config.py,
calibrate.py, digit_rounds.py, planners_cmd.py); --config / --setting / --scenario are
resolved in one place, resolve.py.

Errors: a bad flag, file or field is one line `emonav: error: ...` naming it, exit code 2
(`--debug` shows the traceback instead). Ctrl-C: one line, exit code 130; `eval` keeps
the finished episodes, `train` saves a checkpoint. Output files are checked before any
work and written atomically (never half-written). See docs/reliability.md.
"""

from __future__ import annotations

import argparse
import contextlib
import logging
import os
import signal
import sys
import threading
import traceback
from collections.abc import Iterator

from emonav_drake import progress
from emonav_drake.cli import (
    benchmark,
    calibrate,
    compare,
    config,
    diagnose,
    digit_rounds,
    emotion,
    export,
    lgm,
    planners_cmd,
    plot,
    report,
    sim,
    train,
    walk,
)
from emonav_drake.cli import eval as eval_cmd
from emonav_drake.cli.common import SuggestingParser, UserHelpFormatter
from emonav_drake.errors import RunInterrupted, UserError

# Exit codes.
EXIT_USAGE = 2  # a user error: bad flag, file, field or output path
EXIT_INTERRUPTED = 130  # Ctrl-C (128 + SIGINT)
EXIT_INTERNAL = 1  # an unexpected exception: a bug
EXIT_BROKEN_PIPE = 141  # the reader of stdout went away (`emonav planners | head`): 128 + SIGPIPE

# Exceptions that are the user's to fix: a `UserError` (ConfigError, PolicyError,
# ImageReadError, OutputPathError, DeviceError, …: raised where an input is checked) and the
# file system's (a missing file, a full disk, no permission). Anything else — a plain
# ValueError or numpy's LinAlgError from inside a simulation included — is a bug.
USER_ERRORS = (UserError, OSError)

# The sub-commands in the order of `emonav --help`.
SUBCOMMANDS = (
    sim,
    eval_cmd,
    planners_cmd,
    lgm,
    train,
    export,
    emotion,
    walk,
    plot,
    benchmark,
    compare,
    report,
    diagnose,
    config,
    calibrate,
    digit_rounds,
)


# What `emonav --help` says above the sub-commands (for users; the module docstring is
# for developers).
DESCRIPTION = """\
Emotion-aware social navigation for the bipedal robot Digit, as a Drake diagram.

First commands:
  emonav sim --planner policy --plant digit --seed 0 --record replay.html
                              one episode on the full-order Digit; open replay.html
  emonav planners             every planner: what it reads, its checkpoint, the defaults
  emonav eval --planner mpc --episodes 100
                              success rate and discomfort over seeds 0-99
  emonav SUB-COMMAND --help   the flags of a sub-command, with their defaults

Errors are one line `emonav: error: ...` (exit code 2; --debug shows the traceback);
Ctrl-C stops cleanly (exit code 130: `eval` keeps finished episodes, `train` saves).
"""


def build_parser() -> argparse.ArgumentParser:
    """The `emonav` parser: every sub-command module's `add_parser`, `--version`,
    `--verbose`, `--quiet` and `--debug`."""
    p = SuggestingParser(
        prog="emonav",
        description=DESCRIPTION,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("--version", action="version", version=f"emonav {package_version()}")
    p.add_argument("-v", "--verbose", action="store_true", help="log what each step does")
    p.add_argument("-q", "--quiet", action="store_true", help=QUIET_HELP)
    p.add_argument(
        "--debug",
        action="store_true",
        help="on an error, show the Python traceback instead of the one-line message",
    )
    sub = p.add_subparsers(dest="command", required=True)
    for module in SUBCOMMANDS:
        module.add_parser(sub)
    # accepted after the sub-command too (`emonav sim --debug`, `emonav eval --quiet`);
    # SUPPRESS keeps the sub-parser from overwriting a flag given before the sub-command
    for parser in sub.choices.values():
        parser.formatter_class = UserHelpFormatter
        parser.add_argument(
            "--debug", action="store_true", default=argparse.SUPPRESS, help=argparse.SUPPRESS
        )
        parser.add_argument(
            "-q", "--quiet", action="store_true", default=argparse.SUPPRESS, help=QUIET_HELP
        )
    for name in PLANNER_MODULE_COMMANDS:
        sub.choices[name].add_argument(
            "--planner-module",
            dest="planner_modules",
            action="append",
            default=[],
            metavar="MODULE",
            help=PLANNER_MODULE_HELP,
        )
    return p


QUIET_HELP = "no progress bars (there are none either when stderr is not a terminal)"
# The sub-commands that build planners by name, and so take `--planner-module`.
PLANNER_MODULE_COMMANDS = (
    "sim",
    "eval",
    "benchmark",
    "train",
    "planners",
    "diagnose",
    "digit-rounds",
)
PLANNER_MODULE_HELP = (
    "a module of your own that registers planners (a .py file or a dotted module name; "
    "repeatable): its planners become names for --planner / --planners and, with train, "
    "for a DAgger or SARL route's expert (docs/howto/planner.md)"
)


def planner_modules_in(argv: list[str]) -> list[str]:
    """The values of every `--planner-module X` / `--planner-module=X` in `argv`: imported
    before the parser is built, so that their planners are valid choices."""
    found = []
    for i, a in enumerate(argv):
        if a == "--planner-module" and i + 1 < len(argv):
            found.append(argv[i + 1])
        elif a.startswith("--planner-module="):
            found.append(a.split("=", 1)[1])
    return found


def package_version() -> str:
    """The installed package's version (`pyproject.toml`), or "unknown" if not installed."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("emonav_drake")
    except PackageNotFoundError:
        return "unknown"


# The longest message printed: a value echoed back (a huge list, a long path) is cut.
MAX_MESSAGE = 500


def _one_line(e: BaseException) -> str:
    """The exception's message on one line (YAML and torch messages can span several), at
    most about `MAX_MESSAGE` characters: a longer one keeps its start and its end (which
    often says what is allowed) and says how much was cut in between."""
    lines = [line.strip() for line in str(e).splitlines() if line.strip()]
    text = "; ".join(lines) or type(e).__name__
    if len(text) <= MAX_MESSAGE:
        return text
    head, tail = MAX_MESSAGE * 3 // 4, MAX_MESSAGE // 5
    cut = len(text) - head - tail
    return f"{text[:head]} … [{cut} characters cut] … {text[-tail:]}"


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


def _parse(parser: argparse.ArgumentParser, argv: list[str]) -> argparse.Namespace:
    """`parser.parse_args(argv)`, but a flag the sub-command does not know is that
    sub-command's error (its usage, the closest flag it has), not the top level's."""
    args, extra = parser.parse_known_args(argv)
    if extra:
        subparsers = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
        subparsers.choices[args.command].error(f"unrecognized arguments: {' '.join(extra)}")
    return args


def main(argv: list[str] | None = None) -> int:
    """Run a sub-command; the one place where exceptions become messages and exit codes.

    0: done. 2: a user error (bad flag, file, field or output path), one line
    `emonav: error: ...`. 130: interrupted (Ctrl-C or SIGTERM), one line. 1: an
    unexpected exception (a bug), one line. `--debug` re-raises instead, with the
    traceback. Argument-syntax errors are argparse's (usage and exit code 2).
    """
    argv = sys.argv[1:] if argv is None else [str(a) for a in argv]
    try:
        from emonav_drake.planners.plugins import import_planner_modules

        import_planner_modules(planner_modules_in(argv))  # their names: valid choices
        args = _parse(build_parser(), argv)
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
    # bars only on a terminal, and not with --quiet: never carriage returns in a pipe or log
    bars = not args.quiet and sys.stderr.isatty()
    try:
        with _sigterm_as_interrupt(), progress.allowed_while(bars):
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
    except BrokenPipeError:  # silently, as other command-line tools; later writes go nowhere
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return EXIT_BROKEN_PIPE
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
