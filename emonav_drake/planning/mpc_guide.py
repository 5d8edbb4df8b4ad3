"""The MPC's guide path: a shortest path to the goal around the static discs, on a grid.

The goal term of the MPC (`planners/mpc.py`) is local; alone it leaves the robot in the pockets
that two or three discs can form. `GuidePath` is a cost-to-go field on a square grid of
the world frame (positions and distances in metres): Dijkstra from the goal over an
8-connected grid, cells within contact distance of a disc blocked, cells in its discomfort
zone dearer. It is built once per episode and is part of the planner's memory
(`MpcMemory`), so its arrays are read-only after construction. scipy provides the sparse
graph and the Dijkstra.
"""

from __future__ import annotations

import math

import numpy as np
import scipy.sparse as sp
from scipy.sparse import csgraph

_GUIDE_MAX_CELLS = 60_000  # the guide grid is coarsened beyond this


class GuidePath:
    """Shortest path to the goal around the static discs, on a grid (built once per episode).

    The goal term of the MPC is local; alone it leaves the robot in the pockets that a few
    discs can form. This cost-to-go field (Dijkstra from the goal over an 8-connected grid;
    cells within contact distance of a disc are blocked, cells in its discomfort zone cost
    `zone_cost` times more) gives the reference the goal term follows instead.

    Args:
        goal: (2,) [m].
        centers: the static discs' centres (S, 2) [m].
        r_col, r_zone: contact and discomfort distances from each centre (S,) [m].
        start: (2,) a point the grid must cover (the robot's position) [m].
        resolution: cell size [m] (coarser if the grid would pass 60 000 cells).
        padding: grid margin around start, goal and discs [m].
        zone_cost: extra cost factor inside discomfort zones.
    """

    def __init__(
        self,
        goal: np.ndarray,
        centers: np.ndarray,
        r_col: np.ndarray,
        r_zone: np.ndarray,
        start: np.ndarray,
        resolution: float,
        padding: float,
        zone_cost: float,
    ) -> None:
        pts = np.vstack([goal[None], start[None], centers.reshape(-1, 2)])
        reach = np.concatenate([[0.0, 0.0], r_zone])
        lo = (pts - reach[:, None]).min(axis=0) - padding
        hi = (pts + reach[:, None]).max(axis=0) + padding
        # A far goal would make a huge grid: coarsen it to at most _GUIDE_MAX_CELLS cells.
        resolution = max(resolution, math.sqrt(float(np.prod(hi - lo)) / _GUIDE_MAX_CELLS))
        self.res = resolution
        self.origin = lo
        self.shape = nx, ny = (np.ceil((hi - lo) / resolution).astype(int) + 1).tolist()
        xs = lo[0] + resolution * np.arange(nx)
        ys = lo[1] + resolution * np.arange(ny)
        cx, cy = np.meshgrid(xs, ys, indexing="ij")
        cost = np.ones((nx, ny))
        blocked = np.zeros((nx, ny), dtype=bool)
        for c, r_c, r_z in zip(centers.reshape(-1, 2), r_col, r_zone, strict=True):
            d = np.hypot(cx - c[0], cy - c[1])
            blocked |= d < r_c
            cost = np.where(d < r_z, np.maximum(cost, zone_cost), cost)
        idx = np.arange(nx * ny).reshape(nx, ny)
        rows, cols, weights = [], [], []
        for dx, dy in ((1, 0), (0, 1), (1, 1), (1, -1)):
            i0, i1 = max(0, -dx), nx - max(0, dx)
            j0, j1 = max(0, -dy), ny - max(0, dy)
            a = idx[i0:i1, j0:j1].ravel()
            b = idx[i0 + dx : i1 + dx, j0 + dy : j1 + dy].ravel()
            keep = ~(blocked.ravel()[a] | blocked.ravel()[b])
            a, b = a[keep], b[keep]
            length = resolution * math.hypot(dx, dy)
            rows.append(a)
            cols.append(b)
            weights.append(length * 0.5 * (cost.ravel()[a] + cost.ravel()[b]))
        graph = sp.csr_matrix(
            (np.concatenate(weights), (np.concatenate(rows), np.concatenate(cols))),
            shape=(nx * ny, nx * ny),
        )
        self.goal = np.array(goal, dtype=float)
        self.goal_cell = self._cell(self.goal)
        dist, pred = csgraph.dijkstra(
            graph, directed=False, indices=int(self.goal_cell), return_predecessors=True
        )
        self.dist, self.pred = dist, pred
        self.blocked = blocked
        for a in (self.origin, self.goal, self.dist, self.pred, self.blocked):
            a.flags.writeable = False  # part of the planner's memory: never modified

    def covers(self, p: np.ndarray) -> bool:
        """Whether p lies on the grid."""
        ij = (np.asarray(p) - self.origin) / self.res
        return bool(np.all(ij >= 0) and np.all(ij <= np.array(self.shape) - 1))

    def _cell(self, p: np.ndarray) -> int:
        ij = np.rint((np.asarray(p) - self.origin) / self.res).astype(int)
        ij = np.clip(ij, 0, np.array(self.shape) - 1)
        return int(ij[0] * self.shape[1] + ij[1])

    def _center(self, cells: np.ndarray) -> np.ndarray:
        ij = np.stack(np.divmod(cells, self.shape[1]), axis=-1)
        return self.origin + self.res * ij

    def path(self, p: np.ndarray) -> np.ndarray | None:
        """Waypoints (W, 2) from p to the goal, or None if the goal cannot be reached."""
        cell = self._cell(p)
        if not np.isfinite(self.dist[cell]):  # p in a blocked cell: best neighbour
            i, j = divmod(cell, self.shape[1])
            best, best_d = -1, np.inf
            for di in range(-3, 4):
                for dj in range(-3, 4):
                    ii, jj = i + di, j + dj
                    if 0 <= ii < self.shape[0] and 0 <= jj < self.shape[1]:
                        c = ii * self.shape[1] + jj
                        if self.dist[c] < best_d:
                            best, best_d = c, self.dist[c]
            if best < 0:
                return None
            cell = best
        cells = [cell]
        while cells[-1] != self.goal_cell:
            nxt = int(self.pred[cells[-1]])
            if nxt < 0:
                return None
            cells.append(nxt)
        pts = self._center(np.array(cells))
        pts[0] = p
        pts[-1] = self.goal
        return pts
