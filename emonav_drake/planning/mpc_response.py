"""The MPC's horizon walked by a fitted step-response model instead of the LIP.

`ResponseHorizonModel` is `HorizonModel` (`planning/mpc_model.py`) with one change: the
positions of a plan come from `StepResponseModel.predict` (`robot/step_response.py`) step
after step — the commands already sent, u_{k−2} and u_{k−1}, first, the robot's
step-averaged speed v̄ as the state — rather than from the LIP step map of paper Eq. 1.
The response model is linear in the commands but the heading it accumulates rotates the
steps, so the Jacobian of the step-end positions is taken by forward differences of one
batched rollout (2N + 1 plans). Everything else (obstacles, seeds, costs, QP) is the
LIP MPC's. `planners.mpc.MpcPlanner(config, response=model)` plans with it.

Frame and units as in `planning/mpc_model.py`: world frame, [m], [m/s], [rad].
"""

from __future__ import annotations

import copy

import numpy as np

from emonav_drake.params import EmoNavConfig
from emonav_drake.planning.mpc_model import HorizonModel
from emonav_drake.robot.step_response import LAGS, StepResponseModel

_FD_STEP = 1e-6  # forward-difference step of the Jacobian [m/s] or [rad]


class ResponseHorizonModel(HorizonModel):
    """`HorizonModel` whose rollout is the expected walk of a step-response model.

    Args:
        config: as `HorizonModel`.
        response: the fitted step-response model (e.g. the shipped Digit model).
        committed: (2, 2) the commands already sent, u_{k−2} and u_{k−1}; a planning
            step sets them with `with_committed`.
    """

    def __init__(
        self,
        config: EmoNavConfig,
        response: StepResponseModel,
        committed: np.ndarray | None = None,
    ) -> None:
        super().__init__(config)
        self.response = response
        self.committed = np.zeros((LAGS - 1, 2)) if committed is None else committed

    def with_committed(self, committed: np.ndarray) -> ResponseHorizonModel:
        """A shallow copy with the commands already sent (2, 2) = (u_{k−2}, u_{k−1})."""
        view = copy.copy(self)
        view.committed = np.asarray(committed, dtype=float).reshape(LAGS - 1, 2)
        return view

    def rollout(
        self, p0: np.ndarray, th0: float, v0: float, u: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Expected step ends of plans u (B, N, 2) from the CoM p0 (2,) [m], heading th0
        [rad] and step-averaged speed v0 [m/s]: positions (B, N, 2), the heading after
        each step (B, N) and each step's displacement length (B, N)."""
        u = np.asarray(u, dtype=float)
        b, n = u.shape[:2]
        hist = np.broadcast_to(self.committed, (b, LAGS - 1, 2))
        pos, heading, length = np.empty((b, n, 2)), np.empty((b, n)), np.empty((b, n))
        xy = np.broadcast_to(np.asarray(p0, dtype=float), (b, 2)).copy()
        th, v = np.full(b, float(th0)), np.full(b, float(v0))
        for k in range(n):
            cmds = np.concatenate([hist, u[:, k, None, :]], axis=1)
            y = self.response.predict(v, cmds)  # forward, lateral, turn, next speed
            c, s = np.cos(th), np.sin(th)
            step = np.stack([c * y[:, 0] - s * y[:, 1], s * y[:, 0] + c * y[:, 1]], axis=-1)
            xy = xy + step
            pos[:, k] = xy
            length[:, k] = np.hypot(step[:, 0], step[:, 1])
            th, v, hist = th + y[:, 2], np.maximum(y[:, 3], 0.0), cmds[:, 1:]
            heading[:, k] = th
        return pos, heading, length

    def positions_and_jacobian(
        self, p0: np.ndarray, th0: float, v0: float, u: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Step-end positions (N, 2) of one plan u (N, 2) and ∂p_{k+1}/∂u (N, 2N, 2),
        columns u_v,0…N−1 then u_Δθ,0…N−1, by forward differences."""
        n = self.horizon
        plans = np.repeat(np.asarray(u, dtype=float)[None], 2 * n + 1, axis=0)
        j = np.arange(n)
        plans[1 + j, j, 0] += _FD_STEP
        plans[1 + n + j, j, 1] += _FD_STEP
        pos = self.rollout(p0, th0, v0, plans)[0]  # (2N + 1, N, 2)
        jac = (pos[1:] - pos[0]) / _FD_STEP  # (2N, N, 2)
        return pos[0], jac.transpose(1, 0, 2)
