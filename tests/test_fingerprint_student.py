"""The behaviour fingerprint's training check holds on any machine (issue 46, item 6).

The committed fingerprint records the tiny DAgger route's student as its weights' hash
and its decisions on 36 fixed map observations. The hash is equal only on a machine whose
torch CPU kernels are the same (the committed file's hash was written on one processor;
the same training on another differs in the last bits, consistently); the decisions must
hold everywhere: the same chosen commands, logits within the script's tolerance.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "scripts"))

import behaviour_fingerprint as fingerprint  # noqa: E402

# The tiny route trained in a fresh process, its student as JSON on stdout.
_TRAIN = """
import json, sys
from pathlib import Path
sys.path.insert(0, sys.argv[1])
import behaviour_fingerprint
print(json.dumps(behaviour_fingerprint._dagger(Path(sys.argv[2]))))
"""


@pytest.mark.slow
@pytest.mark.parametrize("kernels", ["native", "default"])
def test_the_tiny_dagger_student_decides_as_recorded(tmp_path, kernels):
    """Trained with this processor's own torch kernels, and with torch's portable ones
    (`ATEN_CPU_CAPABILITY=default`: the weights differ in their last bits, as on another
    processor): both pass the fingerprint's training check."""
    recorded = json.loads((ROOT / "benchmarks/results/behaviour_fingerprint.json").read_text())
    env = dict(os.environ)
    if kernels != "native":
        env["ATEN_CPU_CAPABILITY"] = kernels
    run = subprocess.run(
        [sys.executable, "-c", _TRAIN, str(ROOT / "scripts"), str(tmp_path)],
        capture_output=True,
        text=True,
        env=env,
        check=True,
    )
    student = json.loads(run.stdout.strip().splitlines()[-1])
    new = {"dagger_weights_sha256": student.pop("weights_sha256"), "dagger_decisions": student}
    assert len(student["choices"]) == 36
    problems = fingerprint.differences(
        {**recorded, "trials": {}}, {**new, "trials": {}, "commit": "now"}
    )
    assert problems == []


def test_a_changed_student_is_caught(tmp_path):
    """The tolerance is not a blank cheque: logits moved by 1e-3 (a real change to the
    training moves them by far more) or one other choice fail the check."""
    recorded = json.loads((ROOT / "benchmarks/results/behaviour_fingerprint.json").read_text())
    old = recorded["dagger_decisions"]
    moved = {
        "choices": old["choices"],
        "logits": [[x + 1e-3 for x in row] for row in old["logits"]],
    }
    assert fingerprint._student_differences(old, moved)
    other = {"choices": [old["choices"][0] + 1, *old["choices"][1:]], "logits": old["logits"]}
    assert fingerprint._student_differences(old, other)
    assert fingerprint._student_differences(old, old) == []
