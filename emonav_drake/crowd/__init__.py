"""The crowd, numpy only: pedestrians with emotions, their routes, legs and poses, and ORCA.

The same crowd moves in the LIP world and in the Drake diagrams (`systems/crowd_system.py`).
"""
