"""Exceptions shared by the library and the `emonav` command line.

The CLI maps them to exit codes: a `ValueError` family error (`ConfigError`,
`PolicyError`, `CommandError`, …) is a user error — one line naming the culprit, exit
code 2; `RunInterrupted` is a Ctrl-C that was handled — whatever finished was saved, one
line saying where, exit code 130.
"""

from __future__ import annotations


class RunInterrupted(Exception):
    """A long run (training, evaluation, benchmark) stopped on SIGINT after saving.

    Args:
        message: one line: what was saved and how to resume (e.g. "interrupted at step
            1500; checkpoint saved in runs/sac; continue with --resume runs/sac").
    """
