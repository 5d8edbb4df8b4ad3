"""Exceptions shared by the library and the `emonav` command line.

The CLI maps them to exit codes: a `UserError` (`ConfigError`, `PolicyError`,
`OutputPathError`, …, raised where an input is checked) is a user error — one line naming
the culprit, exit code 2; `RunInterrupted` is a Ctrl-C that was handled — whatever
finished was saved, one line saying where, exit code 130. Any other exception, a plain
`ValueError` or numpy's `LinAlgError` from deep inside a simulation included, is a bug:
exit code 1.
"""

from __future__ import annotations


class UserError(Exception):
    """An input the user can fix: a flag, a file, a field, an output path, a checkpoint.

    Raised where the input is checked, with a message that names the culprit and says
    what is allowed. The concrete errors also derive from `ValueError` (what a library
    user catching bad input expects), but only this type makes the CLI call an error the
    user's: a `ValueError` raised anywhere else is a bug.
    """


class RunInterrupted(Exception):
    """A long run (training, evaluation, benchmark) stopped on SIGINT after saving.

    Args:
        message: one line: what was saved and how to resume (e.g. "interrupted at step
            1500; checkpoint saved in runs/sac; continue with --resume runs/sac").
    """


class UsageError(UserError, ValueError):
    """A flag value or an input file that a command refuses (e.g. `--every 0`, an image
    that cannot be read): the message names the flag or file and what is allowed."""


class PluginError(UserError, RuntimeError):
    """A planner of the user's own (from `--planner-module` or an entry point) failed in
    its own code: it raised, returned no command, or hung. The message names the planner
    and its module; the fault is in that module, not in the package (exit code 2)."""


def did_you_mean(word: str, choices: object) -> str:
    """The hint " (did you mean 'x'?)" naming the choice closest to a mistyped `word`
    (difflib's ratio ≥ 0.6), or "" when none is close: for error messages."""
    import difflib

    close = difflib.get_close_matches(str(word), [str(c) for c in choices], n=1, cutoff=0.6)
    return f" (did you mean {close[0]!r}?)" if close else ""
