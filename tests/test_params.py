import dataclasses as dc
import re

import pytest

from emonav_drake.config_fields import (
    annotate_yaml,
    describe,
    dump_annotated_yaml,
    field_doc,
    field_range,
    field_unit,
    setting,
    undocumented_fields,
)
from emonav_drake.params import ConfigError, EmoNavConfig, dump_config, load_config
from emonav_drake.typed_yaml import validate_fields


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


# --- fields that describe themselves, and the annotated dump (`emonav config --dump`) -----


@dc.dataclass
class _Inner:
    """Inner part.

    More text that is not the description.
    """

    a: float = setting(1.0, "a length", "m", (0.0, 2.0))
    b: list[float] = setting([1.0, 2.0], "two numbers", "", (2, -5.0, 5.0))
    c: str = setting("x", "")


@dc.dataclass
class _Outer:
    """Outer."""

    inner: _Inner = setting(factory=_Inner)
    d: list[float] = setting([3.0], "any number of them", "s", (None, 0.0, 10.0))
    e: int = setting(1, "at least one", "", (1, None))


def _strip_comments(text: str) -> list[str]:
    """The YAML lines of `text` without comment lines, blank lines and trailing comments."""
    return [
        re.sub(r"  # .*$", "", line)
        for line in text.splitlines()
        if line.strip() and not line.lstrip().startswith("#")
    ]


def test_a_setting_carries_its_doc_unit_and_range():
    assert (field_doc(_Inner, "a"), field_unit(_Inner, "a"), field_range(_Inner, "a")) == (
        "a length",
        "m",
        (0.0, 2.0),
    )
    assert field_range(_Outer, "inner.b") == (2, -5.0, 5.0)  # dotted: a nested field
    assert field_doc(_Outer, "inner") == "Inner part."  # a section: its class's description
    assert _Inner().b == [1.0, 2.0] and _Inner().b is not _Inner().b  # a fresh list each
    assert describe(_Inner) == "Inner part." and describe(_Outer) == "Outer."
    assert undocumented_fields(_Outer) == ["inner.c"]
    with pytest.raises(TypeError):
        setting()  # neither a default nor a factory
    for bounds in [(2.0, 1.0), (2, 0.0, None), (1.0,)]:
        with pytest.raises(ValueError):
            setting(1.0, "a range of no form", "", bounds)


def test_validate_fields_reads_the_ranges_in_the_fields():
    validate_fields(_Outer())
    bad = [
        (_Outer(inner=_Inner(a=3.0)), "x.inner.a = 3.0 is out of range: allowed in [0.0, 2.0]"),
        (_Outer(inner=_Inner(b=[1.0])), "x.inner.b = [1.0] is invalid: must have 2 elements"),
        (_Outer(inner=_Inner(b=[1.0, 9.0])), "each element in [-5.0, 5.0]"),
        (_Outer(e=0), "x.e = 0 is out of range: allowed >= 1"),
        (_Outer(d=[1.0, -1.0]), "x.d = [1.0, -1.0] is out of range: each element in [0.0, 10.0]"),
        (_Outer(inner=_Inner(a=float("inf"))), "x.inner.a = inf is invalid: must be a finite"),
    ]
    for obj, message in bad:
        with pytest.raises(ConfigError, match=re.escape(message)):
            validate_fields(obj, "x.")


def test_the_annotated_dump_gives_each_fields_doc_unit_and_range():
    assert dump_annotated_yaml(_Outer()) == (
        "# Outer.\n"
        "\n"
        "# Inner part.\n"
        "inner:\n"
        "  a: 1.0  # a length [m]; in [0.0, 2.0]\n"
        "  b: [1.0, 2.0]  # two numbers; 2 values, each in [-5.0, 5.0]\n"
        "  c: x\n"
        "d: [3.0]  # any number of them [s]; each in [0.0, 10.0]\n"
        "e: 1  # at least one; >= 1\n"
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
    assert "  step_time: 0.4  # T, one walking step [s]; in [0.05, 2.0]\n" in text
    assert "# The reduced-order (LIP) robot and its command bounds" in text.split("\nrobot:\n")[0]
    assert "\n# Full-order Digit walking: gait, ALIP planner" in text.split("\nwalking:\n")[0]


def test_every_config_field_has_a_doc_with_a_meaning():
    """New fields of `EmoNavConfig` must be documented (`setting(default, doc, …)`)."""
    assert undocumented_fields(EmoNavConfig) == []
    for section in dc.fields(EmoNavConfig):
        for f in dc.fields(section.type):
            doc = f.metadata["doc"]
            assert re.search(r"[A-Za-z]{2}", doc), f"{section.name}.{f.name}: {doc!r}"
            assert "[" not in f.metadata["unit"], f"{section.name}.{f.name}: the unit bare"


def test_config_cli_dump_is_annotated_and_bare_on_request(capsys):
    from emonav_drake.cli import main
    from emonav_drake.configs import SETTINGS, load_setting

    for name in SETTINGS:
        assert main(["config", "--dump", "--setting", name]) == 0
        text = capsys.readouterr().out
        assert load_config(data=text) == load_setting(name)
        assert "  # discomfort distance of negative pedestrians [m]; in [0.0, 3.0]\n" in text
    assert main(["config", "--bare"]) == 0
    assert capsys.readouterr().out == (
        f"# emonav configuration: the default configuration\n{dump_config(load_config())}"
    )
