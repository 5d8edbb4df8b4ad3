"""Write `emonav_drake/data/policies/catalog.json` from the shipped checkpoints.

    python scripts/write_policy_catalog.py [--check]

Every `.pt` under `emonav_drake/data/` is loaded (torch) and described
(`planners/catalog.py::describe_checkpoint`: hash, size, what it reads, route, teacher,
stages, run directory). `--check` writes nothing and exits 1 when the catalog differs from
the checkpoints (the test suite runs the same comparison).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from emonav_drake.atomic_io import write_text_atomic  # noqa: E402
from emonav_drake.planners.catalog import (  # noqa: E402
    CATALOG_FILE,
    DATA_DIR,
    catalog_key,
    describe_checkpoint,
)
from emonav_drake.provenance import sha256_file  # noqa: E402
from emonav_drake.torch_load import load_checked  # noqa: E402


def catalog() -> dict:
    """The catalog the shipped checkpoints give."""
    entries = {}
    for path in sorted(DATA_DIR.rglob("*.pt")):
        blob = load_checked(path)
        entries[catalog_key(path)] = describe_checkpoint(
            blob, sha256_file(path), path.stat().st_size
        )
    return {"format": 1, "checkpoints": entries}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--check", action="store_true", help="compare, write nothing")
    args = ap.parse_args()
    text = json.dumps(catalog(), indent=1, ensure_ascii=False) + "\n"
    if args.check:
        same = CATALOG_FILE.is_file() and CATALOG_FILE.read_text() == text
        print("catalog up to date" if same else f"{CATALOG_FILE} differs from the checkpoints")
        return 0 if same else 1
    write_text_atomic(CATALOG_FILE, text)
    print(f"wrote {CATALOG_FILE}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
