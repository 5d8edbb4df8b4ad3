"""Which command does Digit walk in step k? Per-step regression on traced navigation.

Reads trace files of `emonav calibrate collect` and prints the fit of
`emonav_drake.evaluation.step_timing` (the heading change of step k against u_dtheta[k]
and u_dtheta[k-1], the speed at t_{k+1} against u_v[k], u_v[k-1], u_v[k-2], and the
heading error during navigation as RMS).

    python scripts/step_timing_regression.py TRACES.jsonl [...]
"""

from __future__ import annotations

import argparse

from emonav_drake.evaluation.step_timing import fit_step_timing, read_traces


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("traces", nargs="+")
    args = ap.parse_args()
    print("\n".join(fit_step_timing(read_traces(args.traces)).lines()))


if __name__ == "__main__":
    main()
