"""One navigation episode in plain numpy: the LIP world, the observations a planner reads,
the goal input, the rewards (paper Eq. 6-9), the metrics and the episode trace.
"""
