"""What the package does, as one comparable file: the guard of a refactor that must change
nothing (issue 39: "same outputs before and after, bit for bit").

    python scripts/behaviour_fingerprint.py --out before.json     # on the commit before
    python scripts/behaviour_fingerprint.py --check before.json   # after: exit 1 on a change

It runs, in a temporary directory, `emonav benchmark --planners dwa,mpc,policy,sarl` on
both plants (`--trials 3 --first-seed 0 --workers 1`) and a tiny DAgger route (the MPC as
expert, 2 expert episodes and one round, seed 0), and records every trial's record (wall
times left out) and the SHA-256 of the trained student's weights. `--check` prints each
difference (which plant, method and seed; or the weights) and exits 1 if there is one.
The committed `benchmarks/results/behaviour_fingerprint.json` is the one of its commit.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PLANNERS = "dwa,mpc,policy,sarl"
TRIALS = 3


def _benchmark(plant: str, work: Path) -> dict[str, dict]:
    out = work / plant
    cmd = [sys.executable, "-m", "emonav_drake.cli", "benchmark", "--planners", PLANNERS]
    cmd += ["--plant", plant, "--trials", str(TRIALS), "--first-seed", "0", "--workers", "1"]
    subprocess.run([*cmd, "--out", str(out), "--quiet"], check=True, cwd=ROOT)
    trials = {}
    for line in (out / "trials.jsonl").read_text().splitlines():
        t = json.loads(line)
        trials[f"{plant}/{t['method']}/{t['seed']}"] = t["record"]
    return trials


def _dagger(work: Path) -> str:
    from emonav_drake.learning.config import DaggerConfig
    from emonav_drake.learning.dagger import train_dagger
    from emonav_drake.planners.policy import load_policy
    from emonav_drake.planners.specs import MpcSpec

    cfg = DaggerConfig(expert=MpcSpec(), seed=0)
    cfg.expert_episodes, cfg.episodes_per_round, cfg.rounds = 2, 1, 1
    cfg.grad_steps_first, cfg.grad_steps_per_round, cfg.batch_size = 4, 2, 8
    cfg.eval_episodes, cfg.hidden = 1, 16
    train_dagger(work / "dagger", cfg.validate())
    model, _ = load_policy(work / "dagger" / "policy.pt")
    digest = hashlib.sha256()
    for name, tensor in sorted(model.state_dict().items()):
        digest.update(name.encode())
        digest.update(tensor.detach().cpu().contiguous().numpy().tobytes())
    return digest.hexdigest()


def fingerprint() -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        trials = {}
        for plant in ("lip", "digit"):
            trials |= _benchmark(plant, work)
        weights = _dagger(work)
    commit = subprocess.run(
        ["git", "rev-parse", "--short=12", "HEAD"], capture_output=True, text=True, cwd=ROOT
    ).stdout.strip()
    return {"commit": commit, "trials": trials, "dagger_weights_sha256": weights}


def differences(old: dict, new: dict) -> list[str]:
    out = []
    for key in sorted(set(old["trials"]) | set(new["trials"])):
        a, b = old["trials"].get(key), new["trials"].get(key)
        if a != b:
            a, b = a or {}, b or {}
            fields = sorted(k for k in set(a) | set(b) if a.get(k) != b.get(k))
            out.append(f"trial {key}: {', '.join(fields) or 'missing'} differ")
    if old["dagger_weights_sha256"] != new["dagger_weights_sha256"]:
        out.append("the tiny DAgger route's student weights differ")
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    group = ap.add_mutually_exclusive_group(required=True)
    group.add_argument("--out", type=Path, help="write the fingerprint here")
    group.add_argument("--check", type=Path, help="compare with this fingerprint")
    args = ap.parse_args()
    new = fingerprint()
    if args.out:
        args.out.write_text(json.dumps(new, indent=1, sort_keys=True) + "\n")
        print(f"wrote {args.out}: {len(new['trials'])} trials and the DAgger weights")
        return 0
    old = json.loads(args.check.read_text())
    diff = differences(old, new)
    for line in diff:
        print(line)
    print(f"{len(diff)} difference(s) against {args.check} (commit {old['commit']})")
    return 1 if diff else 0


if __name__ == "__main__":
    raise SystemExit(main())
