"""What a user error looks like on the command line, for the CLI tests."""

from __future__ import annotations

from emonav_drake.cli import main


def run(capsys, *argv) -> tuple[int, str]:
    """main(argv) → (exit code, stderr)."""
    code = main([str(a) for a in argv])
    return code, capsys.readouterr().err


def assert_user_error(code: int, err: str, *culprits: str) -> str:
    """Exit 2, exactly one `emonav: error:` line naming every culprit, no traceback."""
    assert code == 2, err
    assert "Traceback" not in err
    lines = [line for line in err.splitlines() if line.startswith("emonav: error: ")]
    assert len(lines) == 1, err
    for culprit in culprits:
        assert culprit in lines[0], (culprit, lines[0])
    return lines[0]
