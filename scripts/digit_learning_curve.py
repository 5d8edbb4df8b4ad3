"""The learning curve of a training route measured on a plant by benchmark runs.

    python scripts/digit_learning_curve.py \
        --point "LIP policy=benchmarks/results/digit_table3:sac" \
        --point "round 0=benchmarks/results/digit_learning_curve:round0" ... \
        [--seeds 0-99] [--history RUN/history.json] \
        --out benchmarks/results/digit_learning_curve/curve.md --png docs/figures/F.png

Every point is summarised on the seeds all points ran (or those of --seeds among them),
compared with the point before it by McNemar's exact test, written as a `## ` section of
--out (quoted by the docs) and drawn in --png; --history adds the SR the route measured
in its own world for the points labelled "round N". See
`emonav_drake/evaluation/learning_curve.py`.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from emonav_drake.evaluation.learning_curve import (
    CurveError,
    curve_markdown,
    measure,
    parse_point,
    plot_curve,
    route_success_rates,
)


def _seeds(text: str) -> range:
    lo, _, hi = text.partition("-")
    try:
        return range(int(lo), int(hi or lo) + 1)
    except ValueError:
        raise CurveError(f"--seeds {text!r}: expected FIRST-LAST, e.g. 0-99") from None


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    p.add_argument("--point", action="append", required=True, help="LABEL=RUN:METHOD")
    p.add_argument("--seeds", help="restrict to these seeds, FIRST-LAST")
    p.add_argument("--history", type=Path, help="the route's history.json")
    p.add_argument("--title", default="Learning curve on Digit")
    p.add_argument(
        "--history-label",
        default="calibrated world (the route's selection seeds)",
        help="legend of the --history curve",
    )
    p.add_argument("--out", type=Path, required=True, help="Markdown file to write")
    p.add_argument("--png", type=Path, help="figure to write")
    args = p.parse_args()
    try:
        curve = measure(
            [parse_point(t) for t in args.point],
            _seeds(args.seeds) if args.seeds else None,
        )
        route = None
        if args.history is not None:
            rates = route_success_rates(args.history)
            route = {f"round {r}": sr for r, sr in rates.items()}
    except CurveError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    text = curve_markdown(curve, args.title)
    args.out.write_text(f"# {args.title}\n\n" + text)
    print(text)
    if args.png is not None:
        plot_curve(curve, args.png, route, args.history_label, title=args.title)
        print(f"figure written to {args.png}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
