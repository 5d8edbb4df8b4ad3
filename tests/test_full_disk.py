"""Third probe (issue 36): a full disk under `export` and `train`, and two messages.

The full disk is real: a tiny tmpfs mounted in a private mount namespace (`unshare -rm`),
holding a previous, valid version of every file the command writes. Each save must fail
with one line naming its file (exit 2), remove its temporary and leave the previous file
byte-identical; before, torch's own C++ writer aborted the process (`export`, rc 134) or
its error became an "internal error … inline_container.cc" (`train`).
"""

from __future__ import annotations

import hashlib
import json
import math
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from emonav_drake.cli import main
from emonav_drake.evaluation.trajectory import build_trajectory
from emonav_drake.navigation.metrics import EpisodeRecord
from emonav_drake.params import EmoNavConfig
from emonav_drake.scenarios.scenario import PedestrianSpec, Scenario, StaticDiscSpec
from tests.cli_errors import assert_user_error, run
from tests.small_disk import run_on_small_disk

PAGE = 4096
FREE_KIB = 256  # room left on the small disk: less than any file saved there
MARK = "RESULT "  # the line the script inside the namespace reports on

# Shared by the scripts run inside the namespace: what the small disk holds afterwards.
_DIGEST = """
import hashlib, json, shutil, sys
from pathlib import Path

def digest(folder):
    return {
        str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
        for p in sorted(folder.rglob("*")) if p.is_file()
    }
"""


def _digest(folder: Path) -> dict[str, str]:
    return {
        str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
        for p in sorted(folder.rglob("*"))
        if p.is_file()
    }


def _kib_used(folder: Path) -> int:
    """KiB the files of `folder` take on a tmpfs (whole pages)."""
    pages = sum(math.ceil(p.stat().st_size / PAGE) for p in folder.rglob("*") if p.is_file())
    return pages * PAGE // 1024


def _on_a_small_disk(tmp_path: Path, staged: Path, script: str, *args: str):
    """Run `script` (after `_DIGEST`) in a private mount namespace where `disk` (argv[1])
    is a tmpfs holding a copy of `staged` and FREE_KIB more; argv[2] is `staged`.
    Returns (the completed process, the script's RESULT mapping or None)."""
    disk = tmp_path / "disk"
    disk.mkdir()
    size = _kib_used(staged) + FREE_KIB
    path = tmp_path / "script.py"
    path.write_text(_DIGEST + textwrap.dedent(script))
    p = run_on_small_disk(
        disk,
        size,
        [sys.executable, path, disk, staged, *args],
        cwd=Path(__file__).resolve().parent.parent,
        timeout=180,
    )
    lines = [line for line in p.stdout.splitlines() if line.startswith(MARK)]
    return p, (json.loads(lines[-1][len(MARK) :]) if lines else None)


def _one_error_line(stderr: str) -> str:
    lines = [line for line in stderr.splitlines() if line.startswith("emonav: ")]
    assert len(lines) == 1 and "Traceback" not in stderr, stderr
    return lines[0]


def _full(path: Path) -> str:
    return f"emonav: error: [Errno 28] No space left on device: {path} not written"


# --------------------------------------------------------------------------- export


@pytest.mark.slow
def test_export_on_a_full_disk_keeps_the_previous_file(tmp_path):
    staged = tmp_path / "staged"
    staged.mkdir()
    assert main(["export", "--out", str(staged / "p.ts")]) == 0
    before = _digest(staged)
    p, result = _on_a_small_disk(
        tmp_path,
        staged,
        """
        from emonav_drake.cli import main

        disk, staged = Path(sys.argv[1]), Path(sys.argv[2])
        shutil.copy(staged / "p.ts", disk / "p.ts")
        code = main(["export", "--out", str(disk / "p.ts")])
        print("RESULT " + json.dumps({"code": code, "after": digest(disk)}))
        """,
    )
    assert p.returncode == 0 and result is not None, (p.returncode, p.stderr[-2000:])
    disk = tmp_path / "disk"
    assert result["code"] == 2
    assert _one_error_line(p.stderr).startswith(_full(disk / "p.ts"))
    assert result["after"] == before  # the previous file intact, no temporary left


# --------------------------------------------------------------------------- train

