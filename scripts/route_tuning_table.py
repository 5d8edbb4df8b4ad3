"""The route-tuning table (benchmarks/results/route_tuning/README.md): successes per family,
setting and planner, the failures' outcomes beside them, and each setting's total.

    python scripts/route_tuning_table.py benchmarks/results/route_tuning

A run directory is named SETTING_FAMILY, SETTING one of `SETTINGS` (its YAML beside it).
"""

from __future__ import annotations

import argparse
import collections
import json
from pathlib import Path

SETTINGS = ("A_plain", "B_default", "C_wide_los", "D_wide_los_long")
PLANNERS = ("dwa", "mpc", "policy")


def _cell(outcomes: collections.Counter) -> str:
    n, ok = sum(outcomes.values()), outcomes["success"]
    failed = ", ".join(f"{k} {v}" for k, v in sorted(outcomes.items()) if k != "success")
    return f"{ok}/{n}" + (f" ({failed})" if failed else "")


def table(root: Path) -> str:
    """The markdown table of every SETTING_FAMILY run directory under `root`."""
    cells: dict[tuple[str, str], dict[str, collections.Counter]] = {}
    totals = {s: collections.Counter() for s in SETTINGS}
    for d in sorted(p for p in root.iterdir() if (p / "trials.jsonl").exists()):
        setting = next((s for s in SETTINGS if d.name.startswith(s + "_")), None)
        if setting is None:
            continue
        per = cells.setdefault((d.name[len(setting) + 1 :], setting), {})
        for line in (d / "trials.jsonl").read_text().splitlines():
            t = json.loads(line)
            per.setdefault(t["method"], collections.Counter())[t["record"]["outcome"]] += 1
            totals[setting]["success" if t["record"]["outcome"] == "success" else "failed"] += 1
    lines = ["| family | setting | DWA | MPC | policy |", "|---|---|---|---|---|"]
    for (family, setting), per in sorted(cells.items()):
        row = [_cell(per[m]) if m in per else "" for m in PLANNERS]
        lines.append(f"| {family} | {setting} | " + " | ".join(row) + " |")
    for s, c in totals.items():
        if c:
            lines.append(f"| all four | {s} | {c['success']} of {sum(c.values())} | | |")
    return "\n".join(lines)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("root", type=Path, help="the directory of the SETTING_FAMILY runs")
    print(table(p.parse_args().root))


if __name__ == "__main__":
    main()
