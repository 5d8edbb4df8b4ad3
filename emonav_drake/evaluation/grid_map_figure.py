"""The paper's Fig. 3 for one scene: the LiDAR scan, its LGM and its OGM, written as a PNG.

Panel (a) is the scene from above in the world frame, in the shared palette
(`palette.py`, Okabe–Ito): the robot blue with a black heading arrow, pedestrians
bluish green / orange / vermillion by emotion (happy / neutral / negative) with their
discomfort zones dashed in the same colour, static discs grey with their dashed d_static
rings, walls (if any) as grey lines with their dashed d_static bands, the LiDAR's hit
points dark grey, its range dotted light grey, the goal a black
star — or, when the goal lies beyond the panel, a black arrow at the panel's edge
pointing to it, labelled with its distance. Panels (b)
and (c) colour the grid values: 0 free (white), 127 discomfort zone (light blue: the hit
of the scan of the discs inflated by their discomfort margins), 255 collision area (dark
navy: the hit of the real scan). Each panel has its legend under it.

Uses matplotlib's object API with the Agg canvas (no screen, no global backend change).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.colors import BoundaryNorm, ListedColormap
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Circle, Patch

from emonav_drake.palette import (
    EMOTION_RGB,
    GOAL_RGB,
    GRID_COLLISION_RGB,
    GRID_DISCOMFORT_RGB,
    GRID_FREE_RGB,
    INK_RGB,
    LIDAR_HIT_RGB,
    LIDAR_RAY_RGB,
    PAPER_RGB,
    ROBOT_RGB,
    STATIC_RGB,
    UNKNOWN_EMOTION_RGB,
    ZONE_EDGE_RGB,
)
from emonav_drake.params import EMOTION_NAMES, NUM_BEAMS
from emonav_drake.scenarios.walls import as_segments
from emonav_drake.sensing.grid_maps import COLLISION_VALUE, DISCOMFORT_VALUE, lgm_frame
from emonav_drake.sensing.lidar import as_discs, as_point, beam_angles, scan_discs

STATIC, PEDESTRIAN = 0, 1

# 0 free, 127 discomfort zone, 255 collision area (palette: white, light blue, dark navy).
_GRID_CMAP = ListedColormap([GRID_FREE_RGB, GRID_DISCOMFORT_RGB, GRID_COLLISION_RGB])
_GRID_NORM = BoundaryNorm([0, 64, 192, 256], _GRID_CMAP.N)
_GRID_EDGE_RGB = STATIC_RGB  # the outline of a grid value's legend patch


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
    num_beams: int = NUM_BEAMS,
    max_range: float = 6.0,
    min_range: float = 0.27,
    robot_radius: float = 0.3,
    title: str | None = None,
    dpi: int = 120,
    emotions: object | None = None,
    segments: object | None = None,
    segment_margin: float = 0.2,
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
        goal_xy: optional goal (2,) in the world frame [m]; drawn as an arrow at the edge
            of panel (a) when it lies beyond it.
        grid_size, num_beams, max_range, min_range: map and LiDAR settings (M, K, L).
        robot_radius: drawn robot radius [m] (the maps ignore it).
        title: optional figure title.
        dpi: PNG resolution.
        emotions: optional (n,) emotion codes (0 happy, 1 neutral, 2 negative; ignored for
            static discs) colouring the pedestrians; without them pedestrians are dark grey
            (`palette.UNKNOWN_EMOTION_RGB`).
        segments: optional walls (W, 2, 2) in the world frame [m] (segment k from
            ``[k, 0]`` to ``[k, 1]``), scanned with the discs (`sensing/lidar.py`).
        segment_margin: the walls' discomfort margin [m] (the static discs' 0.2 m).

    Returns:
        The written path.

    Panel (a) is top-down in the world frame (module docstring for the colours); panel (b)
    is the LGM with the rotational (sector) index on x — labelled with the beam direction
    relative to the heading — and the radial (ring) index on y (range in metres on the
    right); panel (c) the OGM with forward up and the robot's left on the left (metres
    from the robot on the top and right axes), the robot at the centre.
    """
    origin = np.array(as_point(origin_xy))
    heading = float(heading)
    c, r = as_discs(centers, radii)
    mg, kd, emo = _check_disc_arrays(r, margins, kinds, emotions)
    walls = as_segments(segments, "segments")
    settings = dict(
        num_beams=num_beams,
        grid_size=grid_size,
        max_range=max_range,
        min_range=min_range,
        segments=walls,
        segment_margin=segment_margin,
    )
    lgm = lgm_frame(origin, heading, c, r, mg, kind="lgm", **settings)
    ogm = lgm_frame(origin, heading, c, r, mg, kind="ogm", **settings)
    ranges = scan_discs(origin, heading, c, r, num_beams, max_range, min_range, segments=walls)

    fig, (ax_scene, ax_lgm, ax_ogm), (key_scene, key_grid) = _figure_layout()
    shown_emotions, goal_handle = _draw_scene(
        ax_scene,
        origin,
        heading,
        (c, r, mg, kd, emo),
        ranges,
        goal_xy,
        num_beams,
        max_range,
        robot_radius,
    )
    _draw_walls(ax_scene, walls, float(segment_margin))
    _scene_legend(key_scene, kd, emo, shown_emotions, goal_handle, max_range, len(walls) > 0)
    _draw_lgm(ax_lgm, lgm, max_range)
    _draw_ogm(ax_ogm, ogm, max_range)
    _grid_legend(key_grid)

    if title:
        fig.suptitle(title)
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=dpi, format="png")
    return out


