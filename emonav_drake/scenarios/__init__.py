"""Example scenarios shipped with the package (hand-written `Scenario` YAML files).

`emonav sim --scenario NAME` runs one by name (or any file by its path); `emonav config
--list` lists them. The fields are those of `scenarios.scenario.Scenario` (world frame, metres,
radians; emotions happy | neutral | negative); see docs/scenarios.md.

| name | what it tests |
|---|---|
| `head_on` | one negative pedestrian walking straight at the robot, a disc beside the path |
| `crossing` | three pedestrians (happy, neutral, negative) crossing the robot's path |
| `mood_swing` | one pedestrian whose emotion changes every 2 s (the paper's §IV-F) |
| `hallway` | walls, a group walking at the robot, a blocker from a doorway, a slow walker |
| `closed_door` | two rooms; a cart closes the robot's door at 3 s (the global route replans) |

The scenario families (`--family`, docs/scenarios.md) sample scenes of these kinds by seed.
"""

from __future__ import annotations

from pathlib import Path

from emonav_drake.atomic_io import SYMLINK_LOOP, is_symlink_loop
from emonav_drake.params import ConfigError

SCENARIO_DIR = Path(__file__).resolve().parent
EXAMPLES = ("head_on", "crossing", "mood_swing", "hallway", "closed_door")


def scenario_path(name_or_path: str | Path) -> Path:
    """The file of a scenario given by path, or by the name of a shipped example.

    An existing file wins; otherwise a shipped example's name; otherwise `ConfigError`
    naming the examples."""
    p = Path(name_or_path)
    if p.is_file():
        return p
    if str(name_or_path) in EXAMPLES:
        return SCENARIO_DIR / f"{name_or_path}.yaml"
    if is_symlink_loop(p):
        raise ConfigError(f"--scenario {name_or_path}: {SYMLINK_LOOP}")
    raise ConfigError(
        f"--scenario {name_or_path}: no such file, and not a shipped example "
        f"({', '.join(EXAMPLES)})"
    )
