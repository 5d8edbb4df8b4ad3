"""Benchmark tables in the paper's layout (Tables II–III), social metrics and paired tests.

Pure functions over the trial lines of a benchmark run (`evaluation.benchmark`: one dict
per trial with `method`, `seed`, `plant`, `record` — an `EpisodeRecord.to_json()` — and
`wall_seconds`). Every success rate is shown with its trial count and a 95 % Wilson score
interval; methods are compared on the seeds they share with McNemar's exact test
(two-sided binomial test on the discordant pairs).

* Table II: SR [95 % CI] (n), NT mean ± std over the successes [s], DT (summed over the
  trials, as in the paper, and per trial);
* Table III style: IDT [static; happy, neutral, negative] and SR per method and setting;
* social metrics: mean path length, minimum pedestrian distance, collision, timeout and
  (full-order Digit) fall rates, wall time per trial;
* the field's metrics (`navigation/social_metrics.py`, docs/metrics.md): path irregularity,
  jerk, pedestrian clearance, low time-to-collision and intrusion ratios, clearance
  during intrusions — means per trial with 95 % Student-t intervals, over the trials
  that measured them (n/a: none did, e.g. a run recorded before they existed);
* paired comparison: for every pair of methods, the seeds both ran, the discordant counts,
  the exact p-value and whether the difference is significant at α = 0.05.
"""

from __future__ import annotations

import csv
import io
import itertools
import math
from collections.abc import Iterable, Sequence

from emonav_drake.diagrams.plants import PLANTS
from emonav_drake.navigation.metrics import SUCCESS, record_from_json, summarize
from emonav_drake.navigation.social_metrics import INTRUSION_DISTANCE, SOCIAL_FIELDS, TTC_THRESHOLD

ALPHA = 0.05
Z95 = 1.959963984540054  # two-sided 95 % normal quantile


def wilson_interval(successes: int, n: int, z: float = Z95) -> tuple[float, float]:
    """The Wilson score interval of a binomial proportion (95 % by default).

    Unlike the normal approximation it stays inside [0, 1] and is sensible at 0 or n
    successes. `n == 0` gives (0, 1).
    """
    if n <= 0:
        return 0.0, 1.0
    p = successes / n
    z2 = z * z
    centre = (p + z2 / (2 * n)) / (1 + z2 / n)
    half = z / (1 + z2 / n) * math.sqrt(p * (1 - p) / n + z2 / (4 * n * n))
    return max(0.0, centre - half), min(1.0, centre + half)


def mcnemar_exact(b: int, c: int) -> float:
    """Two-sided exact McNemar p-value for discordant counts b and c (binomial, p = 1/2)."""
    n = b + c
    if n == 0:
        return 1.0
    k = min(b, c)
    tail = sum(math.comb(n, i) for i in range(k + 1)) / 2.0**n
    return min(1.0, 2.0 * tail)


def signed_rank_p(old: Sequence[float], new: Sequence[float]) -> float:
    """Two-sided Wilcoxon signed-rank p-value of paired differences new − old (e.g. each
    seed's DT under two methods); pairs with no difference are dropped (the "wilcox" rule),
    and 1.0 when every pair is equal."""
    from scipy.stats import wilcoxon

    d = [b - a for a, b in zip(old, new, strict=True)]
    if not any(d):
        return 1.0
    return float(wilcoxon(d, zero_method="wilcox", alternative="two-sided").pvalue)


def method_order(trials: Iterable[dict], methods: Sequence[str] | None = None) -> list[str]:
    """`methods` (those with trials), then any other method of `trials` in sorted order."""
    present = {t["method"] for t in trials}
    first = [m for m in (methods or []) if m in present]
    return first + sorted(present - set(first))


def summarize_methods(trials: Sequence[dict], methods: Sequence[str] | None = None) -> dict:
    """Per method: `metrics.summarize` of its trials plus successes, the Wilson interval,
    DT per trial, the mean of the per-trial minimum pedestrian distances and wall time."""
    out = {}
    for m in method_order(trials, methods):
        rows = sorted((t for t in trials if t["method"] == m), key=lambda t: t["seed"])
        records = [record_from_json(t["record"]) for t in rows]
        s = summarize(records)
        n = len(records)
        k = sum(r.outcome == SUCCESS for r in records)
        minima = [r.min_ped_distance for r in records if math.isfinite(r.min_ped_distance)]
        s.update(
            successes=k,
            SR_ci=list(wilson_interval(k, n)),
            DT_per_trial=s["DT"] / n,
            min_ped_distance_mean=sum(minima) / len(minima) if minima else None,
            wall_seconds_mean=sum(t.get("wall_seconds", 0.0) for t in rows) / n,
            seeds=[rows[0]["seed"], rows[-1]["seed"]],
        )
        out[m] = s
    return out


