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
  train`, a dotted module name importable by Python (on `PYTHONPATH`) or the path of a
  `.py` file (`import_planner_module`). A benchmark records the modules in its
  settings, and every worker (a Ray actor, on this machine or a cluster) imports them
  before it builds a planner; a DAgger route records them in its configuration
  (`DaggerConfig.planner_modules`), so `--resume` finds its expert again.
"""

from __future__ import annotations

import hashlib
import importlib
import importlib.util
import logging
import sys
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
    if spec.endswith(".py") or "/" in spec or "\\" in spec:
        path = Path(spec).expanduser().resolve()
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
