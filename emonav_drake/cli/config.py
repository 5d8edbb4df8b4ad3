"""`emonav config`: print the resolved configuration as YAML, or list the shipped settings
and example scenarios.

emonav config [--dump] [--bare] [--setting NAME | --config F] [--time-varying]
emonav config --list

The dump is annotated: each field is followed by its meaning, unit and allowed range as a
YAML comment (the field's own, `config_fields.setting`) and each section is headed by the
first line of its dataclass's docstring; `--bare` prints the YAML without comments. Both
load back (`--config`) to the same configuration.
"""

from __future__ import annotations

import argparse
import sys
import textwrap
from pathlib import Path

from emonav_drake.cli.resolve import (
    add_config_choice,
    add_deployable,
    add_family,
    add_sensor,
    resolve_config,
)
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
        help="print the whole configuration, loadable with --config (the default action); "
        "each field is annotated with its meaning, unit and range as a YAML comment",
    )
    c.add_argument(
        "--bare",
        action="store_true",
        help="print the configuration without the comments (the plain YAML)",
    )
    c.add_argument(
        "--list",
        action="store_true",
        help="list the named settings, example scenarios and scenario families",
    )
    add_config_choice(c)
    add_family(c)
    add_sensor(c)
    add_deployable(c)
    c.add_argument("--time-varying", action="store_true", help=TIME_VARYING_HELP)
    c.set_defaults(func=cmd_config)
    return c


def cmd_config(args: argparse.Namespace) -> int:
    """Print the resolved configuration as YAML (loadable with --config)."""
    from emonav_drake.config_fields import dump_annotated_yaml
    from emonav_drake.params import dump_config

    if args.list:
        given = [
            flag
            for flag, value in (
                ("--dump", args.show),
                ("--bare", args.bare),
                ("--setting", args.setting),
                ("--config", args.config),
                ("--time-varying", args.time_varying),
                ("--family", args.family),
                ("--sensor", args.sensor),
                ("--deployable", args.deployable),
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
    config = resolved.config
    text = dump_config(config) if args.bare else dump_annotated_yaml(config)
    sys.stdout.write(f"# emonav configuration: {resolved.source}\n{text}")
    return 0


LIST_WIDTH = 96  # `config --list` wraps its descriptions to this many columns


def _list_examples() -> str:
    """The named settings and example scenarios shipped with the package, one per line."""
    from emonav_drake.configs import SETTINGS, setting_path
    from emonav_drake.scenarios import EXAMPLES, SCENARIO_DIR
    from emonav_drake.scenarios.scenario_families import FAMILIES

    def first_sentence(path: Path) -> str:
        """The first sentence of the file's leading comment (it may span lines)."""
        words = []
        for line in path.read_text().splitlines():
            if not line.startswith("#"):
                break
            words.append(line.lstrip("# ").strip())
        text = " ".join(w for w in words if w)
        end = text.find(". ")
        return text if end < 0 else text[: end + 1]

    def entry(name: str, width: int, text: str) -> list[str]:
        indent = " " * (2 + width + 1)
        return textwrap.wrap(
            text, LIST_WIDTH, initial_indent=f"  {name:{width}s} ", subsequent_indent=indent
        )

    lines = ["settings (--setting NAME):"]
    for n in SETTINGS:
        lines += entry(n, 14, first_sentence(setting_path(n)))
    lines.append("example scenarios (emonav sim --scenario NAME):")
    for n in EXAMPLES:
        lines += entry(n, 14, first_sentence(SCENARIO_DIR / f"{n}.yaml"))
    lines.append("scenario families (--family NAME; each seed samples one scene):")
    for f in FAMILIES.values():
        lines += entry(f.name, 24, f.summary)
    return "\n".join(lines) + "\n"