def _figure_layout() -> tuple[Figure, tuple[Axes, Axes, Axes], tuple[Axes, Axes]]:
    """The figure on an Agg canvas, its three panels and, under them, the two legend axes."""
    fig = Figure(figsize=(16, 6.8), layout="constrained")
    FigureCanvasAgg(fig)
    grid = fig.add_gridspec(2, 3, height_ratios=[1.0, 0.13])
    ax_scene, ax_lgm, ax_ogm = (fig.add_subplot(grid[0, j]) for j in range(3))
    key_scene, key_grid = fig.add_subplot(grid[1, 0]), fig.add_subplot(grid[1, 1:])
    key_scene.axis("off")
    key_grid.axis("off")
    return fig, (ax_scene, ax_lgm, ax_ogm), (key_scene, key_grid)


def _check_disc_arrays(
    r: np.ndarray, margins: object, kinds: object, emotions: object | None
) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """The margins, kinds and emotions (None if not given) as flat arrays shaped as `r`."""
    mg = np.asarray(margins, dtype=float).reshape(-1)
    kd = np.asarray(kinds).reshape(-1)
    if mg.shape != r.shape or kd.shape != r.shape:
        raise ValueError(
            f"margins and kinds must have shape {r.shape}, got {mg.shape} and {kd.shape}"
        )
    emo = None
    if emotions is not None:
        emo = np.asarray(emotions).reshape(-1)
        if emo.shape != r.shape:
            raise ValueError(f"emotions must have shape {r.shape}, got {emo.shape}")
    return mg, kd, emo


def _draw_scene(
    ax: Axes,
    origin: np.ndarray,
    heading: float,
    discs: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray | None],
    ranges: np.ndarray,
    goal_xy: object | None,
    num_beams: int,
    max_range: float,
    robot_radius: float,
) -> tuple[set[int], Line2D | None]:
    """Panel (a), the scene in the world frame, from `discs` = (centres, radii, margins,
    kinds, emotions or None); returns the emotions drawn and the goal's legend entry."""
    c, r, mg, kd, emo = discs
    seen = ranges < max_range
    world_angles = beam_angles(num_beams)[seen] + heading
    hits = origin + ranges[seen, None] * np.c_[np.cos(world_angles), np.sin(world_angles)]
    ax.add_patch(Circle(origin, max_range, fill=False, ls=":", color=LIDAR_RAY_RGB, lw=0.8))
    shown_emotions: set[int] = set()
    for i, (center, radius, margin, kind) in enumerate(zip(c, r, mg, kd, strict=True)):
        if int(kind) == PEDESTRIAN:
            if emo is None:
                rgb = UNKNOWN_EMOTION_RGB
            else:
                shown_emotions.add(int(emo[i]))
                rgb = EMOTION_RGB[int(emo[i])]
            ax.add_patch(Circle(center, radius, fc=(*rgb, 0.45), ec=rgb, lw=1.5))
        else:
            rgb = STATIC_RGB
            ax.add_patch(Circle(center, radius, color=rgb))
        ax.add_patch(Circle(center, radius + margin, fill=False, ls="--", ec=rgb, lw=1.2))
    ax.plot(hits[:, 0], hits[:, 1], ".", color=LIDAR_HIT_RGB, ms=1.5, zorder=5)
    ax.add_patch(Circle(origin, robot_radius, fc=ROBOT_RGB, ec=INK_RGB, lw=0.8, zorder=6))
    arrow = 2.0 * robot_radius
    ax.arrow(
        origin[0],
        origin[1],
        arrow * math.cos(heading),
        arrow * math.sin(heading),
        width=0.03,
        color=INK_RGB,
        length_includes_head=True,
        zorder=7,
    )
    half = max_range + 0.3  # the panel's half width [m]
    ax.set_xlim(origin[0] - half, origin[0] + half)
    ax.set_ylim(origin[1] - half, origin[1] + half)
    goal_handle = None
    if goal_xy is not None:
        goal = np.array(as_point(goal_xy, "goal_xy"))
        goal_handle = _draw_goal(ax, origin, goal, half)
    ax.set_aspect("equal")
    ax.set_xlabel("x [m] (world)")
    ax.set_ylabel("y [m] (world)")
    ax.set_title("(a) LiDAR scan (world frame)")
    return shown_emotions, goal_handle


