"""Planner registry: one name → one planner object with `reset()` and `plan(PlannerInput)`.

The same objects drive the Drake diagram (`systems.NavigationPlanner`) and act as
policies on the Gymnasium environment (`planner.plan(env.unwrapped.planner_input())`).
"""

from __future__ import annotations

from emonav_drake.params import EmoNavConfig

PLANNERS = ("dwa", "mpc", "sac")


def make_planner(name: str, config: EmoNavConfig, **kwargs):
    """Create the planner called `name` ("dwa"; "mpc" and "sac" once built)."""
    if name == "dwa":
        from emonav_drake.core.dwa import DwaPlanner

        return DwaPlanner(config)
    if name in PLANNERS:
        raise NotImplementedError(
            f"planner {name!r} is not available yet in this version; available: ['dwa']"
        )
    raise ValueError(f"unknown planner {name!r}: choose one of {list(PLANNERS)}")