def pairwise_comparisons(
    trials: Sequence[dict], methods: Sequence[str] | None = None, alpha: float = ALPHA
) -> list[dict]:
    """McNemar's exact test for every pair of methods on the seeds both ran.

    b: seeds where the first method succeeded and the second did not; c: the reverse.
    """
    ok = {(t["method"], t["seed"]): t["record"]["outcome"] == SUCCESS for t in trials}
    order = method_order(trials, methods)
    seeds = {m: {s for (mm, s) in ok if mm == m} for m in order}
    out = []
    for a, b_ in itertools.combinations(order, 2):
        common = sorted(seeds[a] & seeds[b_])
        b = sum(ok[(a, s)] and not ok[(b_, s)] for s in common)
        c = sum(ok[(b_, s)] and not ok[(a, s)] for s in common)
        n = len(common)
        sr_a = sum(ok[(a, s)] for s in common) / n if n else None
        sr_b = sum(ok[(b_, s)] for s in common) / n if n else None
        p = mcnemar_exact(b, c)
        out.append(
            {
                "a": a,
                "b": b_,
                "paired_trials": n,
                "SR_a": sr_a,
                "SR_b": sr_b,
                "a_only_success": b,
                "b_only_success": c,
                "p_value": p,
                "significant": bool(n and p < alpha),
            }
        )
    return out


def pairwise_statement(row: dict, alpha: float = ALPHA) -> str:
    """One sentence: which method succeeds more often and whether it is significant."""
    a, b, n = row["a"], row["b"], row["paired_trials"]
    if not n:
        return f"{a} vs {b}: no common seeds"
    if row["SR_a"] == row["SR_b"]:
        lead = f"{a} and {b} succeed equally often ({row['SR_a']:.3f})"
    else:
        hi, lo = (a, b) if row["SR_a"] > row["SR_b"] else (b, a)
        srs = {a: row["SR_a"], b: row["SR_b"]}
        lead = f"{hi} ({srs[hi]:.3f}) vs {lo} ({srs[lo]:.3f})"
    verdict = (
        f"significant at α = {alpha:g}"
        if row["significant"]
        else f"not significant at α = {alpha:g}"
    )
    return (
        f"{lead} on {n} paired seeds: {row['a_only_success']} vs {row['b_only_success']} "
        f"discordant, McNemar exact p = {format_p(row['p_value'])} — {verdict}"
    )


def format_p(p: float) -> str:
    """A p-value for tables: 4 decimals, "< 1e-4" below."""
    return "< 1e-4" if p < 1e-4 else f"{p:.4f}"


def _f(x: float | None, digits: int = 3) -> str:
    return "n/a" if x is None else f"{x:.{digits}f}"


def _sr(s: dict) -> str:
    lo, hi = s["SR_ci"]
    return f"{s['SR']:.3f} [{lo:.3f}, {hi:.3f}] (n={s['episodes']})"


def format_nt(s: dict) -> str:
    if s["NT_mean"] is None:
        return "n/a"
    return f"{s['NT_mean']:.2f} ± {s['NT_std']:.2f}"


def format_idt(s: dict) -> str:
    i = s["IDT"]
    return f"[{i[0]}; {i[1]}, {i[2]}, {i[3]}]"


def markdown_table(header: Sequence[str], rows: Iterable[Sequence[object]]) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(str(c) for c in r) + " |" for r in rows]
    return "\n".join(lines)


READS_HEADER = "reads — could a robot run it?"


