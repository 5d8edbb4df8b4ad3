"""A learned policy's distribution restricted to the grid commands next to a model
planner's command (numpy only): the soft label of the "mpc_nearby" DAgger expert.

The MPC plans with the privileged crowd state; a categorical policy reading only its LGM
cannot always do what the MPC does, and the MPC route's student, which learnt the MPC's
nearest grid command alone (a hard label), stayed below its teacher. This label keeps the
policy's own preferences and takes from the MPC only where to go: the policy's softmax
over the commands within `cells` grid steps of the MPC's command in both u_v and u_Δθ,
renormalised (`nearby_distribution`); its argmax is the command the expert walks.
"""

from __future__ import annotations

import numpy as np


def grid_steps(commands: np.ndarray) -> np.ndarray:
    """(2,): the grid's spacing in u_v [m/s] and u_Δθ [rad] — the smallest positive gap
    between the distinct values of each column of `commands` (C, 2)."""
    c = np.asarray(commands, float).reshape(-1, 2)
    steps = []
    for j in range(2):
        gaps = np.diff(np.unique(c[:, j]))
        if gaps.size == 0:
            raise ValueError(f"the command grid has one value in column {j}: no grid step")
        steps.append(gaps.min())
    return np.array(steps)


def nearby_mask(commands: np.ndarray, command: np.ndarray, cells: int = 1) -> np.ndarray:
    """(C,) bool: the grid commands (C, 2) within `cells` grid steps of `command` (2,) in
    both components; where none is (a command off the grid's span), the nearest one alone
    (grid steps as the unit of distance)."""
    if not isinstance(cells, int) or cells < 0:
        raise ValueError(f"cells must be an int >= 0, got {cells!r}")
    c = np.asarray(commands, float).reshape(-1, 2)
    off = np.abs(c - np.asarray(command, float).reshape(2)) / grid_steps(c)
    mask = (off <= cells + 1e-6).all(axis=1)
    if not mask.any():
        mask[int(np.argmin((off**2).sum(axis=1)))] = True
    return mask


def restricted_softmax(scores: np.ndarray, allowed: np.ndarray) -> np.ndarray:
    """softmax(`scores`) (C,) over the `allowed` (C,) bool entries, zero elsewhere; at least
    one entry must be allowed."""
    s, ok = np.asarray(scores, float), np.asarray(allowed, bool)
    if not ok.any():
        raise ValueError("restricted_softmax needs at least one allowed entry")
    z = np.where(ok, s - s[ok].max(), -np.inf)
    p = np.exp(z)
    return p / p.sum()


def nearby_distribution(
    scores: np.ndarray, commands: np.ndarray, command: np.ndarray, cells: int = 1
) -> np.ndarray:
    """The policy's softmax of `scores` (C,) over the grid commands (C, 2) next to `command`
    (`nearby_mask`), renormalised."""
    return restricted_softmax(scores, nearby_mask(commands, command, cells))
