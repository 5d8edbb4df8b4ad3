"""What the robot senses of the crowd, numpy only: the LiDAR scan and its faults, objects
and legs found in it, the multi-target tracker, and the grid maps (LGM, OGM, DRL-VO*) built
from the scan.
"""
