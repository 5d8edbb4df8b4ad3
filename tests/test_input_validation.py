"""Inputs that crashed, were silently accepted or wrote through links (issue 20).

Every bad input gives exit code 2 and one line `emonav: error: ...` naming the flag, file,
line or field — before any long work, and without touching other files. Real code only:
real benchmark run directories, real files and links, a real full disk (a tiny tmpfs in a
private mount namespace, when the machine allows one).
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import cv2
import numpy as np
import pytest

from emonav_drake.cli import main
from emonav_drake.evaluation.run_directory import load_run, read_trials
from emonav_drake.evaluation.run_settings import BenchmarkSettingsError
from tests.cli_errors import assert_user_error, run
from tests.small_disk import run_on_small_disk

TINY = "episode: {max_steps: 2}\n"
BIG_SEED = 2**64  # one beyond 64 bits


def emonav(*argv, timeout=120):
    """The real `emonav` process: (exit code, stderr)."""
    p = subprocess.run(
        [sys.executable, "-m", "emonav_drake.cli", *map(str, argv)],
        capture_output=True,
        text=True,
        timeout=timeout,
    )
    return p.returncode, p.stderr


@pytest.fixture(scope="module")
def tiny(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("cfg") / "tiny.yaml"
    path.write_text(TINY)
    return path


def _bench_argv(out: Path, tiny: Path, trials: int = 3) -> list[str]:
    return [
        "benchmark",
        "--planners",
        "dwa",
        "--trials",
        str(trials),
        "--first-seed",
        "4",
        "--workers",
        "1",
        "--quiet",
        "--config",
        str(tiny),
        "--out",
        str(out),
    ]


@pytest.fixture(scope="module")
def finished_run(tmp_path_factory, tiny) -> Path:
    """A real, finished benchmark run directory: dwa on seeds 4-6, 2-step episodes."""
    out = tmp_path_factory.mktemp("bench") / "run"
    assert main(_bench_argv(out, tiny)) == 0
    return out


def _edit_line(path: Path, index: int, edit) -> None:
    lines = path.read_text().splitlines(keepends=True)
    t = json.loads(lines[index])
    edit(t)
    lines[index] = json.dumps(t) + "\n"
    path.write_text("".join(lines))


# --- trials.jsonl records: checked when the run directory is read -----------------------------


def _drop_outcome(t):
    del t["record"]["outcome"]


def _set(key, value):
    def edit(t):
        t["record"][key] = value

    return edit


def _negative_idt(t):
    t["record"]["idt"][2] = -3


def _bad_seed(t):
    t["seed"] = -4


@pytest.mark.slow
@pytest.mark.parametrize(
    "edit, culprit",
    [
        (_drop_outcome, "record lacks outcome"),
        (_set("outcome", "won"), "record.outcome = 'won'"),
        (_set("discomfort_steps", -82), "record.discomfort_steps = -82"),
        (_set("steps", -1), "record.steps = -1"),
        (_negative_idt, "record.idt[2] = -3"),
        (_set("path_length", float("nan")), "record.path_length"),
        (_set("min_ped_distance", -0.5), "record.min_ped_distance"),
        (_set("steps", "two"), "record.steps = 'two'"),
        (_set("winner", True), "unknown field 'winner'"),
        (_bad_seed, "seed = -4"),
    ],
)
def test_an_invalid_trial_line_is_refused_naming_the_file_and_line(
    finished_run, tmp_path, tiny, capsys, edit, culprit
):
    out = tmp_path / "run"
    shutil.copytree(finished_run, out)
    trials = out / "trials.jsonl"
    _edit_line(trials, 1, edit)
    tables_before = (out / "tables.md").read_bytes()
    with pytest.raises(BenchmarkSettingsError, match="line 2 is not a valid trial"):
        load_run(out)
    # continuing the run: refused before any trial or table; nothing written
    line = assert_user_error(*run(capsys, *_bench_argv(out, tiny)), f"{trials}: line 2", culprit)
    assert "fix or remove that line" in line
    assert (out / "tables.md").read_bytes() == tables_before


def test_a_bad_last_line_is_not_mistaken_for_a_torn_one(finished_run, tmp_path):
    """A complete last line with an unknown outcome is an error, not silently dropped."""
    out = tmp_path / "run"
    shutil.copytree(finished_run, out)
    _edit_line(out / "trials.jsonl", 2, _set("outcome", "won"))
    with pytest.raises(BenchmarkSettingsError, match="line 3 is not a valid trial"):
        read_trials(out / "trials.jsonl", repair=True)
    assert len((out / "trials.jsonl").read_text().splitlines()) == 3  # nothing cut


# --- run-directory files that are links ------------------------------------------------------


def _torn(path: Path) -> bytes:
    data = path.read_bytes()
    return data[:-25]  # a kill in the middle of the last line


def test_a_trials_file_that_is_a_symlink_is_refused_and_its_target_untouched(
    finished_run, tmp_path, tiny, capsys
):
    out = tmp_path / "run"
    shutil.copytree(finished_run, out)
    other = tmp_path / "precious.jsonl"
    other.write_bytes(_torn(out / "trials.jsonl"))  # would be cut, then appended to
    before = other.read_bytes()
    (out / "trials.jsonl").unlink()
    (out / "trials.jsonl").symlink_to(other)
    assert_user_error(
        *run(capsys, *_bench_argv(out, tiny, trials=4)), str(out), "trials.jsonl", "symbolic link"
    )
    assert other.read_bytes() == before


@pytest.mark.parametrize("name", ["settings.json", "tables.md", "pairwise.csv"])
def test_other_run_files_that_are_symlinks_are_refused(finished_run, tmp_path, tiny, capsys, name):
    out = tmp_path / "run"
    shutil.copytree(finished_run, out)
    other = tmp_path / f"other-{name}"
    shutil.copy(out / name, other)
    (out / name).unlink()
    (out / name).symlink_to(other)
    before = other.read_bytes()
    assert_user_error(*run(capsys, *_bench_argv(out, tiny)), name, "symbolic link")
    assert other.read_bytes() == before and (out / name).is_symlink()


def test_a_trials_file_with_another_hard_link_is_refused(finished_run, tmp_path, tiny, capsys):
    out = tmp_path / "run"
    shutil.copytree(finished_run, out)
    backup = tmp_path / "backup.jsonl"
    os.link(out / "trials.jsonl", backup)
    before = backup.read_bytes()
    assert_user_error(*run(capsys, *_bench_argv(out, tiny, trials=4)), "hard links")
    assert backup.read_bytes() == before


# --- emotion: the annotation must not overwrite the input under another name ----------------


@pytest.mark.parametrize("link", ["symlink", "hardlink", "dotdot"])
def test_emotion_annotate_onto_its_input_by_another_path_is_refused(tmp_path, capsys, link):
    image = tmp_path / "face.png"
    cv2.imwrite(str(image), np.full((64, 64, 3), 120, np.uint8))
    before = image.read_bytes()
    other = tmp_path / "alias.png"
    if link == "symlink":
        other.symlink_to(image)
    elif link == "hardlink":
        os.link(image, other)
    else:
        (tmp_path / "sub").mkdir()
        other = tmp_path / "sub" / ".." / "face.png"
    assert_user_error(*run(capsys, "emotion", other, "--annotate", image), "PATH", "--annotate")
    assert image.read_bytes() == before


# --- scenarios that cannot be an episode's start -------------------------------------------


def _crowd_at_one_spot(n: int) -> str:
    return "pedestrians:\n" + "".join(
        "  - {start: [0.0, 3.0], goal: [0.0, -3.0], emotion: happy}\n" for _ in range(n)
    )


@pytest.mark.parametrize(
    "yaml_text, culprits",
    [
        (
            "pedestrians:\n"
            "  - {start: [0.0, 3.0], goal: [0.0, -3.0], emotion: happy}\n"
            "  - {start: [0.4, 3.0], goal: [0.4, -3.0], emotion: negative}\n",
            ["pedestrians[1].start", "overlaps pedestrians[0].start"],
        ),
        (
            "obstacles:\n  - {center: [0.0, 2.0], radius: 0.5}\n"
            "pedestrians:\n  - {start: [0.0, 2.1], goal: [0.0, -3.0], emotion: happy}\n",
            ["pedestrians[0].start", "inside obstacles[0]"],
        ),
        (
            "obstacles:\n  - {center: [0.0, -3.0], radius: 0.5}\n"
            "pedestrians:\n  - {start: [0.0, 3.0], goal: [0.0, -3.0], emotion: happy}\n",
            ["pedestrians[0].goal", "inside obstacles[0]"],
        ),
        (_crowd_at_one_spot(1000), ["pedestrians", "1000 given", "at most 20"]),
        (_crowd_at_one_spot(2), ["pedestrians[1].start", "overlaps"]),
        (
            "obstacles:\n"
            + "".join(f"  - {{center: [{i * 0.1:.1f}, 2.5], radius: 0.05}}\n" for i in range(21)),
            ["obstacles", "21 given", "at most 20"],
        ),
        ("robot_start: [1.0, 1.0]\nrobot_goal: [1.0, 1.0]\n", ["robot_goal", "goal radius"]),
        ("robot_start: [1.0, 1.0]\nrobot_goal: [1.1, 1.0]\n", ["robot_goal", "goal radius"]),
        ("seed: 18446744073709551616\n", ["seed"]),
    ],
)
def test_scenarios_that_cannot_start_an_episode_are_refused(tmp_path, capsys, yaml_text, culprits):
    sc = tmp_path / "scene.yaml"
    sc.write_text(yaml_text)
    out = tmp_path / "r.json"
    assert_user_error(*run(capsys, "sim", "--scenario", sc, "--json", out), str(sc), *culprits)
    assert not out.exists()


def test_the_sampler_never_draws_a_refused_scenario():
    """Seeds 0-999 of the default configuration pass every check of a scenario file."""
    from emonav_drake.params import load_config
    from emonav_drake.scenarios.scenario import sample_scenario

    cfg = load_config()
    goal_radius = max(cfg.episode.goal_radius, cfg.episode.eval_goal_radius)
    for seed in range(1000):
        sample_scenario(seed, cfg).validate(
            cfg.robot.radius, cfg.crowd.pedestrian_radius, goal_radius
        )


# --- seeds and sizes ---------------------------------------------------------------------------


@pytest.mark.parametrize(
    "argv, flag",
    [
        (["sim", "--seed", "{seed}"], "--seed"),
        (["lgm", "--png", "{tmp}/g.png", "--seed", "{seed}"], "--seed"),
        (["eval", "--episodes", "1", "--first-seed", "{seed}"], "--first-seed"),
        (["walk", "--seconds", "0.1", "--seed", "{seed}"], "--seed"),
        (
            ["benchmark", "--planners", "dwa", "--out", "{tmp}/b", "--first-seed", "{seed}"],
            "--first-seed",
        ),
    ],
)
@pytest.mark.parametrize("seed", [BIG_SEED, 10**30, -1, "1e3"])
def test_every_seed_flag_is_a_64_bit_unsigned_integer(tmp_path, capsys, argv, flag, seed):
    argv = [a.replace("{seed}", str(seed)).replace("{tmp}", str(tmp_path)) for a in argv]
    line = assert_user_error(*run(capsys, *argv), f"{flag} {seed if seed != '1e3' else repr(seed)}")
    if isinstance(seed, int) and seed > 0:
        assert "64 bits" in line
    assert list(tmp_path.iterdir()) == []


def test_the_last_seed_of_a_range_must_fit_too(tmp_path, capsys):
    last = str(2**64 - 1)
    assert_user_error(
        *run(capsys, "eval", "--episodes", "2", "--first-seed", last), "--first-seed", "64 bits"
    )
    out = tmp_path / "b"
    argv = ["benchmark", "--planners", "dwa", "--trials", "2", "--first-seed", last, "--out", out]
    assert_user_error(*run(capsys, *argv), "--first-seed", "64 bits")
    assert not out.exists()


def test_the_largest_seed_is_accepted():
    from emonav_drake.cli.common import parse_seed
    from emonav_drake.scenarios.scenario import sample_scenario

    assert parse_seed(str(2**64 - 1), "--seed") == 2**64 - 1
    assert sample_scenario(2**64 - 1).seed == 2**64 - 1


@pytest.mark.slow
def test_huge_episode_and_trial_counts_are_refused_at_once(tmp_path):
    """Before: minutes of pre-sampling with memory growing; now: one line, at once."""
    code, err = emonav("eval", "--episodes", 10**9, timeout=60)
    assert code == 2 and err.splitlines() == [
        "emonav: error: --episodes 1000000000: must be in [1, 100000] (split a longer "
        "evaluation with --first-seed)"
    ]
    out = tmp_path / "b"
    code, err = emonav(
        "benchmark", "--planners", "dwa", "--trials", 10**12, "--out", out, timeout=60
    )
    assert code == 2 and len(err.splitlines()) == 1 and "--trials 1000000000000" in err
    assert not out.exists()


def test_walk_seconds_is_bounded(tmp_path, capsys):
    """Before: `--seconds 1e9` allocated 37 GiB of commands (exit 1, MemoryError)."""
    from emonav_drake.diagrams.walking import MAX_WALK_SECONDS, run_walk

    out = tmp_path / "w.json"
    assert_user_error(*run(capsys, "walk", "--seconds", "1e9", "--json", out), "--seconds", "3600")
    assert not out.exists()
    with pytest.raises(ValueError, match="seconds must be in"):
        run_walk(MAX_WALK_SECONDS * 2)


# --- flags that mean nothing together, wrong suffixes -----------------------------------------


@pytest.mark.parametrize(
    "extra, culprit",
    [
        (["--setting", "var_dd"], "--setting"),
        (["--config", "{tmp}/c.yaml"], "--config"),
        (["--time-varying"], "--time-varying"),
        (["--dump"], "--dump"),
    ],
)
def test_config_list_refuses_flags_it_ignores(tmp_path, capsys, extra, culprit):
    (tmp_path / "c.yaml").write_text(TINY)
    extra = [a.replace("{tmp}", str(tmp_path)) for a in extra]
    assert_user_error(*run(capsys, "config", "--list", *extra), "--list", culprit)
    assert run(capsys, "config", "--list")[0] == 0


def test_lgm_png_with_another_suffix_is_refused_before_any_work(tmp_path, capsys):
    out = tmp_path / "x.txt"
    assert_user_error(*run(capsys, "lgm", "--png", out), f"--png {out}", ".png")
    assert list(tmp_path.iterdir()) == []


# --- a full disk: the message names the file ------------------------------------------------

FULL_DISK_SCRIPT = textwrap.dedent(
    """
    import json, sys
    from pathlib import Path
    from emonav_drake.atomic_io import atomic_write, write_text_atomic
    from emonav_drake.cli import main
    from emonav_drake.evaluation.run_directory import RunDirectory

    full = Path(sys.argv[1])
    errors = {}
    for name, write in [
        ("write_text_atomic", lambda p: write_text_atomic(p, "x" * 100_000)),
        ("atomic_write", lambda p: atomic_write(p, lambda f: f.write(b"x" * 100_000))),
        ("append", lambda p: RunDirectory(full).append({"pad": "x" * 100_000})),
    ]:
        try:
            write(full / "out.json")
        except OSError as e:
            errors[name] = str(e)
    errors["files"] = sorted(p.name for p in full.iterdir())
    print(json.dumps(errors))
    sys.stdout.flush()
    sys.exit(main(["lgm", "--steps", "0", "--png", str(full / "g.png")]))
    """
)


@pytest.mark.slow
def test_a_full_disk_names_the_file(tmp_path):
    """A 4 KiB tmpfs in a private mount namespace (unshare): every writer fills it."""
    full = tmp_path / "full"
    full.mkdir()
    script = tmp_path / "fill.py"
    script.write_text(FULL_DISK_SCRIPT)
    p = run_on_small_disk(full, 4, [sys.executable, script, full], timeout=120)
    errors = json.loads(p.stdout.splitlines()[0])
    target = full / "out.json"
    assert f"No space left on device: {target} not written" in errors["write_text_atomic"]
    assert f"No space left on device: {target} not written" in errors["atomic_write"]
    assert f"{full / 'trials.jsonl'} could not be appended to" in errors["append"]
    assert not [n for n in errors["files"] if "tmp" in n]  # no temporary file left
    assert p.returncode == 2, p.stderr
    assert p.stderr.splitlines() == [
        f"emonav: error: [Errno 28] No space left on device: {full / 'g.png'} not written "
        "(its previous content, if any, is kept)"
    ]