def method_reads(
    observation: str,
    state_source: str = "truth",
    sensor: str = "ideal",
    steered: bool = False,
    maps_ring_tracks: bool = False,
) -> str:
    """What a method reads and whether a robot could run it, for the tables' reads column.

    `observation`: "state" (the crowd state: DWA, MPC, SARL, RGL) or a learned policy's map
    kind ("LGM", "OGM", "SCAN", "DRLVO"); `state_source` and `sensor` the run's
    (`perception.state_source`, `sensor.preset`); `steered`: a policy that hands its
    command to the MPC on the crowd state; `maps_ring_tracks`: the grid maps take the
    tracked pedestrians (the pedestrian planes of "lgm_vel" and "lgm_tracks" are the
    tracker's, else the simulator's). Privileged: the simulator's crowd (or its
    pedestrians' velocities, DRL-VO*); an exact scan is an upper bound (no sensor gives
    it); a real sensor's scan or the tracks in it: deployable."""
    scan = "the exact scan" if sensor == "ideal" else f"the {sensor} scan"
    verdict = "upper bound (exact scan)" if sensor == "ideal" else "deployable"
    crowd = (
        ("the simulator's crowd", "privileged")
        if state_source == "truth"
        else (f"tracks in {scan}", verdict)
    )
    kind = observation.lower()
    if kind == "state":
        return f"{crowd[0]} — {crowd[1]}"
    if kind == "drlvo":
        return f"maps of {scan} + the simulator's pedestrian velocities — privileged"
    if kind in ("lgm_vel", "lgm_tracks"):
        what = "velocity planes" if kind == "lgm_vel" else "table"
        tracked = state_source == "lidar" and maps_ring_tracks
        peds = (
            (f"tracks in {scan}", verdict) if tracked else ("the simulator's crowd", "privileged")
        )
        return f"LiDAR grid maps of {scan} + the {what} of {peds[0]} — {peds[1]}"
    maps = {"lgm": "LiDAR grid maps", "ogm": "occupancy grid maps", "scan": "LiDAR scans"}
    text = f"{maps.get(kind, kind)} of {scan}"
    if steered:  # the maps' scan and the crowd come from the same sensor
        return f"{text} + the MPC on {crowd[0]} — {crowd[1]}"
    return f"{text} — {verdict}"


def table2_rows(summary: dict, reads: dict | None = None) -> tuple[list[str], list[list[object]]]:
    """Table II: Method | SR [95 % CI] (n) | NT [s] | DT | DT / trial (| what each method
    reads and whether a robot could run it, given `reads` by method)."""
    header = ["Method", "SR [95% CI] (n)", "NT [s] (successes)", "DT (sum)", "DT / trial"]
    rows = [
        [m, _sr(s), format_nt(s), s["DT"], f"{s['DT_per_trial']:.2f}"] for m, s in summary.items()
    ]
    return _with_reads(header, rows, reads)


def _with_reads(
    header: list[str], rows: list[list[object]], reads: dict | None
) -> tuple[list[str], list[list[object]]]:
    """The table with the reads column appended (`READS_HEADER`; a row by its method, the
    first cell), or as it is without `reads`."""
    if reads:
        header.append(READS_HEADER)
        for row in rows:
            row.append(reads.get(row[0], "?"))
    return header, rows


def table3_rows(
    summary: dict,
    setting: str,
    plant: str,
    observations: dict | None = None,
    reads: dict | None = None,
) -> tuple[list[str], list[list[object]]]:
    """Table III style: Method | DD (setting) | Test plant | Obs | IDT | SR (| what each
    method reads and whether a robot could run it, given `reads` by method: the paper's
    Obs column names the observation's kind only)."""
    header = ["Method", "DD (setting)", "Test", "Obs", "IDT [static; happy, neutral, negative]"]
    header.append("SR [95% CI] (n)")
    obs = observations or {}
    rows = [
        [m, setting, plant, obs.get(m, "state"), format_idt(s), _sr(s)] for m, s in summary.items()
    ]
    return _with_reads(header, rows, reads)


