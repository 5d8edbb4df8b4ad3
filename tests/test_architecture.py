"""The architecture rule (docs/architecture.md): the math in core/ is numpy only."""

import ast
from pathlib import Path

CORE = Path(__file__).resolve().parents[1] / "emonav_drake" / "core"
FORBIDDEN = ("pydrake", "torch", "gymnasium", "cv2", "mujoco")


def test_core_imports_no_drake_torch_or_gym():
    offenders = []
    for path in CORE.glob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            names = []
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.module:
                names = [node.module]
            offenders += [f"{path.name}: {n}" for n in names if n.split(".")[0] in FORBIDDEN]
    assert not offenders, offenders
    assert len(list(CORE.glob("*.py"))) >= 10