SAC_CONFIG = """\
grid_kind: scan
total_steps: 30
random_steps: 10
replay_size: 100
batch_size: 8
hidden: 16
eval_every: 1000
eval_episodes: 1
checkpoint_every: 15
threads: 1
"""

TRAIN_SCRIPT = """
import numpy as np
from emonav_drake.cli import main
from emonav_drake.learning.run_state import DAGGER_FORMAT, write_run_state
from emonav_drake.planners.policy import load_policy, save_policy

disk, staged, config = Path(sys.argv[1]), Path(sys.argv[2]), sys.argv[3]
shutil.copytree(staged, disk, dirs_exist_ok=True)
run = disk / "run"
argv = ["train", "--algo", "sac", "--config", config, "--steps", "60", "--resume", str(run)]
code = main(argv)
errors = {}
big = {"x": np.zeros(10**5)}  # 800 kB
model, meta = load_policy(run / "policy.pt")
for name, save in [
    ("policy.pt", lambda: save_policy(run / "policy.pt", model, meta)),
    (
        "dagger_state.pt",
        lambda: write_run_state(disk / "dagger_state.pt", DAGGER_FORMAT, big, {}),
    ),
]:
    try:
        save()
    except OSError as e:
        errors[name] = str(e)
    except Exception as e:
        errors[name] = f"{type(e).__name__}: {e}"
print("RESULT " + json.dumps({"code": code, "errors": errors, "after": digest(disk)}))
"""


@pytest.mark.slow
def test_train_on_a_full_disk_keeps_the_run_directory(tmp_path):
    """`train --resume` whose checkpoint.pt no longer fits; then policy.pt and
    dagger_state.pt saves on the same full disk."""
    from emonav_drake.learning.run_state import DAGGER_FORMAT, write_run_state

    config = tmp_path / "sac.yaml"
    config.write_text(SAC_CONFIG)
    staged = tmp_path / "staged"
    assert (
        main(["train", "--algo", "sac", "--config", str(config), "--out", str(staged / "run")]) == 0
    )
    write_run_state(staged / "dagger_state.pt", DAGGER_FORMAT, {"round": 1}, {})
    before = _digest(staged)
    p, result = _on_a_small_disk(tmp_path, staged, TRAIN_SCRIPT, str(config))
    assert p.returncode == 0 and result is not None, (p.returncode, p.stderr[-2000:])
    disk = tmp_path / "disk"
    assert result["code"] == 2
    assert _one_error_line(p.stderr).startswith(_full(disk / "run" / "checkpoint.pt"))
    assert result["errors"] == {
        "policy.pt": f"[Errno 28] No space left on device: {disk / 'run' / 'policy.pt'} "
        "not written (its previous content, if any, is kept)",
        "dagger_state.pt": f"[Errno 28] No space left on device: {disk / 'dagger_state.pt'} "
        "not written (its previous content, if any, is kept)",
    }
    after = result["after"]
    assert not [name for name in after if ".tmp" in name], after
    # every state file as it was (the resumed run only added a tensorboard event file)
    assert {k: v for k, v in after.items() if "tensorboard" not in k} == {
        k: v for k, v in before.items() if "tensorboard" not in k
    }


# --------------------------------------------------------------------------- plot


def _trajectory_json(tmp_path: Path) -> tuple[Path, dict]:
    cfg = EmoNavConfig()
    sc = Scenario(
        pedestrians=[PedestrianSpec(start=[1.0, -1.0], goal=[1.0, 2.0])],
        obstacles=[StaticDiscSpec(center=[0.0, 1.0], radius=0.4)],
    )
    record = EpisodeRecord(outcome="timeout", steps=2, seed=-1)
    traj = build_trajectory(
        sc,
        cfg,
        record,
        t=[0.0, 0.4, 0.8],
        robot=[[-1.0, 0.0, 0.0, 0.0], [-0.6, 0.0, 0.0, 0.4], [-0.2, 0.0, 0.0, 0.4]],
        command=[[0.4, 0.0], [0.4, 0.0]],
        pedestrians=np.array([[[1.0, -1.0]], [[1.0, -0.6]], [[1.0, -0.2]]]),
        emotions=np.zeros((3, 1), int),
        planner="dwa",
        plant="lip",
    )
    return tmp_path / "run.json", {"outcome": "timeout", "trajectory": traj.to_json()}