def _draw_walls(ax: Axes, walls: np.ndarray, margin: float) -> None:
    """The walls (W, 2, 2) as grey lines, each with the dashed outline of its band of
    half-width `margin` [m] (its discomfort zone), in the world frame."""
    for a, b in walls:
        ax.plot([a[0], b[0]], [a[1], b[1]], color=STATIC_RGB, lw=3, solid_capstyle="butt")
        if margin > 0.0:
            ax.plot(*_band_outline(a, b, margin).T, ls="--", color=STATIC_RGB, lw=1.2)


def _band_outline(a: np.ndarray, b: np.ndarray, h: float, n: int = 16) -> np.ndarray:
    """Closed outline (2n + 1, 2) [m] of the points within `h` of the segment a → b: a
    half circle round b, the side back to a, a half circle round a."""
    e = b - a
    angle = math.atan2(e[1], e[0])
    half = np.linspace(-math.pi / 2, math.pi / 2, n)
    round_b = b + h * np.c_[np.cos(angle + half), np.sin(angle + half)]
    round_a = a + h * np.c_[np.cos(angle + math.pi + half), np.sin(angle + math.pi + half)]
    return np.vstack([round_b, round_a, round_b[:1]])


def _scene_legend(
    key: Axes,
    kd: np.ndarray,
    emo: np.ndarray | None,
    shown_emotions: set[int],
    goal_handle: Line2D | None,
    max_range: float,
    has_walls: bool = False,
) -> None:
    """The legend of panel (a), drawn on the axes `key` under it."""
    handles = [
        Line2D([], [], ls="none", marker="o", ms=10, mfc=ROBOT_RGB, mec=INK_RGB, label="robot"),
        Line2D([], [], color=INK_RGB, lw=1.5, marker=">", ms=5, label="heading"),
        Line2D([], [], ls="none", marker=".", color=LIDAR_HIT_RGB, ms=6, label="LiDAR hits"),
        Line2D([], [], ls=":", color=LIDAR_RAY_RGB, label=f"LiDAR range ({max_range:g} m)"),
    ]
    if emo is None:
        handles.append(_disc_handle(UNKNOWN_EMOTION_RGB, "pedestrian"))
    for e in sorted(shown_emotions) if emo is not None else []:
        handles.append(_disc_handle(EMOTION_RGB[e], f"{EMOTION_NAMES[e]} pedestrian"))
    if np.any(kd != PEDESTRIAN):
        handles.append(
            Line2D([], [], ls="none", marker="o", ms=10, color=STATIC_RGB, label="static disc")
        )
    if has_walls:
        handles.append(Line2D([], [], color=STATIC_RGB, lw=3, label="wall"))
    handles.append(
        Line2D([], [], ls="--", color=ZONE_EDGE_RGB, label="discomfort zone (radius + margin)")
    )
    if goal_handle is not None:
        handles.append(goal_handle)
    key.legend(handles=handles, loc="upper center", ncol=3, fontsize=8, frameon=False)


def _draw_lgm(ax: Axes, lgm: np.ndarray, max_range: float) -> None:
    """Panel (b), the LGM: x = sector (rotational index), y = ring (radial index)."""
    # array rows are sectors, columns rings -> transpose for x = sector
    m = lgm.shape[0]
    ax.imshow(
        lgm.T,
        origin="lower",
        cmap=_GRID_CMAP,
        norm=_GRID_NORM,
        interpolation="nearest",
        aspect="auto",
    )
    # sector s covers beam angles [−180° + s·360°/M, …): ticks at the sector edges
    edges = np.array([0, m / 4, m / 2, 3 * m / 4, m]) - 0.5
    ax.set_xticks(
        edges,
        [
            "0\n−180° behind",
            f"{m // 4}\n−90° right",
            f"{m // 2}\n0° ahead",
            f"{3 * m // 4}\n+90° left",
            f"{m}\n180° behind",
        ],
        fontsize=8,
    )
    ax.axvline(m / 2 - 0.5, color=ROBOT_RGB, ls=":", lw=1.0)
    ring = max_range / m
    ax.secondary_yaxis(
        "right", functions=(lambda j: (j + 0.5) * ring, lambda d: d / ring - 0.5)
    ).set_ylabel("range [m]")
    ax.set_xlabel("rotational index (sector; beam direction from the heading, CCW)")
    ax.set_ylabel("radial index (ring; 0 = at the robot)")
    ax.set_title("(b) LiDAR grid map (LGM)")


