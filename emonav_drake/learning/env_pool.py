"""The SAC trainer's environments: `num_envs` copies stepped together, here or on Ray.

SAC on the full-order Digit is bound by simulation (≈ 0.2 s of CPU per environment step),
so the trainer steps `SacConfig.num_envs` environments at once; on Ray each one lives in
its own actor (a local Ray, or a cluster by address), so the steps of one iteration run in
parallel. Both pools hold the same environments and are driven in the same order, and
every environment is deterministic given its seed and actions: a Ray run equals the
serial one bit for bit (tested). An environment's state (`state_dict`, for the trainer's
checkpoint) comes back from its actor as plain data.
"""

from __future__ import annotations

import contextlib
import dataclasses as dc
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from emonav_drake.learning.config_common import with_run_world
from emonav_drake.learning.env import EmoNavLIPEnv
from emonav_drake.learning.sac_config import SacConfig
from emonav_drake.parallel import Worker, init_ray, ray_get, start_actors
from emonav_drake.params import ConfigError, EmoNavConfig

if TYPE_CHECKING:
    from emonav_drake.learning.digit_env import EmoNavDigitEnv

StepResult = tuple[dict, float, bool, bool, dict]


def _digit_env_class() -> type:
    from emonav_drake.learning.digit_env import EmoNavDigitEnv

    return EmoNavDigitEnv


# The training environment class of each plant (`SacConfig.plant`), by plant name; a
# function giving the class, so that Digit's Drake environment is imported on first use.
ENV_CLASSES: dict[str, Callable[[], type]] = {
    "lip": lambda: EmoNavLIPEnv,
    "digit": _digit_env_class,
}


def env_class_for(plant: str) -> type:
    """The Gymnasium environment class of `plant`; `ConfigError` for a plant without one."""
    if plant not in ENV_CLASSES:
        raise ConfigError(
            f"plant {plant!r} has no training environment: choose {' or '.join(ENV_CLASSES)}"
        )
    return ENV_CLASSES[plant]()


def make_env(
    cfg: SacConfig, env_cfg: EmoNavConfig | None = None, goal_radius: float | None = None
) -> EmoNavLIPEnv | EmoNavDigitEnv:
    """The training environment of `cfg.plant` (`EmoNavLIP-v0` or `EmoNavDigit-v0`) for
    the configured observation variant."""
    env_cfg = with_run_world(env_cfg or EmoNavConfig(), cfg)
    env_cfg.lidar.num_frames = cfg.num_frames
    env_cfg.lidar.grid_size = cfg.grid_size
    env_class = env_class_for(cfg.plant)
    return env_class(
        env_cfg,
        grid_kind=cfg.grid_kind,
        goal_radius=cfg.goal_radius if goal_radius is None else goal_radius,
    )


def _make(cfg_plain: dict, goal_radius: float | None):
    return make_env(SacConfig(**cfg_plain), goal_radius=goal_radius)


class LocalEnvs:
    """`n` training environments in this process, stepped one after the other."""

    def __init__(self, cfg: SacConfig, n: int, goal_radius: float | None = None) -> None:
        self.envs = [_make(dc.asdict(cfg), goal_radius) for _ in range(n)]
        # the spaces, map key and robot limits of the (identical) environments
        self.spec = self.envs[0]

    def __len__(self) -> int:
        return len(self.envs)

    def reset(self, i: int, seed: int) -> dict:
        return self.envs[i].reset(seed=seed)[0]

    def step(self, commands: Sequence[np.ndarray]) -> list[StepResult]:
        return [e.step(c) for e, c in zip(self.envs, commands, strict=True)]

    def state_dicts(self) -> list[dict]:
        return [e.state_dict() for e in self.envs]

    def load_state_dicts(self, states: Sequence[dict]) -> None:
        if len(states) != len(self.envs):
            raise ValueError(f"{len(states)} saved environments for {len(self.envs)}")
        for e, st in zip(self.envs, states, strict=True):
            e.load_state_dict(st)

    def close(self) -> None:
        """Nothing to release."""


class _EnvActor(Worker):
    """One training environment in a Ray actor."""

    def __init__(self, cfg_plain: dict, goal_radius: float | None) -> None:
        super().__init__()
        self.env = _make(cfg_plain, goal_radius)

    def reset(self, seed: int) -> dict:
        return self.env.reset(seed=seed)[0]

    def step(self, command: np.ndarray) -> StepResult:
        return self.env.step(command)

    def state_dict(self) -> dict:
        return self.env.state_dict()

    def load_state_dict(self, state: dict) -> None:
        self.env.load_state_dict(state)


class RayEnvs:
    """`n` training environments, one per Ray actor (one CPU each), stepped in parallel.

    Args:
        address: a Ray cluster's address ("auto", "HOST:6379"); None starts a local Ray
            with `n` CPUs.
    Raises:
        ConfigError: ray is missing, or an actor runs other emonav_drake code.
    """

    def __init__(
        self,
        cfg: SacConfig,
        n: int,
        goal_radius: float | None = None,
        address: str | None = None,
    ) -> None:
        self.ray = init_ray(n, address)
        plain = dc.asdict(cfg)
        self.actors = start_actors(self.ray, _EnvActor, n, (plain, goal_radius))
        self.spec = _make(plain, goal_radius)  # spaces and limits (never stepped)

    def __len__(self) -> int:
        return len(self.actors)

    def _get(self, refs: list[Any]) -> list[Any]:
        return ray_get(self.ray, refs)

    def reset(self, i: int, seed: int) -> dict:
        return _writable(self._get([self.actors[i].reset.remote(seed)])[0])

    def step(self, commands: Sequence[np.ndarray]) -> list[StepResult]:
        refs = [a.step.remote(c) for a, c in zip(self.actors, commands, strict=True)]
        return [(_writable(r[0]), *r[1:]) for r in self._get(refs)]

    def state_dicts(self) -> list[dict]:
        return self._get([a.state_dict.remote() for a in self.actors])

    def load_state_dicts(self, states: Sequence[dict]) -> None:
        if len(states) != len(self.actors):
            raise ValueError(f"{len(states)} saved environments for {len(self.actors)}")
        self._get([a.load_state_dict.remote(st) for a, st in zip(self.actors, states, strict=True)])

    def close(self) -> None:
        with contextlib.suppress(Exception):
            self.ray.shutdown()


def _writable(obs: dict) -> dict:
    """Ray hands out read-only views of the object store; the trainer keeps its own copy."""
    return {k: np.array(v) for k, v in obs.items()}


EnvPool = LocalEnvs | RayEnvs  # one interface: len, reset, step, state_dicts, close


def make_envs(cfg: SacConfig, ray_address: str | None = None, parallel: bool = True) -> EnvPool:
    """The trainer's `cfg.num_envs` environments: on the Ray cluster at `ray_address`, or
    on a local Ray when there are several and `parallel`, else in this process."""
    if ray_address or (cfg.num_envs > 1 and parallel):
        return RayEnvs(cfg, cfg.num_envs, address=ray_address)
    return LocalEnvs(cfg, cfg.num_envs)
