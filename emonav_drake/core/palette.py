"""The colours of the navigation world, shared by every view of it (Meshcat, figures).

RGB triples in [0, 1]. Plain Python (no numpy, drake or matplotlib), so that the Drake
visualiser (`systems/navigation_meshcat.py`) and the matplotlib figures
(`evaluation/grid_map_figure.py`, `evaluation/trajectory_plot.py`,
`evaluation/benchmark_plots.py`) read one definition.
"""

from __future__ import annotations

RGB = tuple[float, float, float]

# Indexed by emotion code (HAPPY 0, NEUTRAL 1, NEGATIVE 2; `params.EMOTION_NAMES`).
EMOTION_RGB: tuple[RGB, RGB, RGB] = (
    (0.20, 0.75, 0.30),  # happy: green
    (0.95, 0.70, 0.15),  # neutral: amber
    (0.85, 0.15, 0.15),  # negative: red
)
ROBOT_RGB: RGB = (0.25, 0.45, 0.85)  # the robot: blue (Meshcat's LIP column)
STATIC_RGB: RGB = (0.50, 0.50, 0.50)  # static discs: grey

# Figures only: colours that must not be mistaken for an emotion or the robot.
GOAL_RGB: RGB = (0.55, 0.25, 0.70)  # the goal: purple
LIDAR_HIT_RGB: RGB = (0.05, 0.05, 0.05)  # LiDAR hit points: near black
# The grid maps' cell values (0 free, 127 discomfort zone, 255 collision area): white,
# light blue, dark navy — one hue, darker = worse, distinct from the emotion colours.
GRID_FREE_RGB: RGB = (1.0, 1.0, 1.0)
GRID_DISCOMFORT_RGB: RGB = (0.60, 0.75, 0.95)
GRID_COLLISION_RGB: RGB = (0.10, 0.15, 0.40)