def social_rows(summary: dict, plant: str) -> tuple[list[str], list[list[object]]]:
    """Social metrics: path length, pedestrian distances, failure rates, wall time."""
    header = [
        "Method",
        "trials",
        "path length [m] (mean)",
        "min ped. distance [m] (min / mean)",
        "collision rate",
        "timeout rate",
    ]
    falls = plant in PLANTS and PLANTS[plant].can_fall
    if falls:
        header.append("fall rate")
    no_route = any(s.get("no_route_rate", 0.0) > 0 for s in summary.values())
    if no_route:  # only where a route layer ran out of routes
        header.append("no-route rate")
    header.append("wall s / trial")
    rows = []
    for m, s in summary.items():
        row = [
            m,
            s["episodes"],
            f"{s['path_length_mean']:.2f}",
            f"{_f(s['min_ped_distance'], 2)} / {_f(s['min_ped_distance_mean'], 2)}",
            f"{s['collision_rate']:.3f}",
            f"{s['timeout_rate']:.3f}",
        ]
        if falls:
            row.append(f"{s['fall_rate']:.3f}")
        if no_route:
            row.append(f"{s['no_route_rate']:.3f}")
        row.append(f"{s['wall_seconds_mean']:.2f}")
        rows.append(row)
    return header, rows


# The field's metrics as table columns: record field → (header, decimals).
FIELD_COLUMNS = {
    "path_irregularity": ("path irregularity [rad/m]", 3),
    "jerk_mean": ("jerk [m/s³]", 3),
    "min_ped_clearance": ("min. ped. clearance [m]", 3),
    "low_ttc_ratio": (f"TTC < {TTC_THRESHOLD:g} s (share of steps)", 3),
    "intrusion_ratio": (f"intrusion < {INTRUSION_DISTANCE:g} m (share of steps)", 3),
    "intrusion_clearance": ("clearance in intrusions [m]", 3),
}


def format_mean_ci(s: dict, name: str, digits: int = 3) -> str:
    """A field metric's cell: "mean [lo, hi]", with "(n=k)" when only k of the trials
    measured it; "n/a" when none did."""
    n, mean, ci = s.get(f"{name}_n", 0), s.get(f"{name}_mean"), s.get(f"{name}_ci")
    if not n or mean is None:
        return "n/a"
    text = f"{mean:.{digits}f}"
    if ci is not None:
        text += f" [{ci[0]:.{digits}f}, {ci[1]:.{digits}f}]"
    return text if n == s["episodes"] else f"{text} (n={n})"


def field_rows(summary: dict) -> tuple[list[str], list[list[object]]]:
    """The field's metrics: Method | trials | one column per metric (mean [95 % CI])."""
    header = ["Method", "trials", *(h for h, _ in FIELD_COLUMNS.values())]
    rows = [
        [m, s["episodes"], *(format_mean_ci(s, k, d) for k, (_, d) in FIELD_COLUMNS.items())]
        for m, s in summary.items()
    ]
    return header, rows


def pairwise_rows(pairs: Sequence[dict]) -> tuple[list[str], list[list[object]]]:
    header = [
        "A",
        "B",
        "paired seeds",
        "SR A",
        "SR B",
        "A only",
        "B only",
        "McNemar exact p",
        f"significant (α = {ALPHA:g})",
    ]
    rows = [
        [
            r["a"],
            r["b"],
            r["paired_trials"],
            _f(r["SR_a"]),
            _f(r["SR_b"]),
            r["a_only_success"],
            r["b_only_success"],
            format_p(r["p_value"]),
            "yes" if r["significant"] else "no",
        ]
        for r in pairs
    ]
    return header, rows


def csv_text(header: Sequence[str], rows: Iterable[Sequence[object]]) -> str:
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(header)
    w.writerows(rows)
    return buf.getvalue()


def table2_csv(summary: dict) -> str:
    """Table II as CSV with the numbers unformatted."""
    header = ["method", "trials", "successes", "SR", "SR_ci_low", "SR_ci_high"]
    header += ["NT_mean", "NT_std", "DT", "DT_per_trial"]
    rows = [
        [m, s["episodes"], s["successes"], s["SR"], *s["SR_ci"], s["NT_mean"], s["NT_std"]]
        + [s["DT"], s["DT_per_trial"]]
        for m, s in summary.items()
    ]
    return csv_text(header, rows)


def table3_csv(summary: dict, setting: str, plant: str, observations: dict | None = None) -> str:
    obs = observations or {}
    header = ["method", "setting", "plant", "observation", "IDT_static", "IDT_happy"]
    header += ["IDT_neutral", "IDT_negative", "trials", "SR", "SR_ci_low", "SR_ci_high"]
    rows = [
        [m, setting, plant, obs.get(m, "state"), *s["IDT"], s["episodes"], s["SR"], *s["SR_ci"]]
        for m, s in summary.items()
    ]
    return csv_text(header, rows)


