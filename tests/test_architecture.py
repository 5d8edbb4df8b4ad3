"""The architecture rules (docs/architecture.md), read from the package's own imports.

1. The maths folders (`MATHS`) are numpy only (no Drake, torch, Gymnasium, OpenCV).
2. Every import points down the layer table below (or stays within its layer), including
   imports made inside functions.
3. No import cycle between the package's modules.
"""

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "emonav_drake"
# The numpy maths, one folder per concept; `core` only forwards its old module names.
MATHS = ("scenarios", "crowd", "sensing", "robot", "navigation", "planning", "core")
FORBIDDEN_IN_MATHS = ("pydrake", "torch", "gymnasium", "cv2", "mujoco")

# Bottom to top: a module may import its own layer and the layers below it, never above.
# A layer is named by the package's top-level module or folder.
LAYERS: list[tuple[str, frozenset[str]]] = [
    (
        "base",
        frozenset(
            {
                "__init__",
                "errors",
                "params",
                "typed_yaml",
                "config_fields",
                "params_robot",
                "params_crowd",
                "params_planners",
                "atomic_io",
                "json_input",
                "torch_load",
                "torch_device",
                "run_lock",
                "provenance",
                "progress",
                "watchdog",
                "registry",
                "parallel",
                "configs",
                "models",
                "palette",
            }
        ),
    ),
    ("maths", frozenset(MATHS)),
    ("perception", frozenset({"perception"})),
    ("planners", frozenset({"planners"})),
    ("systems", frozenset({"systems"})),
    ("diagrams", frozenset({"diagrams"})),
    ("learning", frozenset({"learning"})),
    ("evaluation", frozenset({"evaluation"})),
    ("cli", frozenset({"cli"})),
]
_RANK = {name: i for i, (_, names) in enumerate(LAYERS) for name in names}


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
    if parts[-1] == "__init__" and len(parts) > 1:
        parts = parts[:-1]
    return ".".join(parts)


def _modules() -> dict[str, Path]:
    return {_module_name(p): p for p in PACKAGE.rglob("*.py") if "__pycache__" not in p.parts}


def _imports(path: Path, name: str, modules: set[str]) -> set[str]:
    """The package modules `path` imports (resolved to the module, not the attribute)."""
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text())):
        targets: list[str] = []
        if isinstance(node, ast.Import):
            targets = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[: len(package.split(".")) - node.level + 1]
                mod = ".".join(base + ([node.module] if node.module else []))
            else:
                mod = node.module or ""
            targets = [mod] + [f"{mod}.{a.name}" for a in node.names]
        for t in targets:
            while t and t not in modules:
                t = t.rpartition(".")[0]
            if t and t != name:
                found.add(t)
    return found


def import_graph() -> dict[str, set[str]]:
    """Module → the package modules it imports, anywhere in its source."""
    mods = _modules()
    names = set(mods)
    return {m: _imports(p, m, names) for m, p in mods.items()}


def layer_of(module: str) -> int:
    """The rank of a module's layer (`LAYERS`); KeyError names an unplaced module."""
    parts = module.split(".")
    top = parts[1] if len(parts) > 1 else "__init__"
    if top.startswith("cli"):
        top = "cli"
    if top not in _RANK:
        raise KeyError(f"{module}: no layer in LAYERS; place its folder or module there")
    return _RANK[top]


def upward_imports(graph: dict[str, set[str]]) -> list[str]:
    return sorted(
        f"{a} -> {b}" for a, targets in graph.items() for b in targets if layer_of(b) > layer_of(a)
    )


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph.get(v, ())):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                found.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return found


def _maths_files() -> list[Path]:
    return [p for folder in MATHS for p in (PACKAGE / folder).glob("*.py")]


def test_maths_import_no_drake_torch_or_gym():
    offenders = []
    for path in _maths_files():
        for node in ast.walk(ast.parse(path.read_text())):
            names = []
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.module:
                names = [node.module]
            offenders += [
                f"{path.relative_to(PACKAGE)}: {n}"
                for n in names
                if n.split(".")[0] in FORBIDDEN_IN_MATHS
            ]
    assert not offenders, offenders
    assert len(_maths_files()) >= 40


