"""The paper's learned methods by name: observation variant, training route, shipped policy.

Every variant differs from EmoBipedNav by its observation only and is trained by the same
CPU route with the same budget (`learning/dagger.py`; the DWA expert round and 10 DAgger
rounds, each round evaluated on the selection seeds 600 000 … 600 199 and the best kept).
The route's settings are the YAML files in `emonav_drake/configs/variants/`
(`DaggerConfig` fields); `emonav train --variant NAME` runs it. A trained policy ships as
`emonav_drake/data/policies/NAME.pt` (EmoBipedNav: `data/policy_lgm.pt`) and is then a
planner name of `emonav sim|eval|benchmark` (`--planner NAME`, `--planners NAME,…`).

| name | paper | observation |
|---|---|---|
| `emobipednav` | EmoBipedNav | 9 LiDAR grid maps (trained in the LIP world) |
| `single_lgm` | Single-LGM | 1 LiDAR grid map |
| `ogm` | OGM | 9 Cartesian occupancy grids |
| `lidar_sac` | LiDAR-SAC | 9 raw scans, 1-D CNN |
| `lndnl` | LNDNL | 9 raw scans, LSTM |
| `drlvo` | DRL-VO* | scan OGM + pedestrian velocity maps (1 image) |
| `emobipednav_digit` | EmoBipedNav, Digit/Digit | 9 LGMs; trained with Digit's dynamics |
| `emobipednav_digit_mpc` | EmoBipedNav, Digit/Digit | the same, the MPC as teacher |
| `emobipednav_distilled` | (ours) | the same, its own LGM shield distilled in |
| `emobipednav_guide` | (ours) | the same route; goal bearing of a guide sub-goal |
| `emobipednav_dd02` | Table III, DD 0.2 m | the same route, trained with 0.2 m for every emotion |
| `emobipednav_dd05` | Table III, DD 0.5 m | the same route, trained with 0.5 m for every emotion |
| `emobipednav_mixed` | (ours) | the MPC route trained on the `mixed` scenario family |

`emobipednav_digit` and `emobipednav_digit_mpc` differ by their training world, not its
observation: the LIP-trained policy fine-tuned in the Digit-calibrated reduced world
(`robot/step_response.py`, `learning/calibration.py`). `emobipednav_distilled` continues
`emobipednav_digit_mpc` with that policy behind its LGM shield as the teacher (soft labels;
the same observation); its Digit rounds' round 2 (`emonav digit-rounds`, not a variant:
`data/policies/emobipednav_distilled_digit.pt`) is the default `--planner policy`.
`emobipednav_guide` is the
MPC route with `goal_input: guide`
(`navigation/goal_input.py`): a deviation from the paper's observation, measured against it.
`emobipednav_dd02` and `emobipednav_dd05` are its route trained in the constant settings
`no_emotion` and `constant_0.5` (`DaggerConfig.setting`), Table III's first two rows.
`emobipednav_mixed` is `emobipednav_digit_mpc`'s route on the `mixed` scenario family
(`DaggerConfig.family`; corridors, walls, standing and grouped pedestrians beside the
paper's arena), measured against that route on the paper's arena alone.
"""

from __future__ import annotations

import dataclasses as dc
from pathlib import Path

from emonav_drake.params import ConfigError

_PACKAGE = Path(__file__).resolve().parent.parent
CONFIG_DIR = _PACKAGE / "configs" / "variants"
POLICY_DIR = _PACKAGE / "data" / "policies"


@dc.dataclass(frozen=True)
class PolicyVariant:
    """One learned method of the paper.

    Attributes:
        name: the registry name (planner name on the command line).
        paper: the method's name in the paper's Table II.
        observation: what the policy sees, in words.
        checkpoint_file: the shipped policy file, relative to the package's `data/`.
        route: "lip" (trained on the LIP world, the paper's LIP/·) or "digit" (trained
            with Digit's dynamics through the calibrated world, Digit/Digit).
    """

    name: str
    paper: str
    observation: str
    checkpoint_file: str
    route: str = "lip"  # the world it was trained in: "lip" or "digit" (calibrated)

    @property
    def config(self) -> Path:
        """The route's `DaggerConfig` YAML."""
        return CONFIG_DIR / f"{self.name}.yaml"

    @property
    def checkpoint(self) -> Path:
        """Where the shipped policy is (it may not be shipped yet: `is_shipped`)."""
        return _PACKAGE / "data" / self.checkpoint_file

    @property
    def is_shipped(self) -> bool:
        return self.checkpoint.is_file()


