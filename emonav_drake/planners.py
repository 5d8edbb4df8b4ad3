"""Planner registry: one name → one planner object (`systems.navigation_planner.Planner`).

The same objects drive the Drake diagram (`systems.NavigationPlanner`, through the pure
`plan_with_memory(obs, memory)`, the memory living in the Context) and act as policies on
the Gymnasium environment (`planner.plan(env.unwrapped.planner_input())`, the memory kept
on the object, `reset()` between episodes).
"""

from __future__ import annotations

from emonav_drake.params import EmoNavConfig

PLANNERS = ("dwa", "mpc", "sac")


def make_planner(name: str, config: EmoNavConfig, checkpoint=None, device: str = "cpu"):
    """Create the planner called `name`: "dwa", "mpc", or "sac" (a trained policy;
    `checkpoint` defaults to the policy shipped with the package)."""
    if name == "dwa":
        from emonav_drake.core.dwa import DwaPlanner

        return DwaPlanner(config)
    if name == "mpc":
        from emonav_drake.core.mpc import MpcPlanner

        return MpcPlanner(config)
    if name == "sac":
        from emonav_drake.learning.policy import PolicyPlanner

        return PolicyPlanner(checkpoint, device=device)
    raise ValueError(f"unknown planner {name!r}: choose one of {list(PLANNERS)}")


def configure_for(planner, config: EmoNavConfig) -> str:
    """Adapt the diagram's observation settings to a learned policy; return the grid kind.

    A policy checkpoint records the observation it was trained on (grid kind, frames,
    grid size); the LiDAR grid-map builder must produce exactly that.
    """
    expected = getattr(planner, "expected_shape", None)
    if expected is None:
        return "lgm"
    config.lidar.num_frames, config.lidar.grid_size = expected[0], expected[1]
    if planner.grid_kind not in ("lgm", "ogm"):
        raise ValueError(
            f"policy observation {planner.grid_kind!r} is not available in the diagram yet"
        )
    return planner.grid_kind
