"""The planners' maths, numpy only: DWA on the LIP model, the MPC's model, guide path,
quadratic program and step-response horizon, SARL's joint state, and the LGM shield.
The planners themselves (the `Planner` protocol, networks, checkpoints) live in `planners/`.
"""
