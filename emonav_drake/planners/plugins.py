"""Planners from outside the package: installed plug-ins and modules named on the command line.

A planner module is any Python module that calls `planners.register(PlannerKind(...))`
when it is imported (`docs/howto/planner.md`, `examples/cautious_planner.py`). Two ways
make its planners known without editing the package:

* **an installed plug-in**: a distribution that declares an entry point in the group
  `emonav_drake.planners` (in its `pyproject.toml`, the table
  `[project.entry-points."emonav_drake.planners"]` with a line such as
  `cautious = "my_package.cautious"`). Every such module is imported once, when
  `emonav_drake.planners` is first imported (`load_entry_points`);
* **a module named per run**: `--planner-module MODULE` on `emonav sim|eval|benchmark|
  train|planners|diagnose|digit-rounds`, a dotted module name importable by Python (on
  `PYTHONPATH`) or the path of a `.py` file (`import_planner_module`). A benchmark
  records the modules in its settings, and every worker (a Ray actor, on this machine or
  a cluster) imports them before it builds a planner; a DAgger route records them in its
  configuration (`DaggerConfig.planner_modules`), so `--resume` knows its expert.

Code runs only from the command line (issue 46): a data file that names planner modules
(a benchmark's `settings.json`, a route's YAML, a training run's saved state, the source
run of `emonav digit-rounds`) is refused unless the same modules are given with
`--planner-module` (`require_named_on_command_line`, called by each command after it reads
the file and before anything is imported). A benchmark records each module's content too
(`modules_sha256`), so a run continued with a changed plug-in is refused.
"""

from __future__ import annotations

import hashlib
import importlib
import importlib.util
import logging
import shlex
import sys
from collections.abc import Sequence
from importlib.metadata import entry_points
from pathlib import Path

from emonav_drake.params import ConfigError

log = logging.getLogger(__name__)

ENTRY_POINT_GROUP = "emonav_drake.planners"


def load_entry_points() -> list[str]:
    """Import every installed plug-in module of `ENTRY_POINT_GROUP`; returns their names.

    A plug-in that fails to import is reported (a warning naming it and the error) and
    skipped: a broken third-party package must not stop the built-in planners."""
    loaded = []
    for ep in entry_points(group=ENTRY_POINT_GROUP):
        try:
            ep.load()
        except Exception as e:  # noqa: BLE001 - any error of someone else's module
            log.warning("planner plug-in %s (%s) not loaded: %s: %s", ep.name, ep.value,
                        type(e).__name__, e)  # fmt: skip
            continue
        loaded.append(ep.name)
    return loaded


def import_planner_module(spec: str) -> str:
    """Import the planner module `spec` (a `.py` path or a dotted module name) once and
    return what a run records of it: the file's absolute path, or the module name.

    Raises `ConfigError` naming the module when it cannot be found or fails to import
    (the error it raised is in the message)."""
    spec = str(spec).strip()
    if not spec:
        raise ConfigError("--planner-module: give a module name or a .py file")
    if is_file_spec(spec):
        path = Path(recorded_form(spec))
        if not path.is_file():
            raise ConfigError(f"--planner-module {spec}: no such file")
        # one stable module name per file, so a second import is the same module
        digest = hashlib.sha256(str(path).encode()).hexdigest()[:12]
        name = f"emonav_user_planner_{path.stem}_{digest}"
        if name not in sys.modules:
            loader_spec = importlib.util.spec_from_file_location(name, path)
            if loader_spec is None or loader_spec.loader is None:
                raise ConfigError(f"--planner-module {spec}: not a Python module")
            module = importlib.util.module_from_spec(loader_spec)
            sys.modules[name] = module
            try:
                loader_spec.loader.exec_module(module)
            except Exception as e:
                del sys.modules[name]
                raise _import_failed(spec, e) from e
        return str(path)
    try:
        importlib.import_module(spec)
    except ModuleNotFoundError as e:
        raise ConfigError(
            f"--planner-module {spec}: no such module ({e}); give a dotted name on "
            "PYTHONPATH or the path of a .py file"
        ) from None
    except Exception as e:
        raise _import_failed(spec, e) from e
    return spec


