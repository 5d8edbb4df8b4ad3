"""The notebooks are committed with their outputs, so they read on a code host."""

import json
from pathlib import Path

NOTEBOOKS = sorted((Path(__file__).resolve().parent.parent / "notebooks").glob("*.ipynb"))


def test_every_notebook_is_committed_executed_with_its_figures():
    assert len(NOTEBOOKS) >= 3
    for path in NOTEBOOKS:
        cells = [c for c in json.loads(path.read_text())["cells"] if c["cell_type"] == "code"]
        counts = [c.get("execution_count") for c in cells]
        # every code cell ran, in order, in one kernel
        assert counts == list(range(1, len(cells) + 1)), path.name
        outputs = [o for c in cells for o in c.get("outputs", [])]
        assert not [o for o in outputs if o.get("output_type") == "error"], path.name
        assert any("image/png" in o.get("data", {}) for o in outputs), path.name
