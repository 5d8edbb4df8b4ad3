"""The map observation a navigation diagram gives its planner, step by step."""

from __future__ import annotations

import numpy as np
from pydrake.systems.analysis import Simulator


def diagram_stacks(nav, step_time: float, steps: int) -> list[np.ndarray]:
    """The grid-map builder's `lgm_stack` at t_k = k·`step_time`, k = 0 … `steps` − 1,
    before the updates at t_k (what the planner reads then), of `nav`
    (`build_navigation_diagram`'s result)."""
    sim = Simulator(nav.diagram)
    sim.Initialize()
    ctx = sim.get_mutable_context()
    port = nav.grid_maps.GetOutputPort("lgm_stack")
    out = []
    for k in range(steps):
        if k > 0:
            sim.AdvanceTo(k * step_time)
        out.append(np.array(port.Eval(nav.grid_maps.GetMyContextFromRoot(ctx))))
    return out
