"""The allowed range of every numeric field of the configurations and scenarios.

Tables of data, read through `config_yaml.validate_ranges`: the dotted field name → its
bounds, both ends finite. `RANGES` is `EmoNavConfig`'s (`params.py`); `SCENARIO_RANGES`,
`PEDESTRIAN_RANGES` and `OBSTACLE_RANGES` are a scenario file's (`core/scenario_spec.py`),
taken from `RANGES` wherever a scenario holds what a configuration holds (the robot's
start and goal, the emotion change period), so that a file and a configuration are held
to one range; `ESTIMATE_RANGES` is an emotion estimate's (`perception/noisy_emotions.py`).
Kept apart from the dataclasses so that those read as the fields and their defaults; a
new numeric field gets its line here (`tests/test_probe3_resources.py` fails otherwise).
The cross-field rules (a minimum below its maximum, rates that are multiples of the time
step, …) are code and stay in the dataclasses' `validate`.

The rewards are bounded so that an episode's total stays finite and printable: at most
|collision| + |discomfort| + goal + progress_gain × (the longest step) per step, over at
most `episode.max_steps` steps: 7 × 10^7 at the bounds.
"""

import math
from typing import Any

# Seeds are 64-bit unsigned integers (numpy's generators take them; a larger one would
# alias a smaller one).
SEED_RANGE = (0, 2**64 - 1)

# (low, high) inclusive; list fields: (length, low, high) for each element.
RANGES: dict[str, Any] = {
    "robot.step_time": (0.05, 2.0),
    "robot.com_height": (0.3, 2.0),
    "robot.gravity": (1.0, 20.0),
    "robot.radius": (0.05, 1.0),
    "robot.max_speed": (0.01, 2.0),
    "robot.max_heading_change": (0.01, math.pi / 2),
    "robot.start": (2, -50.0, 50.0),
    "robot.goal": (2, -50.0, 50.0),
    "lidar.num_beams": (4, 36000),
    "lidar.max_range": (0.5, 50.0),
    "lidar.min_range": (0.0, 5.0),
    "lidar.grid_size": (2, 1000),
    "lidar.num_frames": (1, 64),
    "crowd.dt": (0.01, 1.0),
    "crowd.pedestrian_radius": (0.05, 1.0),
    "crowd.preferred_speed": (0.0, 3.0),
    "crowd.min_pedestrians": (0, 20),
    "crowd.max_pedestrians": (0, 20),
    "crowd.min_static": (0, 20),
    "crowd.max_static": (0, 20),
    "crowd.static_radius_min": (0.05, 2.0),
    "crowd.static_radius_max": (0.05, 2.0),
    "crowd.circle_radius_min": (0.5, 20.0),
    "crowd.circle_radius_max": (0.5, 20.0),
    "crowd.static_x_range": (2, -20.0, 20.0),
    "crowd.static_y_range": (2, -20.0, 20.0),
    "crowd.goal_tolerance": (0.01, 2.0),
    "crowd.neighbor_dist": (0.1, 100.0),
    "crowd.max_neighbors": (0, 100),
    "crowd.time_horizon": (0.1, 30.0),
    "crowd.time_horizon_obst": (0.1, 30.0),
    "crowd.safety_space": (0.0, 1.0),
    "crowd.emotion_probs": (3, 0.0, 1.0),
    "crowd.emotion_change_period": (0.1, 100.0),
    "reward.collision": (-100.0, 0.0),  # a penalty
    "reward.discomfort": (-100.0, 0.0),  # a penalty, once per step in a zone
    "reward.goal": (0.0, 100.0),
    "reward.progress_gain": (0.0, 100.0),  # [1/m]
    "reward.static_discomfort": (0.0, 3.0),
    "reward.happy_discomfort": (0.0, 3.0),
    "reward.neutral_discomfort": (0.0, 3.0),
    "reward.negative_discomfort": (0.0, 3.0),
    "episode.max_steps": (1, 100000),
    "episode.goal_radius": (0.01, 2.0),
    "episode.eval_goal_radius": (0.01, 2.0),
    "episode.discount": (0.0, 1.0),
    "dwa.speed_samples": (2, 101),
    "dwa.heading_samples": (2, 101),
    "dwa.horizon_steps": (1, 50),
    "dwa.goal_weight": (0.0, 1e4),  # weights as the MPC's: >= 0, bounded
    "dwa.clearance_weight": (0.0, 1e4),
    "dwa.discomfort_weight": (0.0, 1e4),
    "dwa.speed_weight": (0.0, 1e4),
    "dwa.clearance_cap": (0.01, 10.0),
    "dwa.safety_margin": (0.0, 2.0),
    "dwa.hard_steps": (1, 50),
    "walking.step_width": (0.1, 0.5),
    "walking.clearance": (0.01, 0.3),
    "walking.touchdown_speed": (0.0, 1.0),
    "walking.early_touchdown": (0.5, 1.0),
    "walking.touchdown_tolerance": (0.0, 0.05),
    "walking.stand_com_lead": (-0.1, 0.1),
    "walking.speed_integral_limit": (0.0, 0.5),
    "walking.heading_blend_fraction": (0.1, 1.0),
    "walking.swing_yaw_blend_fraction": (0.1, 1.0),
    "walking.swing_finish_fraction": (0.3, 1.0),
    "walking.target_freeze_fraction": (0.1, 1.0),
    "walking.prediction_fraction": (0.0, 1.0),
    "walking.torso_height": (0.7, 1.1),
    "walking.torso_pitch": (-0.5, 0.5),
    "walking.stand_time": (0.0, 1.0e6),
    "walking.speed_integral_gain": (0.0, 1.0),
    "walking.lateral_step_min": (0.0, 0.5),
    "walking.lateral_step_max": (0.1, 1.0),
    "walking.max_step_length": (0.05, 1.0),
    "walking.lambda_orientation": (0.0, 200.0),
    "walking.lambda_height": (0.0, 200.0),
    "walking.lambda_horizontal": (0.0, 200.0),
    "walking.lambda_swing": (0.0, 200.0),
    "walking.kd_leg": (6, 0.0, 1000.0),
    "walking.kd_arm": (0.0, 1000.0),
    "walking.kp_arm": (0.0, 10000.0),
    "walking.ankle_torque_fraction": (0.0, 1.0),
    "walking.planner_period": (0.001, 0.1),
    "walking.controller_period": (0.0002, 0.02),
    "walking.time_step": (0.0002, 0.005),
    "walking.friction": (0.1, 2.0),
    "walking.fall_height": (0.2, 1.0),
    "walking.fall_check_period": (0.0002, 0.01),
    "mpc.horizon_steps": (2, 40),
    "mpc.scp_iterations": (1, 20),
    "mpc.goal_weight": (0.0, 1e4),
    "mpc.terminal_weight": (0.0, 1e4),
    "mpc.reference_lead": (0.0, 100.0),
    "mpc.guide_resolution": (0.01, 1.0),
    "mpc.guide_padding": (0.5, 50.0),
    "mpc.guide_zone_cost": (1.0, 100.0),
    "mpc.speed_smoothness_weight": (0.0, 1e4),
    "mpc.turn_smoothness_weight": (0.0, 1e4),
    "mpc.turn_weight": (0.0, 1e4),
    "mpc.discomfort_weight": (0.0, 1e6),
    "mpc.collision_weight": (0.0, 1e6),
    "mpc.slack_quadratic_weight": (1e-6, 1e4),
    "mpc.prediction_discount": (0.01, 1.0),
    "mpc.collision_margin": (0.0, 1.0),
    "mpc.discomfort_margin": (0.0, 1.0),
    "mpc.hard_pedestrian_steps": (0, 40),
    "mpc.trust_region": (0.01, math.pi),
    "mpc.seed_headings": (1, 41),
    "mpc.seed_max_offset": (0.0, math.pi),
    "mpc.previous_plan_bonus": (0.0, 1.0),
    "mpc.fallback_speed_scale": (0.0, 1.0),
    "mpc.osqp_eps": (1e-8, 1e-1),
    "mpc.osqp_max_iter": (10, 100000),
    "mpc.time_limit": (1e-4, 10.0),
}


