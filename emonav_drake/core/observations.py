"""The observation kinds a navigation policy can read, and their keys.

A policy's map observation is one of: "lgm" (the paper's LiDAR grid maps with emotion
zones), "ogm" (occupancy grids without them), "scan" (raw LiDAR scans; LiDAR-SAC, LNDNL),
"drlvo" (the DRL-VO* image). The observation dictionary (`EmoNavLIP-v0`, `EmoNavDigit-v0`,
`systems.NavigationObservation`) holds the map under `map_key(kind)` beside "goal" and
"last_action".
"""

from __future__ import annotations


def map_key(grid_kind: str) -> str:
    """The map observation's key: "lgm" for grid maps (LGM or OGM), "scan" for scans,
    "image" for the DRL-VO* image."""
    return {"scan": "scan", "drlvo": "image"}.get(grid_kind, "lgm")