def _draw_ogm(ax: Axes, ogm: np.ndarray, max_range: float) -> None:
    """Panel (c), the OGM in the robot frame, the robot at its centre."""
    # rows grow forward, columns grow to the robot's right
    m = ogm.shape[0]
    ax.imshow(
        ogm,
        origin="lower",
        cmap=_GRID_CMAP,
        norm=_GRID_NORM,
        interpolation="nearest",
    )
    cell = 2.0 * max_range / m
    centre = m / 2 - 0.5  # the robot sits on the corner between the four middle cells
    ax.plot(centre, centre, "^", ms=9, mfc=ROBOT_RGB, mec=INK_RGB, zorder=5)
    ax.secondary_xaxis(
        "top",
        functions=(lambda j: (centre - j) * cell, lambda y: centre - y / cell),
    ).set_xlabel("left of the robot [m]")
    ax.secondary_yaxis(
        "right",
        functions=(lambda i: (i - centre) * cell, lambda x: centre + x / cell),
    ).set_ylabel("ahead of the robot [m]")
    ax.set_xlabel("X pixel (column; robot's right →)")
    ax.set_ylabel("Y pixel (row; forward ↑)")
    ax.set_title("(c) occupancy grid map (OGM, robot frame)")


def _grid_legend(key: Axes) -> None:
    """The legend of panels (b) and (c), drawn on the axes `key` under them."""
    grid_handles = [
        Patch(fc=GRID_FREE_RGB, ec=_GRID_EDGE_RGB, label="0: free"),
        Patch(
            fc=GRID_DISCOMFORT_RGB,
            ec=_GRID_EDGE_RGB,
            label=f"{DISCOMFORT_VALUE}: discomfort zone (hit of the inflated scan)",
        ),
        Patch(
            fc=GRID_COLLISION_RGB,
            ec=_GRID_EDGE_RGB,
            label=f"{COLLISION_VALUE}: collision area (hit of the real scan)",
        ),
    ]
    key.legend(
        handles=grid_handles
        + [
            Line2D([], [], color=ROBOT_RGB, ls=":", label="(b) straight ahead"),
            Line2D(
                [], [], ls="none", marker="^", ms=8, mfc=ROBOT_RGB, mec=INK_RGB, label="(c) robot"
            ),
        ],
        loc="upper center",
        ncol=3,
        fontsize=8,
        frameon=False,
        title="grid values (b, c)",
        title_fontsize=8,
    )


def _disc_handle(rgb: tuple[float, float, float], label: str) -> Line2D:
    return Line2D([], [], ls="none", marker="o", ms=10, mfc=(*rgb, 0.45), mec=rgb, label=label)


def _draw_goal(ax, origin: np.ndarray, goal: np.ndarray, half: float) -> Line2D:
    """The goal as a star, or, beyond the panel (half width `half` [m] about `origin`), an
    arrow at the panel's edge pointing to it, labelled with its distance; the legend entry."""
    offset = goal - origin
    if np.all(np.abs(offset) <= half - 0.2):
        ax.plot(*goal, "*", ms=16, color=GOAL_RGB, mec=PAPER_RGB, mew=0.8, zorder=8)
        return Line2D([], [], ls="none", marker="*", ms=12, color=GOAL_RGB, label="goal")
    distance = float(np.hypot(*offset))
    u = offset / distance
    tip = origin + u * ((half - 0.25) / np.max(np.abs(u)))  # on the edge, 0.25 m inside
    tail = tip - 1.1 * u
    ax.annotate(
        "",
        xy=tip,
        xytext=tail,
        arrowprops=dict(arrowstyle="-|>,head_width=0.4,head_length=0.8", color=GOAL_RGB, lw=2.5),
        zorder=8,
    )
    ax.annotate(
        f"goal\n{distance:.1f} m",
        tail - 0.35 * u,
        ha="center",
        va="center",
        fontsize=8,
        color=GOAL_RGB,
        fontweight="bold",
        bbox=dict(boxstyle="round,pad=0.15", fc=PAPER_RGB, ec="none", alpha=0.85),
        zorder=8,
    )
    return Line2D([], [], color=GOAL_RGB, lw=2.5, marker=">", ms=6, label="goal (beyond the panel)")
