"""Render the diagrams' pictures for the docs from `Diagram.GetGraphvizString` (needs the
Graphviz `dot` program: `apt-get install graphviz`).

    .venv/bin/python scripts/render_diagram_figures.py   # writes docs/figures/*.svg
"""

from __future__ import annotations

import subprocess
from pathlib import Path

from emonav_drake.diagrams.digit_station import DigitStation
from emonav_drake.diagrams.navigation import build_navigation_diagram
from emonav_drake.diagrams.navigation_digit import build_digit_navigation_diagram
from emonav_drake.params import load_config
from emonav_drake.planners.dwa import DwaPlanner
from emonav_drake.scenarios.scenario import sample_scenario

OUT = Path(__file__).resolve().parent.parent / "docs" / "figures"


def render(dot: str, name: str) -> Path:
    path = OUT / f"{name}.svg"
    svg = subprocess.run(["dot", "-Tsvg"], input=dot, capture_output=True, text=True, check=True)
    path.write_text(svg.stdout)
    return path


def main() -> None:
    OUT.mkdir(parents=True, exist_ok=True)
    cfg = load_config()
    scenario = sample_scenario(0, cfg)
    nd = build_digit_navigation_diagram(scenario, cfg, DwaPlanner(cfg))
    lip = build_navigation_diagram(scenario, cfg, DwaPlanner(cfg))
    station = DigitStation(cfg)
    for dot, name in (
        (nd.diagram.GetGraphvizString(max_depth=1), "navigation_digit_diagram"),
        (station.GetGraphvizString(max_depth=1), "digit_station_diagram"),
        (lip.diagram.GetGraphvizString(max_depth=1), "navigation_lip_diagram"),
    ):
        print(f"wrote {render(dot, name)}")


if __name__ == "__main__":
    main()