def _import_failed(spec: str, e: Exception) -> ConfigError:
    """The error of a planner module whose own code raised `e` while it was imported."""
    return ConfigError(f"--planner-module {spec}: importing it failed: {type(e).__name__}: {e}")


def import_planner_modules(specs: list[str] | tuple[str, ...]) -> list[str]:
    """`import_planner_module` for each; the recorded forms, in order."""
    return [import_planner_module(s) for s in specs]


def is_file_spec(spec: str) -> bool:
    """Whether the module spec `spec` names a file (a `.py` path) rather than a dotted
    module name."""
    return spec.endswith(".py") or "/" in spec or "\\" in spec


def recorded_form(spec: str) -> str:
    """What a run records of the module spec `spec`, without importing it: a `.py` path
    resolved to an absolute path (relative to the working directory), a dotted module
    name as given (stripped). Two specs name the same module when these are equal."""
    spec = str(spec).strip()
    if is_file_spec(spec):
        return str(Path(spec).expanduser().resolve())
    return spec


def module_sha256(recorded: str) -> str | None:
    """The sha256 of a planner module's source, in hex: of the `.py` file's bytes, or for
    a dotted module of its `__file__` (an imported module's; else the file Python's finder
    names, which may import its parent packages). None when there is no source file (a
    namespace package, a built-in module) or it cannot be read."""
    from emonav_drake.provenance import sha256_file

    recorded = str(recorded).strip()
    if is_file_spec(recorded):
        file: str | None = recorded_form(recorded)
    else:
        module = sys.modules.get(recorded)
        file = getattr(module, "__file__", None) if module is not None else None
        if module is None:
            try:
                found = importlib.util.find_spec(recorded)
            except (ImportError, ValueError):
                found = None
            file = found.origin if found is not None and found.has_location else None
    if not file or not Path(file).is_file():
        return None
    try:
        return sha256_file(file)
    except OSError:
        return None


def modules_sha256(recorded: Sequence[str]) -> dict[str, str | None]:
    """`module_sha256` of each recorded module spec, by spec (what a benchmark's settings
    record as `planner_modules_sha256`)."""
    return {str(m): module_sha256(m) for m in recorded}


def require_named_on_command_line(
    recorded: object,
    given: Sequence[str],
    source: str | Path,
    field: str = "planner_modules",
) -> list[str]:
    """Refuse a data file that names planner modules not given on the command line.

    `recorded` is the value of `field` read from the file `source` (None or absent: no
    modules); `given` are the `--planner-module` values of the command line. A `.py` path
    is compared as an absolute path (`recorded_form`: relative to the working directory),
    a dotted name as a string. Nothing is imported here. Returns the recorded modules in
    their recorded form (absolute paths), in order.

    Raises `ConfigError`, one line naming `source`, `field` and the `--planner-module`
    flags to add, when a recorded module is not among `given` (or `field` is not a list
    of module names)."""
    if recorded is None:
        return []
    if not (
        isinstance(recorded, (list, tuple))
        and all(isinstance(m, str) and m.strip() for m in recorded)
    ):
        raise ConfigError(
            f"{source}: {field} = {recorded!r} is not a list of planner modules (.py paths "
            "or dotted module names)"
        )
    named = {recorded_form(g) for g in given}
    missing = [m for m in recorded if recorded_form(m) not in named]
    if missing:
        flags = " ".join(f"--planner-module {shlex.quote(m)}" for m in missing)
        raise ConfigError(
            f"{source}: {field} names {', '.join(missing)}; code is imported only from the "
            f"command line: add {flags}"
        )
    return [recorded_form(m) for m in recorded]
