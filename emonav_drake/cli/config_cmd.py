"""`emonav config`: print the resolved configuration as YAML, or list the shipped settings
and example scenarios.

emonav config [--dump] [--setting NAME | --config F] [--time-varying]
emonav config --list
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from emonav_drake.cli.config import add_config_choice, resolve_config
from emonav_drake.params import ConfigError

TIME_VARYING_HELP = "one pedestrian's emotion changes every 2 s (paper §IV-F)"


def add_parser(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Register `emonav config` on the CLI's sub-parsers."""
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
    add_config_choice(c)
    c.add_argument("--time-varying", action="store_true", help=TIME_VARYING_HELP)
    c.set_defaults(func=cmd_config)
    return c


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
    resolved = resolve_config(args)
    sys.stdout.write(f"# emonav configuration: {resolved.source}\n{dump_config(resolved.config)}")
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
