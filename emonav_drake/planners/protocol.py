"""What the navigation diagram and the Gymnasium env need of a planner (`Planner`)."""

from __future__ import annotations

from typing import Any, Protocol

import numpy as np

from emonav_drake.navigation.lip_world import PlannerInput


class Planner(Protocol):
    """What the navigation diagram and the Gymnasium env need of a planner.

    The diagram uses the pure pair `initial_memory()` / `plan_with_memory(obs, memory)`:
    a planning step is a function of (planner input, memory) that returns the command and
    the next memory without modifying its argument. The env, DAgger and scripts use the
    stateful pair `plan(obs)` / `reset()`, which keeps one memory on the object
    (`command, self._memory = self.plan_with_memory(obs, self._memory)`). A pure function
    rather than `get_memory()` / `set_memory()` on the object: the Drake event then never
    depends on what the object last planned (a cloned Context, two simulations sharing the
    planner, or an exception between a restore and a save cannot leak memory from one
    context into another), the object's own memory is only the convenience of `plan`, and
    `plan(obs)` keeps working unchanged. Memoryless planners (DWA, replay, policies)
    return None as their memory.
    """

    name: str
    # Learned policies also declare the map observation they read:
    #   grid_kind: "lgm", "ogm", "scan" or "drlvo"; expected_shape / expected_dtype: the
    #   stack the diagram's `LidarGridMapBuilder` must produce (`planners.configure_for`).
    # Planners without them read the privileged crowd state (`PlannerInput.crowd`).

    def initial_memory(self) -> Any:
        """The memory at the start of an episode (copyable with `copy.deepcopy`)."""
        ...

    def plan_with_memory(self, obs: PlannerInput, memory: Any) -> tuple[np.ndarray, Any]:
        """(u_v [m/s], u_Δθ [rad]) for this walking step and the memory for the next one;
        `memory` is not modified."""
        ...

    def reset(self) -> None:
        """Back to `initial_memory()` for `plan` (a new episode)."""
        ...

    def plan(self, obs: PlannerInput) -> np.ndarray:
        """`plan_with_memory` with the memory kept on the object."""
        ...
