"""The settings of the DAgger rounds on the full-order Digit (`emonav digit-rounds`,
`learning/digit_dagger.py`): rounds, episodes and their seeds, the expert's acting
probability, gradient steps and the Digit share of every batch, and the labelling expert
(the calibrated run's, a planner spec). `validate` names the command-line flag of a value
out of range.
"""

from __future__ import annotations

import dataclasses as dc

from emonav_drake.config_fields import setting
from emonav_drake.params import ConfigError
from emonav_drake.planners.specs import ExpertSpec, describe_spec


@dc.dataclass
class DigitRoundsConfig:
    """Settings of the Digit rounds (the command line's)."""

    rounds: int = setting(2, "DAgger rounds on Digit (--rounds)")
    episodes: int = setting(60, "Digit episodes per round (--episodes)")
    first_seed: int = setting(4_000_000, "the rounds' seeds start here (--first-seed)")
    beta: float = setting(
        0.25, "the expert acts with this probability in round 1, halved every round (--beta)"
    )
    grad_steps: int = setting(1500, "gradient steps after each round (--grad-steps)")
    batch_size: int = setting(64, "labelled states per gradient step")
    digit_fraction: float = setting(0.5, "the share of every batch drawn from Digit samples")
    seed: int = setting(0, "the rounds' seed (sampling, network updates)")
    expert: ExpertSpec | None = setting(
        None,
        "the labelling expert, a planner spec (`planners/specs.py`): `run_digit_rounds` sets "
        "it to the calibrated run's (`DaggerConfig.teacher()`), so both kinds of "
        "demonstrations have one teacher; None until then",
    )
    planner_modules: list[str] = setting(
        [],
        "the calibrated run's planner modules from outside the package: every worker imports "
        "them, so an expert of the user's own labels on Digit too",
    )

    def validate(self) -> DigitRoundsConfig:
        """Raise `ConfigError` naming the flag (or field) of a value out of range."""
        from emonav_drake.diagrams.trials import MAX_TRIALS
        from emonav_drake.scenarios.scenario import MAX_SEED

        for name in ("rounds", "episodes", "grad_steps", "batch_size"):
            value = getattr(self, name)
            if not (isinstance(value, int) and value >= 1):
                raise ConfigError(f"{_flag(name)} {value}: must be an integer >= 1")
        if self.episodes > MAX_TRIALS:
            raise ConfigError(f"--episodes {self.episodes}: must be in [1, {MAX_TRIALS}]")
        if not 0.0 <= self.beta <= 1.0:
            raise ConfigError(f"--beta {self.beta}: must be in [0, 1] (a probability)")
        if not 0.0 < self.digit_fraction <= 1.0:
            raise ConfigError(f"digit_fraction = {self.digit_fraction}: must be in (0, 1]")
        if not 0 <= self.seed <= MAX_SEED:
            raise ConfigError(f"seed = {self.seed}: must be in [0, 2**64 - 1]")
        last = self.first_seed + self.rounds * self.episodes - 1
        if self.first_seed < 0 or last > MAX_SEED:
            raise ConfigError(
                f"--first-seed {self.first_seed}: the rounds' seeds {self.first_seed} … {last} "
                "must be in [0, 2**64 - 1]"
            )
        return self


def rounds_plain(cfg: DigitRoundsConfig) -> dict:
    """The rounds' settings as plain data (the expert as its YAML form, `describe_spec`)."""
    return dc.asdict(cfg) | {"expert": describe_spec(cfg.expert)}


def _flag(name: str) -> str:
    """The command-line flag of a `DigitRoundsConfig` field (the field if it has none)."""
    return "--" + name.replace("_", "-") if name != "batch_size" else "batch_size ="
