import dataclasses as dc
import re

import pytest

from emonav_drake.config_notes import (
    annotate_yaml,
    describe,
    dump_annotated_yaml,
    field_notes,
    undocumented_fields,
)
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


# --- field notes and the annotated dump (`emonav config --dump`) ------------------------------


@dc.dataclass
class _Inner:
    """Inner part.

    More text that is not the description.
    """

    a: float = 1.0  # trailing note [m]
    # a comment line
    # continued above
    b: list[float] = dc.field(default_factory=lambda: [1.0, 2.0])
    c: str = "x"


@dc.dataclass
class _Outer:
    """Outer."""

    inner: _Inner = dc.field(default_factory=_Inner)
    d: list[float] = dc.field(  # note on the first line of a wrapped field
        default_factory=lambda: [3.0]
    )


def _strip_comments(text: str) -> list[str]:
    """The YAML lines of `text` without comment lines, blank lines and trailing comments."""
    return [
        re.sub(r"  # .*$", "", line)
        for line in text.splitlines()
        if line.strip() and not line.lstrip().startswith("#")
    ]


def test_field_notes_read_the_source_comments():
    assert field_notes(_Inner) == {
        "a": "trailing note [m]",
        "b": "a comment line continued above",
    }
    assert field_notes(_Outer) == {"d": "note on the first line of a wrapped field"}
    assert describe(_Inner) == "Inner part." and describe(_Outer) == "Outer."
    assert undocumented_fields(_Outer) == ["inner.c"]
    assert dump_annotated_yaml(_Outer()) == (
        "# Outer.\n"
        "\n"
        "# Inner part.\n"
        "inner:\n"
        "  a: 1.0  # trailing note [m]\n"
        "  b: [1.0, 2.0]  # a comment line continued above\n"
        "  c: x\n"
        "d: [3.0]  # note on the first line of a wrapped field\n"
    )
    # a scalar continued on the next line keeps no comment (it would end the scalar)
    assert annotate_yaml(_Inner, "a: long\n  words\nc: x\n") == "a: long\n  words\nc: x\n"


@pytest.mark.parametrize(
    "yaml_text",
    [None, "robot: {max_speed: 0.3, start: [-3.0, 0.5]}\nwalking: {arms: held}\n"],
)
def test_annotated_dump_is_the_bare_yaml_with_comments_and_loads_back(yaml_text):
    config = load_config(data=yaml_text) if yaml_text else load_config()
    text = dump_annotated_yaml(config)
    assert load_config(data=text) == config
    assert _strip_comments(text) == dump_config(config).splitlines()
    assert "  step_time: 0.4  # T, one walking step [s]\n" in text
    assert "# The reduced-order (LIP) robot and its command bounds" in text.split("\nrobot:\n")[0]
    assert "\n# Full-order Digit walking: gait, ALIP planner" in text.split("\nwalking:\n")[0]


def test_every_config_field_has_a_note_with_a_meaning():
    """New fields of `EmoNavConfig` must be documented by a comment in `params.py`."""
    assert undocumented_fields(EmoNavConfig) == []
    for section in dc.fields(EmoNavConfig):
        for name, note in field_notes(section.type).items():
            meaning = re.sub(r"\[[^\]]*\]", "", note)  # drop the units in brackets
            assert re.search(r"[A-Za-z]{2}", meaning), f"{section.name}.{name}: {note!r}"


def test_config_cli_dump_is_annotated_and_bare_on_request(capsys):
    from emonav_drake.cli import main
    from emonav_drake.configs import SETTINGS, load_setting

    for name in SETTINGS:
        assert main(["config", "--dump", "--setting", name]) == 0
        text = capsys.readouterr().out
        assert load_config(data=text) == load_setting(name)
        assert "  # discomfort distance of negative pedestrians [m]\n" in text
    assert main(["config", "--bare"]) == 0
    assert capsys.readouterr().out == (
        f"# emonav configuration: the default configuration\n{dump_config(load_config())}"
    )
