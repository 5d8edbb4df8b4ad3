"""Reading JSON a user gives: one function, one kind of error.

`json.loads` fails in more ways than `ValueError`: text nested too deeply (`[[[[…`, a
hundred thousand levels) raises `RecursionError`, bytes that are not UTF-8 raise
`UnicodeDecodeError` (a `ValueError`, but with a message naming no file). Every JSON file
the CLI reads — a run's `settings.json` and `trials.jsonl`, calibration traces, a
step-response model, an `emonav sim --json` trajectory — goes through `parse_json` (one
document or one line, `where` names it) or `read_json` (a file): any decode failure
becomes a `JsonInputError` (a `ConfigError`: the CLI prints one line naming the file,
and the line of a JSON-lines file, exit code 2). What the value means is the caller's to
check.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from emonav_drake.params import ConfigError


class JsonInputError(ConfigError):
    """A JSON file (or line) the CLI was given cannot be decoded."""


def parse_json(text: str | bytes, where: str, what: str = "not valid JSON") -> Any:
    """The value of the JSON document `text`; `JsonInputError` "`where`: `what`: why" for
    anything that does not decode (`where` a file or `FILE:LINE`): bad syntax, bytes that
    are not UTF-8, nesting deeper than Python's recursion limit."""
    try:
        return json.loads(text)
    except RecursionError:
        problem = "nested too deeply (arrays or objects inside each other, ~1000 levels or more)"
    except UnicodeDecodeError as e:
        problem = f"not UTF-8 text (byte {e.start}: binary content?)"
    except json.JSONDecodeError as e:
        problem = f"{e.msg} at line {e.lineno} column {e.colno}"
    except ValueError as e:  # what else the decoder may refuse
        problem = str(e)
    raise JsonInputError(f"{where}: {what}: {problem}")


def read_json(path: str | Path, what: str = "not valid JSON") -> Any:
    """The JSON value of the file `path` (`parse_json`); `OSError` if it cannot be read."""
    path = Path(path)
    return parse_json(path.read_bytes(), str(path), what)
