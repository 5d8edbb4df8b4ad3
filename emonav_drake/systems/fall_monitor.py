"""`FallMonitor`: the one fall check of the full-order Digit, at a fixed rate.

Input ports:
    state (nq + nv): the Digit plant state (q, v).
    geometry_query (abstract `QueryObject`): the scene graph's query object; the check
        asks it for the point pairs in penetration (geometry, not the contact solver's
        results, so a touch is seen in any state, including a context set by hand).
Output port:
    fall (abstract `FallStatus`): whether the robot has fallen, when [s] and why. Latched:
        once fallen it stays fallen.
Abstract state: the `FallStatus`, updated by a periodic unrestricted event every
`walking.fall_check_period` (default 5 ms, 200 Hz) from t = 0.

A fall is, in this order of checking: a non-finite plant state; the torso origin below
`walking.fall_height` [m]; or any body but a foot touching the ground (a knee, a shin,
the torso, an arm — any collision geometry of a non-foot body penetrating the ground's).
It is an outcome, never an
exception: the check that detects it ends the simulation (a `ReachedTermination` event
status, so `AdvanceTo` returns at the fall, at no per-step cost), and the walking and
navigation run loops report the outcome "fall".
"""

from __future__ import annotations

import dataclasses as dc
import math

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.geometry import QueryObject
from pydrake.multibody.tree import BodyIndex
from pydrake.systems.framework import Context, EventStatus, LeafSystem, State

from emonav_drake.navigation.metrics import FALL
from emonav_drake.params import WalkingParams
from emonav_drake.systems.digit_plant import DigitModel

__all__ = ["FALL", "FallMonitor", "FallStatus"]


@dc.dataclass(frozen=True)
class FallStatus:
    """Whether and how the robot fell.

    Attributes:
        fallen: True once a fall was detected.
        time: detection time [s] (NaN while standing).
        reason: e.g. "left_shin touched the ground", "torso at 0.512 m", "non-finite
            state" ("" while standing).
    """

    fallen: bool = False
    time: float = math.nan
    reason: str = ""

    # Immutable: Drake copies a system's abstract state twice at each of its unrestricted
    # updates (the fall check's, every few milliseconds); a copy is the object itself
    # (a generic deep copy of a frozen dataclass cost ~3 % of a Digit episode's wall time).
    def __copy__(self) -> FallStatus:
        return self

    def __deepcopy__(self, memo: dict) -> FallStatus:
        return self


class FallMonitor(LeafSystem):
    """Checks the Digit plant for a fall (see the module docstring).

    Args:
        model: the Digit plant and its index maps (torso height index, non-foot bodies).
        params: `fall_height` [m] and `fall_check_period` [s].
        terminate: end the simulation at the check that detects the fall (the event
            returns `EventStatus.ReachedTermination`, so `Simulator.AdvanceTo` returns
            early); False keeps simulating the fallen robot.
    """

    def __init__(self, model: DigitModel, params: WalkingParams, terminate: bool = True) -> None:
        super().__init__()
        self._terminate = terminate
        plant = model.plant
        self._plant = plant
        self._torso_z = int(model.base_q[6])
        self._fall_height = params.fall_height
        # collision geometries of the non-foot bodies (→ body name) and of the ground
        self._non_foot = {
            gid: plant.get_body(BodyIndex(i)).name()
            for i in sorted(model.non_foot_bodies)
            for gid in plant.GetCollisionGeometriesForBody(plant.get_body(BodyIndex(i)))
        }
        self._ground = frozenset(plant.GetCollisionGeometriesForBody(plant.world_body()))
        nx = plant.num_positions() + plant.num_velocities()
        self._state_in = self.DeclareVectorInputPort("state", nx)
        self._query_in = self.DeclareAbstractInputPort(
            "geometry_query", AbstractValue.Make(QueryObject())
        )
        self._status = self.DeclareAbstractState(AbstractValue.Make(FallStatus()))
        self.DeclareStateOutputPort("fall", self._status)
        self.DeclarePeriodicUnrestrictedUpdateEvent(params.fall_check_period, 0.0, self._check)

    def fall_reason(self, context: Context) -> str:
        """Why the robot in `context` counts as fallen now ("" if it does not)."""
        x = self._state_in.Eval(context)
        if not np.all(np.isfinite(x)):
            return "non-finite state"
        z = float(x[self._torso_z])
        if z < self._fall_height:
            return f"torso at {z:.3f} m"
        for pair in self._query_in.Eval(context).ComputePointPairPenetration():
            for mine, other in ((pair.id_A, pair.id_B), (pair.id_B, pair.id_A)):
                if other in self._ground and mine in self._non_foot:
                    return f"{self._non_foot[mine]} touched the ground"
        return ""

    def _check(self, context: Context, state: State) -> EventStatus:
        if context.get_abstract_state(self._status).get_value().fallen:
            return EventStatus.Succeeded()
        reason = self.fall_reason(context)
        if not reason:
            return EventStatus.Succeeded()
        state.get_mutable_abstract_state(self._status).set_value(
            FallStatus(True, context.get_time(), reason)
        )
        if self._terminate:
            return EventStatus.ReachedTermination(self, f"fall: {reason}")
        return EventStatus.Succeeded()
