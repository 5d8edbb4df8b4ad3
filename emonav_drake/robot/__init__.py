"""The robot models, numpy only: the LIP step map (paper Eq. 1), ALIP foot placement, the
walking targets the controller tracks, the fitted step response and the step-map tracking
statistics.
"""
