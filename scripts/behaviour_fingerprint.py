"""What the package does, as one comparable file: the guard of a refactor that must change
nothing (issue 39: "same outputs before and after, bit for bit").

    python scripts/behaviour_fingerprint.py --out before.json     # on the commit before
    python scripts/behaviour_fingerprint.py --check before.json   # after: exit 1 on a change

It runs, in a temporary directory, `emonav benchmark --planners dwa,mpc,policy,sarl` on
both plants (`--trials 3 --first-seed 0 --workers 1`) and a tiny DAgger route (the MPC as
expert, 2 expert episodes and one round, seed 0), and records every trial's record (wall
times left out), the SHA-256 of the trained student's weights, and the student's decisions
on fixed inputs (its logits and chosen command on 36 map observations of three seeded
scenes). `--check` prints each difference (which plant, method and seed; or the student)
and exits 1 if there is one. The committed `benchmarks/results/behaviour_fingerprint.json`
is the one of its commit.

What must be equal where (docs/reliability.md, "Reproducible on which machine"): the
benchmark records bit for bit on any machine; the student's weights bit for bit on the
same machine only — torch's CPU kernels differ between processors in the last bits, so
on another machine the weights' hash differs, consistently. The training check therefore
passes when the hash is equal, or else when every decision on the fixed inputs is the same
command and every logit is within `LOGIT_TOLERANCE` of the recorded one.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import subprocess
import sys
import tempfile
from pathlib import Path

from emonav_drake.provenance import kernels_difference, numeric_kernels

# The kernels of a fingerprint written before they were recorded (860e3d2): OpenBLAS's
# SkylakeX set, the one that reproduces it (docs/reliability.md).
SKYLAKEX = {"blas": [{"library": "openblas", "version": "?", "architecture": "SkylakeX"}]}

ROOT = Path(__file__).resolve().parent.parent
PLANNERS = "dwa,mpc,policy,sarl"
TRIALS = 3
# How far the student's logits may move on another processor. Measured on one machine by
# forcing torch's three CPU kernel sets (ATEN_CPU_CAPABILITY=default, avx2, and the native
# avx512): three different weight hashes, the same 36 choices, logits within 1.2e-7. The
# bound is ~1000x that and far below the median gap between the two best logits (0.037).
LOGIT_TOLERANCE = 1e-4
DECISION_SEEDS = (0, 1, 2)  # scenes whose observations the student decides on
DECISION_STEPS = 12  # observations per scene (walking straight at 0.3 m/s)


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


def _dagger(work: Path) -> dict:
    from emonav_drake.learning.config import DaggerConfig
    from emonav_drake.learning.dagger import train_dagger
    from emonav_drake.planners.policy import load_policy
    from emonav_drake.planners.specs import MpcSpec

    cfg = DaggerConfig(expert=MpcSpec(), seed=0)
    cfg.expert_episodes, cfg.episodes_per_round, cfg.rounds = 2, 1, 1
    cfg.grad_steps_first, cfg.grad_steps_per_round, cfg.batch_size = 4, 2, 8
    cfg.eval_episodes, cfg.hidden = 1, 16
    train_dagger(work / "dagger", cfg.validate())
    path = work / "dagger" / "policy.pt"
    model, _ = load_policy(path)
    digest = hashlib.sha256()
    for name, tensor in sorted(model.state_dict().items()):
        digest.update(name.encode())
        digest.update(tensor.detach().cpu().contiguous().numpy().tobytes())
    return {"weights_sha256": digest.hexdigest(), **_decisions(path)}


def _decisions(path: Path) -> dict:
    """The student's logits and chosen command index on fixed observations: the map
    observations of three seeded scenes of the paper's arena while the robot walks straight
    (numpy only, the same on any machine)."""
    import numpy as np

    from emonav_drake.navigation.lip_world import NavigationWorld
    from emonav_drake.params import EmoNavConfig
    from emonav_drake.planners.policy import PolicyPlanner
    from emonav_drake.scenarios.scenario import sample_scenario

    student = PolicyPlanner(path)
    cfg = EmoNavConfig()
    logits, choices = [], []
    for seed in DECISION_SEEDS:
        world = NavigationWorld(sample_scenario(seed, cfg), cfg, grid_kind=student.grid_kind)
        for _ in range(DECISION_STEPS):
            obs = world.planner_input()
            scores = student.command_scores(
                obs.lgm_stack, student.goal_state(obs), obs.last_command
            )
            logits.append([float(x) for x in scores])
            choices.append(int(np.argmax(scores)))
            if world.step(np.array([0.3, 0.0]))[1]:
                break
    return {"logits": logits, "choices": choices}


def fingerprint() -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        trials = {}
        for plant in ("lip", "digit"):
            trials |= _benchmark(plant, work)
        student = _dagger(work)
    commit = subprocess.run(
        ["git", "rev-parse", "--short=12", "HEAD"], capture_output=True, text=True, cwd=ROOT
    ).stdout.strip()
    return {
        "commit": commit,
        "trials": trials,
        "dagger_weights_sha256": student.pop("weights_sha256"),
        "dagger_decisions": student,
        "numerics": numeric_kernels(),  # the BLAS kernels the trials ran on
    }


def differences(old: dict, new: dict) -> list[str]:
    out = []
    for key in sorted(set(old["trials"]) | set(new["trials"])):
        a, b = old["trials"].get(key), new["trials"].get(key)
        if a != b:
            a, b = a or {}, b or {}
            fields = sorted(k for k in set(a) | set(b) if a.get(k) != b.get(k))
            out.append(f"trial {key}: {', '.join(fields) or 'missing'} differ")
    if old["dagger_weights_sha256"] != new["dagger_weights_sha256"]:
        out += _student_differences(old.get("dagger_decisions"), new["dagger_decisions"])
    return out


def _student_differences(old: dict | None, new: dict) -> list[str]:
    """With other weights (another processor, or a change): the decisions on the fixed
    inputs must be the same commands with logits within `LOGIT_TOLERANCE`."""
    if old is None:
        return ["the tiny DAgger route's student weights differ (no decisions recorded)"]
    if old["choices"] != new["choices"]:
        changed = sum(a != b for a, b in zip(old["choices"], new["choices"], strict=False))
        return [f"the tiny DAgger student chooses another command on {changed} fixed inputs"]
    worst = max(
        (abs(a - b) for la, lb in zip(old["logits"], new["logits"], strict=True)
         for a, b in zip(la, lb, strict=True)),
        default=0.0,
    )  # fmt: skip
    if worst > LOGIT_TOLERANCE:
        return [f"the tiny DAgger student's logits moved by {worst:.3g} (> {LOGIT_TOLERANCE})"]
    print(
        f"note: the student's weights differ in their last bits (another processor?); its "
        f"decisions on {len(new['choices'])} fixed inputs are the same, logits within "
        f"{worst:.2g}"
    )
    return []


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
    kernels = kernels_difference(old.get("numerics", SKYLAKEX), new["numerics"])
    if diff and kernels:  # the last bits follow OpenBLAS's kernels (docs/reliability.md)
        print(f"note: {kernels}")
    return 1 if diff else 0


if __name__ == "__main__":
    raise SystemExit(main())
