"""Every command of the README's first block of `emonav` commands ("First commands") runs
and exits 0, as a new user would type it from the repository's root."""

import re
import shlex
from pathlib import Path

import pytest

from emonav_drake.cli import main

ROOT = Path(__file__).resolve().parent.parent
README = ROOT / "README.md"

_BASH_BLOCK = re.compile(r"^```bash\n(.*?)^```", re.S | re.M)
_ACTIVATE = ["source", ".venv/bin/activate"]


def _commands(block: str) -> list[list[str]]:
    """The block's commands as argv lists: comments dropped, `\\` continuations joined."""
    text = re.sub(r"\\\n", " ", block)
    return [argv for line in text.splitlines() if (argv := shlex.split(line, comments=True))]


def first_command_block(text: str) -> list[list[str]]:
    """The commands of the first bash block that runs `emonav`."""
    for block in _BASH_BLOCK.findall(text):
        commands = _commands(block)
        if any(argv[0] == "emonav" for argv in commands):
            return commands
    raise AssertionError("README.md has no bash block of emonav commands")


COMMANDS = first_command_block(README.read_text())


def test_the_first_block_is_a_handful_of_emonav_commands():
    emonav = [argv for argv in COMMANDS if argv != _ACTIVATE]
    assert all(argv[0] == "emonav" for argv in emonav), emonav
    assert 4 <= len(emonav) <= 6


@pytest.mark.parametrize(
    "argv", [a for a in COMMANDS if a[0] == "emonav"], ids=lambda a: " ".join(a[1:])
)
def test_a_first_command_runs(argv, monkeypatch, capsys):
    monkeypatch.chdir(ROOT)  # paths in the README are relative to the repository
    assert main(argv[1:]) == 0
    assert capsys.readouterr().out.strip()  # it printed something


def test_the_parser_reads_comments_and_continuations():
    block = "source .venv/bin/activate\nemonav sim --seed 7  # one episode\nemonav a \\\n  --b c\n"
    assert _commands(block) == [
        _ACTIVATE,
        ["emonav", "sim", "--seed", "7"],
        ["emonav", "a", "--b", "c"],
    ]