VARIANTS: dict[str, PolicyVariant] = {
    v.name: v
    for v in (
        PolicyVariant("emobipednav", "EmoBipedNav", "9 LiDAR grid maps", "policy_lgm.pt"),
        PolicyVariant("single_lgm", "Single-LGM", "1 LiDAR grid map", "policies/single_lgm.pt"),
        PolicyVariant("ogm", "OGM", "9 Cartesian occupancy grids", "policies/ogm.pt"),
        PolicyVariant("lidar_sac", "LiDAR-SAC", "9 raw scans, 1-D CNN", "policies/lidar_sac.pt"),
        PolicyVariant("lndnl", "LNDNL", "9 raw scans, LSTM", "policies/lndnl.pt"),
        PolicyVariant(
            "drlvo", "DRL-VO*", "scan OGM + pedestrian velocity maps", "policies/drlvo.pt"
        ),
        PolicyVariant(
            "emobipednav_digit",
            "EmoBipedNav (Digit/Digit)",
            "9 LiDAR grid maps; trained with Digit's step response",
            "policies/emobipednav_digit.pt",
            route="digit",
        ),
        PolicyVariant(
            "emobipednav_digit_mpc",
            "EmoBipedNav (Digit/Digit, MPC teacher)",
            "9 LiDAR grid maps; trained with Digit's step response, labelled by the MPC",
            "policies/emobipednav_digit_mpc.pt",
            route="digit",
        ),
        PolicyVariant(
            "emobipednav_distilled",
            "EmoBipedNav (Digit/Digit), its LGM shield distilled in (not in the paper)",
            "9 LiDAR grid maps; trained with Digit's step response, labelled by its shield",
            "policies/emobipednav_distilled.pt",
            route="digit",
        ),
        PolicyVariant(
            "emobipednav_guide",
            "EmoBipedNav + guide sub-goal (Digit/Digit, MPC teacher; not in the paper)",
            "9 LiDAR grid maps; the goal bearing of a sub-goal around the static discs",
            "policies/emobipednav_guide.pt",
            route="digit",
        ),
        PolicyVariant(
            "emobipednav_dd02",
            "EmoBipedNav, DD 0.2 m (Digit/Digit; Table III)",
            "9 LiDAR grid maps; trained with one discomfort distance, 0.2 m",
            "policies/emobipednav_dd02.pt",
            route="digit",
        ),
        PolicyVariant(
            "emobipednav_dd05",
            "EmoBipedNav, DD 0.5 m (Digit/Digit; Table III)",
            "9 LiDAR grid maps; trained with one discomfort distance, 0.5 m",
            "policies/emobipednav_dd05.pt",
            route="digit",
        ),
        PolicyVariant(
            "emobipednav_mixed",
            "EmoBipedNav (Digit/Digit, MPC teacher) on the scenario families (not in the paper)",
            "9 LiDAR grid maps; trained with Digit's step response on the mixed family",
            "policies/emobipednav_mixed.pt",
            route="digit",
        ),
    )
}


def variant(name: str) -> PolicyVariant:
    """The variant called `name`; `ConfigError` listing the names otherwise."""
    if name not in VARIANTS:
        raise ConfigError(f"unknown variant {name!r}: choose one of {', '.join(VARIANTS)}")
    return VARIANTS[name]


def resolve_policy_file(spec: str, label: str = "init policy") -> Path:
    """The file of a policy a route starts from: "shipped" (the LIP-trained LGM policy,
    variant `emobipednav`), a shipped variant's name (e.g. "single_lgm", unless a file of
    that name exists), or a path. `ConfigError` starting with `label` for a variant that
    has no shipped policy."""
    if spec == "shipped":
        return VARIANTS["emobipednav"].checkpoint
    path = Path(spec)
    if not path.exists() and spec in VARIANTS:
        v = VARIANTS[spec]
        if not v.is_shipped:
            raise ConfigError(
                f"{label} {spec}: {v.paper} has no shipped policy in this version; train it "
                f"(`emonav train --variant {spec} --out runs/{spec}`) and pass "
                f"runs/{spec}/policy.pt"
            )
        return v.checkpoint
    return path


def shipped_checkpoint(name: str) -> Path:
    """The shipped policy of variant `name`; `ConfigError` saying how to train it if absent."""
    v = variant(name)
    if not v.is_shipped:
        raise ConfigError(
            f"{name} ({v.paper}) has no shipped policy in this version: train it with "
            f"`emonav train --variant {name} --out runs/{name}` and pass "
            f"--checkpoint runs/{name}/policy.pt"
        )
    return v.checkpoint
