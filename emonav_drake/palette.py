"""Every colour emonav draws with, by role: one definition for every view of the world.

The Drake visualiser (`systems/navigation_meshcat.py`, its replay legend in
`diagrams/meshcat_viewing.py`), the matplotlib figures (`evaluation/trajectory_plot.py`,
`grid_map_figure.py`, `benchmark_plots.py`, `learning_curve.py`), `scripts/*.py` and the
notebooks take their colours from here, by name; `tests/test_palette.py` fails on a colour
written anywhere else in them, and on roles that collide.

RGB triples in [0, 1]; plain Python (no numpy, drake or matplotlib), so that every view
can import it. Alphas are the views' own business (`(*ROBOT_RGB, 0.3)`).

The colour-blind-safe set is Okabe & Ito's (2008, "Color Universal Design",
https://jfly.uni-koeln.de/color/): eight colours that stay apart under protanopia,
deuteranopia and tritanopia. The three emotions keep their intuitive reading:

==========================  ==========================================================
role                        colour
==========================  ==========================================================
happy / neutral / negative  bluish green #009E73 / orange #E69F00 / vermillion #D55E00
robot, its trail and path   blue #0072B2 (its path: light → dark blue with time)
goal, goal radius           black (a star in the figures, a pole and ring in Meshcat)
static discs, their zones   dark grey
LiDAR rays                  light grey (hit points: dark grey)
discomfort zones            the colour of their pedestrian (or static disc), dashed or
                            faded; in a legend, dark grey
footstep targets            left sky blue #56B4E9, right reddish purple #CC79A7
LiDAR tracks                violet #A020F0 (tracked static discs: dark violet)
commands                    mid grey
heading marks, ink          black; labels near black; paper white
==========================  ==========================================================

The goal and the rays carry no hue, so they can be mistaken for no emotion; nor can the
robot's blue or the footsteps' sky blue and reddish purple (checked under simulated
colour blindness by `tests/test_palette.py`). Charts that are not the scene (methods of a
benchmark, model against measurement, series of seeds) have their own entries below.
"""

from __future__ import annotations

RGB = tuple[float, float, float]


def _hex(code: str) -> RGB:
    """'#RRGGBB' → an RGB triple in [0, 1]."""
    return tuple(int(code[i : i + 2], 16) / 255 for i in (1, 3, 5))  # type: ignore[return-value]


# Okabe & Ito's eight colours (the colour-blind-safe set everything below picks from)
OKABE_ITO: dict[str, RGB] = {
    "black": _hex("#000000"),
    "orange": _hex("#E69F00"),
    "sky_blue": _hex("#56B4E9"),
    "bluish_green": _hex("#009E73"),
    "yellow": _hex("#F0E442"),
    "blue": _hex("#0072B2"),
    "vermillion": _hex("#D55E00"),
    "reddish_purple": _hex("#CC79A7"),
}


def _grey(level: float) -> RGB:
    return (level, level, level)


# --- the scene --------------------------------------------------------------------------

# Indexed by emotion code (HAPPY 0, NEUTRAL 1, NEGATIVE 2; `params.EMOTION_NAMES`).
EMOTION_RGB: tuple[RGB, RGB, RGB] = (
    OKABE_ITO["bluish_green"],  # happy
    OKABE_ITO["orange"],  # neutral
    OKABE_ITO["vermillion"],  # negative
)
UNKNOWN_EMOTION_RGB: RGB = _grey(0.20)  # a pedestrian drawn without its emotion

ROBOT_RGB: RGB = OKABE_ITO["blue"]  # the robot, its trail (Meshcat) and its path
ROBOT_LIGHT_RGB: RGB = (0.72, 0.85, 0.94)  # the robot's path at its start (light blue)
ROBOT_DARK_RGB: RGB = (0.00, 0.19, 0.33)  # ... at its end (dark blue), its time labels
TRAIL_RGB: RGB = ROBOT_RGB