def test_every_module_has_a_layer():
    modules = list(_modules())
    assert len(modules) > 100  # the package was read
    unplaced = []
    for module in modules:
        try:
            layer_of(module)
        except KeyError as e:
            unplaced.append(str(e))
    assert unplaced == []


@pytest.mark.slow
def test_every_import_points_down():
    graph = import_graph()
    assert sum(len(t) for t in graph.values()) > 200  # the graph was read, not empty
    assert upward_imports(graph) == []


@pytest.mark.slow
def test_no_import_cycle():
    assert cycles(import_graph()) == []


@pytest.mark.parametrize(
    ("graph", "upward", "cyclic"),
    [
        # a system importing learning is upward; a two-module cycle is a cycle
        (
            {
                "emonav_drake.systems.a": {"emonav_drake.learning.b"},
                "emonav_drake.learning.b": set(),
            },
            ["emonav_drake.systems.a -> emonav_drake.learning.b"],
            [],
        ),
        (
            {
                "emonav_drake.learning.a": {"emonav_drake.learning.b"},
                "emonav_drake.learning.b": {"emonav_drake.learning.a"},
            },
            [],
            [["emonav_drake.learning.a", "emonav_drake.learning.b"]],
        ),
        # downward and same-layer imports pass
        (
            {
                "emonav_drake.evaluation.a": {"emonav_drake.crowd.b", "emonav_drake.evaluation.c"},
                "emonav_drake.evaluation.c": {"emonav_drake.params"},
            },
            [],
            [],
        ),
    ],
)
def test_the_checks_catch_what_they_forbid(graph, upward, cyclic):
    assert upward_imports(graph) == upward
    assert cycles(graph) == cyclic


def test_imports_inside_functions_count(tmp_path):
    src = tmp_path / "x.py"
    src.write_text("def f():\n    from emonav_drake.learning.env import map_key\n")
    mods = {"emonav_drake.systems.x", "emonav_drake.learning.env"}
    assert _imports(src, "emonav_drake.systems.x", mods) == {"emonav_drake.learning.env"}


def folder_shares() -> dict[str, float]:
    """Each sub-package's (and the top-level modules') share of the package's lines."""
    lines: dict[str, int] = {}
    for path in PACKAGE.rglob("*.py"):
        parts = path.relative_to(PACKAGE).parts
        key = parts[0] if len(parts) > 1 else "(top level)"
        lines[key] = lines.get(key, 0) + len(path.read_text().splitlines())
    total = sum(lines.values())
    return {k: v / total for k, v in sorted(lines.items(), key=lambda kv: -kv[1])}


def test_no_folder_holds_a_quarter_of_the_package():
    # core/ once held 24.7 % of the lines as one room of 39 modules; folders by concept
    shares = folder_shares()
    assert len(shares) >= 12
    folder, share = next(iter(shares.items()))
    assert share < 0.20, f"{folder}/ holds {share:.1%} of the package's lines"


def test_an_old_core_import_gives_the_moved_module_with_a_warning():
    import importlib
    import sys

    import emonav_drake.navigation.lip_world as lip_world
    from emonav_drake.core import MOVED

    sys.modules.pop("emonav_drake.core.navigation", None)
    with pytest.warns(DeprecationWarning, match=r"emonav_drake\.navigation\.lip_world"):
        old = importlib.import_module("emonav_drake.core.navigation")
    assert old is lip_world
    # every old name (the 45 modules core/ held) resolves to a maths module or the palette
    moved = {importlib.import_module(f"emonav_drake.{new}").__name__ for new in MOVED.values()}
    maths = {_module_name(p) for p in _maths_files()} | {"emonav_drake.palette"}
    assert len(moved) == 45 and moved <= maths
    with pytest.raises(ImportError):
        importlib.import_module("emonav_drake.core.no_such_module")
