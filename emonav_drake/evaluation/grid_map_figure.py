"""The paper's Fig. 3 for one scene: the LiDAR scan, its LGM and its OGM, written as a PNG.

Uses matplotlib's object API with the Agg canvas (no screen, no global backend change).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.colors import BoundaryNorm, ListedColormap
from matplotlib.figure import Figure
from matplotlib.patches import Circle

from emonav_drake.core.grid_maps import lgm_frame
from emonav_drake.core.lidar import as_discs, as_point, beam_angles, scan_discs

STATIC, PEDESTRIAN = 0, 1

# 0 free (white), 127 discomfort (blue), 255 collision (red), as in the paper's figures.
_GRID_CMAP = ListedColormap(["white", "tab:blue", "tab:red"])
_GRID_NORM = BoundaryNorm([0, 64, 192, 256], _GRID_CMAP.N)


def render_grid_map_figure(
    path: str | Path,
    origin_xy: object,
    heading: float,
    centers: object,
    radii: object,
    margins: object,
    kinds: object,
    goal_xy: object | None = None,
    grid_size: int = 100,
    num_beams: int = 1800,
    max_range: float = 6.0,
    min_range: float = 0.27,
    robot_radius: float = 0.3,
    title: str | None = None,
    dpi: int = 120,
) -> Path:
    """Write a three-panel PNG: (a) the scene, (b) its LGM, (c) its OGM.

    Args:
        path: output PNG file; parent directories are created.
        origin_xy: robot (LiDAR) position (2,) in the world frame [m].
        heading: robot heading in the world frame [rad].
        centers: disc centres (n, 2) in the world frame [m].
        radii: disc radii (n,) [m].
        margins: discomfort margins (n,) [m] (pedestrian: emotion distance; static: 0.2).
        kinds: (n,) 0 for a static disc, 1 for a pedestrian.
        goal_xy: optional goal (2,) in the world frame [m].
        grid_size, num_beams, max_range, min_range: map and LiDAR settings (M, K, L).
        robot_radius: drawn robot radius [m] (the maps ignore it).
        title: optional figure title.
        dpi: PNG resolution.

    Returns:
        The written path.

    Panel (a) is top-down in the world frame: LiDAR hits of the real scan (red dots),
    pedestrians (blue rings), static discs (solid cyan), discomfort margins (dashed), the
    robot (red, arrow = heading) and the goal (green). Panel (b) is the LGM with the
    rotational (sector) index on x and the radial (ring) index on y; panel (c) the OGM
    with forward up and the robot's left on the left.
    """
    origin = np.array(as_point(origin_xy))
    heading = float(heading)
    c, r = as_discs(centers, radii)
    mg = np.asarray(margins, dtype=float).reshape(-1)
    kd = np.asarray(kinds).reshape(-1)
    if mg.shape != r.shape or kd.shape != r.shape:
        raise ValueError(
            f"margins and kinds must have shape {r.shape}, got {mg.shape} and {kd.shape}"
        )
    settings = dict(
        num_beams=num_beams, grid_size=grid_size, max_range=max_range, min_range=min_range
    )
    lgm = lgm_frame(origin, heading, c, r, mg, kind="lgm", **settings)
    ogm = lgm_frame(origin, heading, c, r, mg, kind="ogm", **settings)
    ranges = scan_discs(origin, heading, c, r, num_beams, max_range, min_range)

    fig = Figure(figsize=(15, 5), layout="constrained")
    FigureCanvasAgg(fig)
    ax_scene, ax_lgm, ax_ogm = fig.subplots(1, 3)

    # (a) scene, world frame
    seen = ranges < max_range
    world_angles = beam_angles(num_beams)[seen] + heading
    hits = origin + ranges[seen, None] * np.c_[np.cos(world_angles), np.sin(world_angles)]
    ax_scene.add_patch(Circle(origin, max_range, fill=False, ls=":", color="0.6", lw=0.8))
    for center, radius, margin, kind in zip(c, r, mg, kd, strict=True):
        if int(kind) == PEDESTRIAN:
            ax_scene.add_patch(Circle(center, radius, fill=False, color="tab:blue", lw=1.5))
            edge = "tab:blue"
        else:
            ax_scene.add_patch(Circle(center, radius, color="c"))
            edge = "c"
        ax_scene.add_patch(Circle(center, radius + margin, fill=False, ls="--", color=edge))
    ax_scene.plot(hits[:, 0], hits[:, 1], ".", color="tab:red", ms=1.5, label="LiDAR hits")
    ax_scene.add_patch(Circle(origin, robot_radius, color="tab:red", alpha=0.9))
    arrow = 2.0 * robot_radius
    ax_scene.arrow(
        origin[0],
        origin[1],
        arrow * math.cos(heading),
        arrow * math.sin(heading),
        width=0.03,
        color="k",
        length_includes_head=True,
    )
    if goal_xy is not None:
        goal = np.array(as_point(goal_xy, "goal_xy"))
        ax_scene.add_patch(Circle(goal, 0.15, color="tab:green"))
    ax_scene.set_xlim(origin[0] - max_range, origin[0] + max_range)
    ax_scene.set_ylim(origin[1] - max_range, origin[1] + max_range)
    ax_scene.set_aspect("equal")
    ax_scene.set_xlabel("x [m] (world)")
    ax_scene.set_ylabel("y [m] (world)")
    ax_scene.set_title("(a) LiDAR scan")

    # (b) LGM: array rows are sectors, columns rings -> transpose for x = sector
    ax_lgm.imshow(
        lgm.T,
        origin="lower",
        cmap=_GRID_CMAP,
        norm=_GRID_NORM,
        interpolation="nearest",
        aspect="auto",
    )
    ax_lgm.set_xlabel("rotational index (sector; 0 = behind right, CCW)")
    ax_lgm.set_ylabel("radial index (ring; 0 = at the robot)")
    ax_lgm.set_title("(b) LiDAR grid map (LGM)")

    # (c) OGM: rows grow forward, columns grow to the robot's right
    ax_ogm.imshow(
        ogm,
        origin="lower",
        cmap=_GRID_CMAP,
        norm=_GRID_NORM,
        interpolation="nearest",
    )
    ax_ogm.set_xlabel("X pixel (column; robot's right →)")
    ax_ogm.set_ylabel("Y pixel (row; forward ↑)")
    ax_ogm.set_title("(c) occupancy grid map (OGM)")

    if title:
        fig.suptitle(title)
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=dpi, format="png")
    return out