def social_csv(summary: dict) -> str:
    """The social metrics and then the field's: for each, its mean, 95 % interval and
    number of trials that measured it (empty cells: not measured)."""
    header = ["method", "trials", "path_length_mean", "min_ped_distance", "min_ped_distance_mean"]
    header += ["collision_rate", "timeout_rate", "fall_rate", "wall_seconds_mean"]
    for name in SOCIAL_FIELDS:
        header += [f"{name}_mean", f"{name}_ci_low", f"{name}_ci_high", f"{name}_n"]
    rows = []
    for m, s in summary.items():
        row = [m, s["episodes"], s["path_length_mean"], s["min_ped_distance"]]
        row += [s["min_ped_distance_mean"], s["collision_rate"], s["timeout_rate"], s["fall_rate"]]
        row.append(s["wall_seconds_mean"])
        for name in SOCIAL_FIELDS:
            ci = s.get(f"{name}_ci") or [None, None]
            row += [s.get(f"{name}_mean"), *ci, s.get(f"{name}_n", 0)]
        rows.append(row)
    return csv_text(header, rows)


def pairwise_csv(pairs: Sequence[dict]) -> str:
    header = ["a", "b", "paired_trials", "SR_a", "SR_b", "a_only_success", "b_only_success"]
    header += ["p_value", "significant"]
    return csv_text(header, [[r[h] for h in header] for r in pairs])


def render_markdown(
    trials: Sequence[dict],
    methods: Sequence[str] | None,
    setting: str,
    plant: str,
    observations: dict | None = None,
    title: str = "Benchmark",
    notes: Sequence[str] = (),
    reads: dict | None = None,
) -> str:
    """All tables as one Markdown document (`reads`: what each method reads and whether a
    robot could run it, `method_reads`, as a column of Tables II and III)."""
    summary = summarize_methods(trials, methods)
    pairs = pairwise_comparisons(trials, methods)
    parts = [f"# {title}", ""]
    parts += [f"- {n}" for n in notes]
    parts += [
        "",
        "## Table II: success rate, navigation time, discomfort",
        "",
        "SR with its 95 % Wilson score interval and the number of trials; NT mean ± std over "
        "the successful trials; DT: walking steps inside any discomfort zone, summed over the "
        "trials (the paper's DT) and per trial.",
        "",
        markdown_table(*table2_rows(summary, reads)),
        "",
        "## Table III style: individual discomfort times",
        "",
        "IDT: walking steps inside the discomfort zone of a static disc and of happy, neutral "
        "and negative pedestrians, summed over the trials.",
        "",
        markdown_table(*table3_rows(summary, setting, plant, observations, reads)),
        "",
        "## Social metrics",
        "",
        "Minimum pedestrian distance: centre to centre, the smallest over all trials / the mean "
        "of the per-trial minima.",
        "",
        markdown_table(*social_rows(summary, plant)),
        "",
        "## Field metrics: smoothness, clearance, time to collision, intrusions",
        "",
        "Means per trial with their 95 % Student-t interval (n: trials that measured a "
        "metric, when not all did; n/a: none did). Path irregularity: turning beyond the "
        "least needed to face the goal, per metre (SocNavBench); jerk: of the commanded "
        "velocity (Francis et al. 2025); clearance: robot to pedestrian, surface to "
        f"surface; TTC < {TTC_THRESHOLD:g} s: share of walking steps with a pedestrian's "
        f"constant-velocity time to collision below {TTC_THRESHOLD:g} s; intrusion: share "
        f"of steps closer than {INTRUSION_DISTANCE:g} m to a pedestrian and the mean "
        "clearance in them (CrowdNav++ / HEIGHT). Definitions: docs/metrics.md.",
        "",
        markdown_table(*field_rows(summary)),
        "",
        f"## Paired comparison (same seeds, McNemar exact test, α = {ALPHA:g})",
        "",
    ]
    if pairs:
        parts += [markdown_table(*pairwise_rows(pairs)), ""]
        parts += [f"- {pairwise_statement(r)}" for r in pairs]
        parts += [
            "",
            "Each p-value is for one comparison on its own (not adjusted for the number of pairs).",
        ]
    else:
        parts.append("One method only: nothing to compare.")
    return "\n".join(parts) + "\n"
