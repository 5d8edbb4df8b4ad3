import pytest

from emonav_drake.params import ConfigError, EmoNavConfig, dump_config, load_config


def test_defaults_are_the_papers_table_1():
    c = load_config()
    assert (c.robot.step_time, c.robot.com_height, c.robot.gravity) == (0.4, 1.02, 9.81)
    assert (c.lidar.num_beams, c.lidar.grid_size, c.lidar.max_range) == (1800, 100, 6.0)
    assert (c.episode.discount, c.lidar.num_frames, c.reward.static_discomfort) == (0.99, 9, 0.2)
    assert (c.episode.goal_radius, c.robot.max_speed, c.robot.max_heading_change) == (
        0.1,
        0.4,
        0.2,
    )
    assert (c.crowd.pedestrian_radius, c.robot.radius) == (0.3, 0.3)
    assert c.reward.emotion_distances() == (0.2, 0.35, 0.5)


def test_yaml_round_trip_and_override():
    c = load_config(data="robot: {max_speed: 0.3}\nlidar: {num_frames: 4}\n")
    assert c.robot.max_speed == 0.3 and c.lidar.num_frames == 4
    assert c.robot.step_time == 0.4  # untouched fields keep the defaults
    again = load_config(data=dump_config(c))
    assert again == c


@pytest.mark.parametrize(
    "yaml_text, field",
    [
        ("robot: {max_speed: -1.0}", "robot.max_speed"),
        ("lidar: {grid_size: 7}", "lidar.num_beams"),  # 1800 not divisible by 7
        ("crowd: {min_pedestrians: 5}", "crowd.min_pedestrians"),
        ("crowd: {emotion_probs: [0.5, 0.5, 0.5]}", "crowd.emotion_probs"),
        ("episode: {discount: 1.5}", "episode.discount"),
        ("robot: {start: [0.0]}", "robot.start"),
        ("crowd: {dt: 0.3}", "crowd.dt"),  # not a divisor of T = 0.4
    ],
)
def test_out_of_range_value_names_the_field(yaml_text, field):
    with pytest.raises(ConfigError, match=field.replace(".", r"\.")):
        load_config(data=yaml_text)


def test_unknown_field_and_wrong_type_are_clear(tmp_path):
    with pytest.raises(ConfigError, match="speedd"):
        load_config(data="robot: {max_speedd: 0.3}")
    with pytest.raises(ConfigError, match="num_frames"):
        load_config(data="lidar: {num_frames: 2.5}")
    with pytest.raises(ConfigError, match="no such file"):
        load_config(tmp_path / "missing.yaml")


def test_validate_catches_nan():
    c = EmoNavConfig()
    c.robot.com_height = float("nan")
    with pytest.raises(ConfigError, match="robot.com_height"):
        c.validate()
