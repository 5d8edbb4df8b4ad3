"""Digit Table II with perceived emotions: the default policy and the MPC in the deployable
setting (LiDAR tracks on the VLP-16's scan) with emotions from the simulator, from the head
camera frame by frame (the paper's cascade), and kept per track (BlazeFace), on the same
seeds: success with Wilson intervals, DT and IDT per emotion (happy / neutral / negative)
per trial, McNemar exact on success and the signed-rank test on the per-seed negative-zone
steps against the simulator's emotions; what keeping emotions per track buys.

    python scripts/emotion_source_table.py [--seeds 300] [--write]

Run directories (`RUNS`): the simulator's emotions are `digit_deployable` (its policy and
MPC rows); the camera rows `digit_deployable_camera` (`--deployable --emotion-source
camera`) and `digit_deployable_tracks` (`--deployable`, whose default is
`camera_tracks`). With --write the table goes to `digit_deployable_tracks/
emotion_source_table.md`, which docs/results.md quotes.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import state_source_table as sst  # noqa: E402

from emonav_drake.evaluation.tables import mcnemar_exact, signed_rank_p  # noqa: E402

METHODS = ("policy", "mpc")
RUNS = (  # (label, run directory)
    ("the simulator's", "digit_deployable"),
    ("camera, per frame (cascade)", "digit_deployable_camera"),
    ("camera, kept per track (BlazeFace)", "digit_deployable_tracks"),
)
TABLE_FILE = "emotion_source_table.md"
# what each method's crowd input is in these deployable runs (`evaluation.tables.method_reads`)
CROWD_READ = {"policy": "LiDAR grid maps of the vlp16 scan", "mpc": "tracks in the vlp16 scan"}
TABLE_SECTION = "Table II with perceived emotions"  # the sections docs/results.md quotes
GAIN_SECTION = "What keeping emotions per track buys"


def _idt(rs: list[dict], k: int) -> float:
    return float(np.mean([r["idt"][k] for r in rs]))


def table(num_seeds: int) -> str:
    seeds_all = list(range(num_seeds))
    rows = [
        "| method | emotions | SR [95 % CI] (n) | DT / trial | IDT / trial: happy / neutral / "
        "negative | vs the simulator's emotions: success only this : only truth, McNemar; "
        "negative-zone steps signed-rank | reads — could a robot run it? |",
        "|---|---|---|---|---|---|---|",
    ]
    for m in METHODS:
        base = sst.records(RUNS[0][1], m)
        for label, run in RUNS:
            recs = sst.records(run, m)
            seeds = [s for s in seeds_all if s in recs]
            if run == RUNS[0][1]:  # the simulator's emotions: no robot has them
                reads = f"{CROWD_READ[m]} + the simulator's emotions — privileged"
            else:
                reads = f"{CROWD_READ[m]} + the head camera's emotions — deployable"
            if not seeds:
                rows.append(f"| {m} | {label} | no trials yet | | | | {reads} |")
                continue
            rs = [recs[s] for s in seeds]
            versus = "—"
            both = [s for s in seeds if s in base]
            if run != RUNS[0][1] and both:
                ok = lambda r: r["outcome"] == "success"  # noqa: E731
                a = sum(ok(recs[s]) and not ok(base[s]) for s in both)
                b = sum(ok(base[s]) and not ok(recs[s]) for s in both)
                neg = signed_rank_p(
                    [base[s]["idt"][3] for s in both], [recs[s]["idt"][3] for s in both]
                )
                versus = f"{a}:{b}, p {sst._p(mcnemar_exact(a, b))}; "
                versus += f"negative p {sst._p(neg)} (n = {len(both)})"
            dt = np.mean([r["discomfort_steps"] for r in rs])
            idt = " / ".join(f"{_idt(rs, k):.2f}" for k in (1, 2, 3))
            rows.append(
                f"| {m} | {label} | {sst._sr(rs)} | {dt:.2f} | {idt} | {versus} | {reads} |"
            )
    return "\n".join(rows)


def fusion_gain(num_seeds: int) -> str:
    """What keeping emotions per track buys over the per-frame camera, on the seeds both
    ran: negative-zone steps per trial (signed-rank) and success (McNemar)."""
    rows = [
        "| method | negative-zone steps / trial: per frame → per track | signed-rank p | "
        "success only per track : only per frame, McNemar | trials |",
        "|---|---|---|---|---|",
    ]
    for m in METHODS:
        frame, track = sst.records(RUNS[1][1], m), sst.records(RUNS[2][1], m)
        both = [s for s in range(num_seeds) if s in frame and s in track]
        if not both:
            rows.append(f"| {m} | no paired trials yet | | | |")
            continue
        neg_f = [frame[s]["idt"][3] for s in both]
        neg_t = [track[s]["idt"][3] for s in both]
        ok = lambda r: r["outcome"] == "success"  # noqa: E731
        a = sum(ok(track[s]) and not ok(frame[s]) for s in both)
        b = sum(ok(frame[s]) and not ok(track[s]) for s in both)
        rows.append(
            f"| {m} | {np.mean(neg_f):.2f} → {np.mean(neg_t):.2f} | "
            f"{sst._p(signed_rank_p(neg_f, neg_t))} | {a}:{b}, p {sst._p(mcnemar_exact(a, b))}"
            f" | {len(both)} |"
        )
    return "\n".join(rows)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=300, help="seeds 0 … N − 1")
    ap.add_argument("--write", action="store_true", help=f"also write {TABLE_FILE}")
    args = ap.parse_args()
    text = (
        f"## {TABLE_SECTION}\n\n{table(args.seeds)}\n\n## {GAIN_SECTION}\n\n"
        f"{fusion_gain(args.seeds)}"
    )
    print(text)
    if args.write:
        from emonav_drake.atomic_io import write_text_atomic

        out = sst.RESULTS / RUNS[-1][1] / TABLE_FILE
        cmd = f"python scripts/emotion_source_table.py --seeds {args.seeds} --write"
        write_text_atomic(out, f"Written by `{cmd}`.\n\n{text}\n")
        print(f"wrote {out}")


if __name__ == "__main__":
    main()
