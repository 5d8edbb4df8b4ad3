"""The paper's evaluation settings as named configuration files (package data).

Each `<name>.yaml` beside this file is an ordinary `EmoNavConfig` override, loadable with
`params.load_config(setting_path(name))` (or `load_setting(name)`); the command line takes
them as `--setting NAME` (`emonav benchmark`, `emonav config --show`).

| name | what (paper) |
|---|---|
| `no_emotion` | constant discomfort distance 0.2 m for every emotion (Tables II, III "0.2 m") |
| `constant_0.5` | constant 0.5 m for every emotion (Table III "0.5 m") |
| `var_dd` | by emotion: happy 0.2, neutral 0.35, negative 0.5 m — the defaults (Var-DD) |
| `time_varying` | `var_dd` + one pedestrian's emotion changing every 2 s (§IV-F) |
"""

from __future__ import annotations

from pathlib import Path

from emonav_drake.params import ConfigError, EmoNavConfig, load_config

CONFIG_DIR = Path(__file__).resolve().parent
SETTINGS = ("no_emotion", "constant_0.5", "var_dd", "time_varying")


def setting_path(name: str) -> Path:
    """The YAML file of the named setting; `ConfigError` naming the choices if unknown."""
    if name not in SETTINGS:
        raise ConfigError(
            f"--setting {name!r}: unknown setting; choose one of {', '.join(SETTINGS)}"
        )
    return CONFIG_DIR / f"{name}.yaml"


def load_setting(name: str) -> EmoNavConfig:
    """The defaults overridden by the named setting, validated."""
    return load_config(setting_path(name))