@pytest.mark.parametrize(
    "field, index, value, culprit",
    [
        ("robot", (1, 0), None, "robot[1][0] (x) = null or NaN at step 1 (t = 0.4 s)"),
        ("robot", (2, 1), float("nan"), "robot[2][1] (y) = null or NaN at step 2 (t = 0.8 s)"),
        (
            "pedestrians",
            (1, 0, 1),
            None,
            "pedestrians[1][0][1] (y) = null or NaN at step 1 (t = 0.4 s)",
        ),
        ("t", (2,), float("inf"), "t[2] = Infinity at step 2"),
    ],
)
def test_plot_of_a_trajectory_with_non_finite_numbers_names_them(
    tmp_path, capsys, field, index, value, culprit
):
    path, data = _trajectory_json(tmp_path)
    row = data["trajectory"][field]
    for i in index[:-1]:
        row = row[i]
    row[index[-1]] = value
    path.write_text(json.dumps(data))  # NaN and Infinity as Python's json writes them
    png = tmp_path / "p.png"
    line = assert_user_error(*run(capsys, "plot", path, "--png", png), str(path), culprit)
    assert "not a finite number" in line
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.json"]


def test_plot_of_a_finite_trajectory_still_draws(tmp_path):
    path, data = _trajectory_json(tmp_path)
    path.write_text(json.dumps(data))
    assert main(["plot", str(path), "--png", str(tmp_path / "p.png")]) == 0


# --------------------------------------------------------------------------- emotion estimate


@pytest.mark.parametrize("command", [["sim"], ["eval", "--episodes", "1"]])
def test_classifier_mode_names_the_flag_and_the_file(tmp_path, capsys, command):
    est = tmp_path / "est.yaml"
    est.write_text("mode: classifier\n")
    tiny = tmp_path / "tiny.yaml"
    tiny.write_text("episode: {max_steps: 2}\n")
    code, err = run(capsys, *command, "--config", tiny, "--emotion-estimate", est)
    line = assert_user_error(code, err, f"--emotion-estimate {est}", "mode: classifier")
    assert "camera" in line and "confusion" in line  # what to use instead
    assert "ep/s" not in err  # refused before the first episode


def test_other_emotion_estimate_errors_name_the_flag_and_the_file(tmp_path, capsys):
    est = tmp_path / "est.yaml"
    est.write_text("period: -1\n")
    assert_user_error(
        *run(capsys, "sim", "--emotion-estimate", est),
        f"--emotion-estimate {est}: emotion_estimate.period = -1.0",
    )


CURVE_SCRIPT = """
import resource, signal, sys, types
from pathlib import Path
import torch
from emonav_drake.learning.sac_curve import append_curve_row

path = Path(sys.argv[1])
signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # a write past the limit: EFBIG, not a kill
limit = path.stat().st_size + 10  # room for 10 bytes of the next row: a torn row before
resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))
stats = {"SR": 0.5, "collision_rate": 0.25, "timeout_rate": 0.25, "NT_mean": 21.0, "DT": 3.0,
         "return_mean": 1.5}
try:
    append_curve_row(path, 20, 4, stats, types.SimpleNamespace(alpha=torch.tensor(0.2)))
except OSError as e:
    print(e)
"""


@pytest.mark.slow
def test_a_learning_curve_row_that_does_not_fit_is_not_torn(tmp_path):
    """The SAC learning curve's append on a disk that fills mid-row (a file size limit)."""
    import types

    import torch

    from emonav_drake.learning.sac_curve import append_curve_row

    curve = tmp_path / "learning_curve.csv"
    stats = {"SR": 1.0, "collision_rate": 0.0, "timeout_rate": 0.0, "NT_mean": 20.0, "DT": 1.0}
    append_curve_row(
        curve, 10, 2, stats | {"return_mean": 2.0}, types.SimpleNamespace(alpha=torch.tensor(0.3))
    )
    before = curve.read_bytes()
    script = tmp_path / "curve.py"
    script.write_text(CURVE_SCRIPT)
    p = subprocess.run(
        [sys.executable, str(script), str(curve)],
        capture_output=True,
        text=True,
        timeout=120,
        cwd=Path(__file__).resolve().parent.parent,
    )
    assert p.returncode == 0, p.stderr
    assert f"{curve} could not be appended to (its earlier rows are kept)" in p.stdout, p.stdout
    assert curve.read_bytes() == before  # no torn row
