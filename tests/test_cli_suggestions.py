"""Errors that help (issue 51, item 5): a mistyped planner, family, setting, sub-command,
flag or configuration value names the closest valid one; an unknown flag of a sub-command
prints that sub-command's usage."""

from __future__ import annotations

import pytest

from emonav_drake.cli import main
from emonav_drake.errors import did_you_mean


def _argparse_error(capsys, *argv: str) -> str:
    with pytest.raises(SystemExit) as exit_info:
        main(list(argv))
    assert exit_info.value.code == 2
    return capsys.readouterr().err


@pytest.mark.parametrize(
    ("argv", "hint"),
    [
        (["sim", "--planner", "dwx"], "invalid choice: 'dwx' (did you mean 'dwa'?)"),
        (["sim", "--family", "ofice"], "invalid choice: 'ofice' (did you mean 'office'?)"),
        (["sim", "--setting", "var_d"], "invalid choice: 'var_d' (did you mean 'var_dd'?)"),
        (["simm"], "invalid choice: 'simm' (did you mean 'sim'?)"),
        (["sim", "--planer", "dwa"], "--planer (did you mean '--planner'?)"),
        (["benchmark", "--out", "x", "--trails", "3"], "--trails (did you mean '--trials'?)"),
    ],
)
def test_a_typo_names_the_closest_valid_word(capsys, argv, hint):
    err = _argparse_error(capsys, *argv)
    assert hint in err, err
    assert "Traceback" not in err


def test_an_unknown_flag_of_a_sub_command_prints_its_usage_not_the_top_level_one(capsys):
    err = _argparse_error(capsys, "sim", "--planer", "dwa")
    assert err.startswith("usage: emonav sim "), err
    assert "emonav sim: error: unrecognized arguments: --planer" in err


def test_nothing_close_gives_no_hint_and_still_lists_the_choices(capsys):
    err = _argparse_error(capsys, "sim", "--family", "zzzz")
    assert "did you mean" not in err and "choose from 'paper', " in err
    assert did_you_mean("zzzz", ["paper", "office"]) == ""


def test_an_unknown_benchmark_method_lists_every_planner_and_the_closest(capsys, tmp_path):
    code = main(["benchmark", "--planners", "policy,mcp", "--out", str(tmp_path / "b")])
    err = capsys.readouterr().err
    assert code == 2 and "unknown method 'mcp' (did you mean 'mpc'?)" in err
    for name in ("sarl", "rgl", "policy_shield", "emobipednav_mixed"):
        assert name in err
    assert not (tmp_path / "b").exists()


def test_a_mistyped_family_in_a_configuration_file_names_the_closest(capsys, tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("crowd: {family: ofice}\n")
    assert main(["sim", "--config", str(bad)]) == 2
    assert "crowd.family = 'ofice'" in (err := capsys.readouterr().err)
    assert "(did you mean 'office'?)" in err
