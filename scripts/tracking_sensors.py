"""The LiDAR tracker's CLEAR-MOT per sensor preset and scenario family, in one table.

    python scripts/tracking_sensors.py --episodes 100 --first-seed 800000 \
        --out benchmarks/results/tracking_sensors \
        --png docs/figures/tracking_quality_vlp16.png

Runs `scripts/tracking_study.py` for every preset (ideal, vlp16, ust10lx) × family
(paper, dense_20, group_approach, robot_crowding) into `<out>/<preset>_<family>/`; a study
whose `summary.json` exists is kept (run the same command again to continue). Then writes
`<out>/table.md` (MOTA, MOTP, identity switches per 1000 pedestrian-scans, misses, false
pedestrians, IDF1 per preset and family, and the commit) and `<out>/table.json`. --png
draws the figure of the realistic preset (vlp16) on the paper's family. The tracker was
tuned on seeds 700 000-700 019 (family paper): measure on other seeds (800 000 on).
"""

from __future__ import annotations

import argparse
import json
import shlex
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import tracking_study  # noqa: E402

from emonav_drake.atomic_io import write_json, write_text_atomic  # noqa: E402
from emonav_drake.provenance import package_identity  # noqa: E402

PRESETS = ("ideal", "vlp16", "ust10lx")
FAMILIES = ("paper", "dense_20", "group_approach", "robot_crowding")
FIGURE = ("vlp16", "paper")  # the realistic preset on the paper's arena
TUNING_SEEDS = range(700_000, 700_020)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--episodes", type=int, default=100, help="episodes per study (100)")
    p.add_argument("--first-seed", type=int, default=800_000, help="first seed (800000)")
    p.add_argument("--out", type=Path, required=True, help="directory of the studies")
    p.add_argument("--png", type=Path, help="the figure of vlp16 on the paper's family")
    p.add_argument("--presets", default=",".join(PRESETS), help="comma-separated presets")
    p.add_argument("--families", default=",".join(FAMILIES), help="comma-separated families")
    args = p.parse_args(argv)
    seeds = range(args.first_seed, args.first_seed + max(args.episodes, 0))
    if seeds.start < TUNING_SEEDS.stop and TUNING_SEEDS.start < seeds.stop:
        print(
            f"tracking_sensors: error: --first-seed {args.first_seed}: seeds overlap the "
            f"tuning seeds {TUNING_SEEDS.start}-{TUNING_SEEDS.stop - 1}",
            file=sys.stderr,
        )
        return 2
    presets = [s for s in args.presets.split(",") if s]
    families = [f for f in args.families.split(",") if f]
    for preset in presets:
        for family in families:
            out = args.out / f"{preset}_{family}"
            if (out / "summary.json").is_file():
                print(f"{preset} × {family}: done before, kept")
                continue
            print(f"{preset} × {family}: {args.episodes} episodes from seed {args.first_seed}")
            study_argv = [
                "--episodes",
                str(args.episodes),
                "--first-seed",
                str(args.first_seed),
                "--sensor",
                preset,
                "--family",
                family,
                "--out",
                str(out),
            ]
            if args.png is not None and (preset, family) == FIGURE:
                study_argv += ["--png", str(args.png)]
            code = tracking_study.main(study_argv)
            if code != 0:
                return code
    rows = [_row(args.out / f"{s}_{f}", s, f) for s in presets for f in families]
    given = sys.argv[1:] if argv is None else argv
    command = shlex.join(["python", "scripts/tracking_sensors.py", *given])
    package = package_identity()
    write_json(args.out / "table.json", {"command": command, "package": package, "rows": rows})
    text = _table_md(rows, command, package)
    write_text_atomic(args.out / "table.md", text)
    print(text)
    return 0


def _row(study: Path, preset: str, family: str) -> dict:
    """One table row from a study's summary.json."""
    s = json.loads((study / "summary.json").read_text())
    m = s["clear_mot"]
    objects = max(int(m["num_objects"]), 1)
    return {
        "preset": preset,
        "family": family,
        "episodes": s["episodes"],
        "seeds": s["seeds"],
        "scans": s["scans"],
        "pedestrian_scans": m["num_objects"],
        "mota": m["mota"],
        "motp_m": m["motp"],
        "switches": m["num_switches"],
        "switches_per_1000": 1000.0 * m["num_switches"] / objects,
        "misses": m["num_misses"],
        "miss_rate": m["num_misses"] / objects,
        "false_pedestrians": m["num_false_positives"],
        "false_rate": m["num_false_positives"] / objects,
        "idf1": m["idf1"],
        "false_by_cause": s["false_positives_by_cause"],
        "misses_by_cause": s["misses_by_cause"],
    }


def _table_md(rows: list[dict], command: str, package: dict) -> str:
    lines = [
        "| sensor | family | episodes (pedestrian-scans) | MOTA | MOTP [cm] | ID switches / 1000 | "
        "misses | false pedestrians | IDF1 |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r['preset']} | {r['family']} | {r['episodes']} ({r['pedestrian_scans']}) | "
            f"{r['mota']:.3f} | {100 * r['motp_m']:.1f} | {r['switches_per_1000']:.2f} | "
            f"{r['miss_rate']:.3f} | {r['false_rate']:.3f} | {r['idf1']:.3f} |"
        )
    lines += [
        "",
        "Misses and false pedestrians as a share of the pedestrian-scans scored (within the "
        "tracker's range and the sensor's field of view). At commit "
        f"`{str(package.get('commit'))[:7]}`{' (dirty)' if package.get('dirty') else ''}:",
        "",
        f"    {command}",
        "",
    ]
    return "\n".join(lines)


if __name__ == "__main__":
    sys.exit(main())