GOAL_RGB: RGB = OKABE_ITO["black"]  # the goal: a black star / pole, no emotion's hue
GOAL_RADIUS_RGB: RGB = GOAL_RGB  # the goal radius: a dotted (figures) / drawn (Meshcat) ring

STATIC_RGB: RGB = _grey(0.40)  # static discs and their d_static rings
ZONE_EDGE_RGB: RGB = _grey(0.30)  # "discomfort zone edge" in a legend (any colour's)

LIDAR_RAY_RGB: RGB = _grey(0.75)  # LiDAR rays (Meshcat) and the range circle (figures)
LIDAR_HIT_RGB: RGB = _grey(0.15)  # LiDAR hit points (figures and Meshcat)

FOOTSTEP_RGB: tuple[RGB, RGB] = (OKABE_ITO["sky_blue"], OKABE_ITO["reddish_purple"])  # L, R

# The crowd as the robot tracks it from its LiDAR scan (`--state-source lidar`), drawn
# beside the true crowd: a violet none of the scene's other roles takes (no emotion's hue,
# apart from the robot's blue and the footsteps' even under colour blindness); tracked
# static discs in a darker shade of it.
TRACK_RGB: RGB = _hex("#A020F0")
TRACK_STATIC_RGB: RGB = tuple(0.5 * v for v in TRACK_RGB)  # type: ignore[assignment]

COMMAND_RGB: RGB = _grey(0.60)  # a command held over a step (step plots)

INK_RGB: RGB = OKABE_ITO["black"]  # heading marks, outlines, collision/fall marks, error bars
TEXT_RGB: RGB = _grey(0.10)  # labels drawn on the scene
PAPER_RGB: RGB = (1.0, 1.0, 1.0)  # the background; halos around marks drawn on paths

# The grid maps' cell values (0 free, 127 discomfort zone, 255 collision area): white,
# light blue, dark navy — one hue, darker = worse, distinct from the emotion colours.
GRID_FREE_RGB: RGB = PAPER_RGB
GRID_DISCOMFORT_RGB: RGB = (0.60, 0.75, 0.95)
GRID_COLLISION_RGB: RGB = (0.10, 0.15, 0.40)

# How an episode ended, for charts of outcomes (`evaluation/diagnosis.py`): collisions
# take the colour of what was hit (an emotion, STATIC_RGB), these the rest.
OUTCOME_RGB: dict[str, RGB] = {
    "timeout": OKABE_ITO["reddish_purple"],
    "fall": INK_RGB,
    "no_route": (0.55, 0.50, 0.05),  # olive: the route layer found none left
}

# Rates in [0, 1] as a heat map (`emonav report`'s success per family): perceptually
# uniform and readable with colour-blindness; labels on it in PAPER_RGB below RATE_LABEL_SWITCH
# (dark cells), INK_RGB above.
RATE_CMAP = "viridis"
RATE_LABEL_SWITCH = 0.6

# The HTML overlay of a Meshcat replay (caption and legend)
CAPTION_BOX_RGB: RGB = PAPER_RGB
CAPTION_TEXT_RGB: RGB = _grey(0.13)
CAPTION_NOTE_RGB: RGB = _grey(0.40)

# The world the robot's head camera renders (`systems/head_camera.py`,
# `systems/pedestrian_bodies.py`): muted and hueless but for the sky, so that the face
# textures are the only emotion cue in the image.
CAMERA_SKY_RGB: RGB = (0.80, 0.87, 0.94)
CAMERA_GROUND_RGB: RGB = (0.62, 0.60, 0.56)
CAMERA_DISC_RGB: RGB = _grey(0.55)  # a static disc
PEDESTRIAN_CLOTHES_RGB: RGB = (0.30, 0.34, 0.40)  # the body
PEDESTRIAN_HAIR_RGB: RGB = (0.24, 0.17, 0.11)  # the head, also seen from behind

# --- charts -----------------------------------------------------------------------------