# A scenario file (`core.scenario.Scenario`): the same ranges as the configuration's robot
# start and goal and emotion change period. Seed −1: written by hand.
SCENARIO_RANGES: dict[str, Any] = {
    "robot_start": RANGES["robot.start"],
    "robot_goal": RANGES["robot.goal"],
    "robot_heading": (-2 * math.pi, 2 * math.pi),
    "emotion_change_period": RANGES["crowd.emotion_change_period"],
    "seed": (-1, SEED_RANGE[1]),
}
# Its pedestrians (`PedestrianSpec`) and obstacles (`StaticDiscSpec`): in the robot's world.
MAX_GROUPS = 20  # group numbers 0 … 20 (a scenario holds at most 20 pedestrians)
PEDESTRIAN_RANGES: dict[str, Any] = {
    "start": RANGES["robot.start"],
    "goal": RANGES["robot.start"],
    "waypoints": (None, *RANGES["robot.start"][1:]),  # any number of points [x, y]
    "speed": (0.05, 2.0),  # [m/s] walking; 1.0 is the paper's "high walking speed"
    "stand_time": (0.0, 1000.0),  # [s]
    "start_delay": (0.0, 1000.0),  # [s]
    "group": (-1, MAX_GROUPS),
}
OBSTACLE_RANGES: dict[str, Any] = {
    "center": RANGES["robot.start"],
    "radius": (0.01, 5.0),  # a hand-placed disc may be larger than the sampler's
}
WALL_RANGES: dict[str, Any] = {
    "start": RANGES["robot.start"],
    "end": RANGES["robot.start"],
}

# An emotion estimate (`perception.noisy_emotions.EmotionEstimateParams`) and its head
# camera; the confusion matrix's rows must also sum to 1 (`validate_confusion`).
ESTIMATE_RANGES: dict[str, Any] = {
    "confusion": (3, 0.0, 1.0),
    "seed": SEED_RANGE,
    "period": (0.01, 100.0),  # [s]
    "camera.width": (16, 4096),  # [px]
    "camera.height": (16, 4096),  # [px]
    "camera.fov_y_deg": (1.0, 170.0),  # [deg]
    "camera.lip_height": (0.1, 3.0),  # [m]
    "camera.digit_offset": (3, -2.0, 2.0),  # [m]
    "camera.near": (0.001, 100.0),  # [m]
    "camera.far": (0.01, 1000.0),  # [m]
    "camera.min_face_size": (8, 4096),  # [px]
    "camera.max_range": (0.1, 100.0),  # [m]
}