# Methods of a benchmark (bars, lines): never an emotion's colour, since the IDT chart
# groups its bars by emotion. Unlisted methods take `METHOD_CYCLE` in turn.
METHOD_CYCLE: tuple[RGB, ...] = (
    OKABE_ITO["yellow"],
    _grey(0.35),
    _grey(0.65),
    OKABE_ITO["black"],
    # shades of the methods' hues (never of an emotion's), for charts of 8 methods or more
    (0.93, 0.76, 0.87),  # light reddish purple
    (0.55, 0.50, 0.05),  # olive (dark yellow)
    (0.00, 0.24, 0.45),  # dark blue
    (0.76, 0.88, 0.96),  # light sky blue
)
# Every method of the paper's Table II keeps one colour in every figure (the LIP and the
# Digit charts of notebooks/benchmark.ipynb draw them in different orders).
METHOD_RGB: dict[str, RGB] = {
    "policy": OKABE_ITO["blue"],
    "mpc": OKABE_ITO["reddish_purple"],
    "dwa": OKABE_ITO["sky_blue"],
    **dict(
        zip(
            ("emobipednav", "single_lgm", "lidar_sac", "sarl", "ogm", "lndnl", "drlvo", "rgl"),
            METHOD_CYCLE,
            strict=True,
        )
    ),
    # the default policy before the distilled one (shown beside it in older runs)
    "emobipednav_digit_mpc": (0.416, 0.239, 0.604),  # dark purple, #6a3d9a
}

# Model against measurement (`scripts/plot_step_response.py`, tracking notebook)
MEASURED_RGB: RGB = INK_RGB  # what Digit did
LIP_RGB: RGB = OKABE_ITO["reddish_purple"]  # the LIP step map (Eq. 1) under u_k
LIP_DELAYED_RGB: tuple[RGB, RGB] = (_grey(0.55), _grey(0.80))  # ... under u_{k-1}, u_{k-2}
FITTED_RGB: RGB = OKABE_ITO["blue"]  # the fitted step-response model
DATA_RGB: RGB = OKABE_ITO["blue"]  # a chart's single data series
REFERENCE_RGB: RGB = _grey(0.55)  # a second series drawn for reference beside the main one
SHADE_RGB: RGB = _grey(0.85)  # a shaded span (a part left out of the statistics)
# Several series of one kind (seeds, rates): Okabe & Ito's order
SERIES_RGB: tuple[RGB, ...] = tuple(
    OKABE_ITO[n]
    for n in (
        "blue",
        "orange",
        "bluish_green",
        "vermillion",
        "reddish_purple",
        "sky_blue",
        "yellow",
        "black",
    )
)


def method_colours(labels: list[str]) -> list[RGB]:
    """One colour per method label, in order: `METHOD_RGB` for the known ones (a label
    "NAME (note)" as NAME), the others `METHOD_CYCLE` in turn (skipping colours the known
    ones use)."""
    keys = [m.split(" (")[0] for m in labels]  # "policy (default)" is drawn as "policy"
    taken = {METHOD_RGB[m] for m in keys if m in METHOD_RGB}
    spare = [c for c in (*METHOD_CYCLE, *SERIES_RGB) if c not in taken and c not in EMOTION_RGB]
    spare = list(dict.fromkeys(spare))  # each colour once: no two methods share one
    out, i = [], 0
    for m in keys:
        if m in METHOD_RGB:
            out.append(METHOD_RGB[m])
        else:
            out.append(spare[i % len(spare)])
            i += 1
    return out


def css(rgb: RGB, alpha: float | None = None) -> str:
    """An RGB triple as a CSS colour: '#rrggbb', or 'rgba(r,g,b,a)' with an alpha."""
    if alpha is None:
        return "#" + "".join(f"{round(255 * v):02x}" for v in rgb)
    r, g, b = (round(255 * v) for v in rgb)
    return f"rgba({r},{g},{b},{alpha:g})"
