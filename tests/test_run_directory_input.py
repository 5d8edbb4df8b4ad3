"""Run directories and the other JSON the CLI reads, Meshcat hosts, Ray addresses (issue 36).

Nothing a user gives may change a result unseen, or end in a traceback: deeply nested
JSON, a `settings.json` that is not a run's settings, a `config_yaml` edited without its
hash, trial records that disagree with themselves or with the run's configuration, a
`--meshcat-host` that is not this machine, a `--ray-address` nobody answers at, a disk
that fills while `trials.jsonl` grows. Real files, real runs, a real tmpfs.
"""

from __future__ import annotations

import glob
import json
import shutil
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

from emonav_drake.cli import main
from emonav_drake.evaluation.run_directory import load_run
from tests.cli_errors import assert_user_error, run
from tests.small_disk import run_on_small_disk
from tests.test_input_validation import _bench_argv as bench_argv

REPO = Path(__file__).resolve().parents[1]
COMMITTED = REPO / "benchmarks" / "results"
LIP_RUN = COMMITTED / "lip_table2"  # 1500 trials of the paper's setting
DEEP = "[" * 100_000  # json.loads: RecursionError, not a ValueError
TINY = "episode: {max_steps: 12}\n"


def emonav(*argv, timeout=120, prefix=()) -> tuple[int, str, float]:
    """The real `emonav` process (run through `prefix`): (exit code, stderr, seconds)."""
    t0 = time.monotonic()
    p = subprocess.run(
        [*prefix, sys.executable, "-m", "emonav_drake.cli", *map(str, argv)],
        capture_output=True,
        text=True,
        timeout=timeout,
    )
    return p.returncode, p.stderr, time.monotonic() - t0


def _bench_argv(out: Path, tiny: Path, trials: int = 2) -> list[str]:
    return bench_argv(out, tiny, trials)


@pytest.fixture(scope="module")
def tiny(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("cfg") / "tiny.yaml"
    path.write_text(TINY)
    return path


@pytest.fixture(scope="module")
def fresh(tmp_path_factory, tiny) -> Path:
    """A real benchmark run of this code (resumable by it): dwa, seeds 4–5, 12 steps."""
    out = tmp_path_factory.mktemp("bench") / "fresh"
    assert main(_bench_argv(out, tiny)) == 0
    return out


def _copy(run_dir: Path, tmp_path: Path, name: str = "run") -> Path:
    out = tmp_path / name
    shutil.copytree(run_dir, out)
    return out


def _snapshot(d: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(d.iterdir())}


def _edit_line(path: Path, number: int, edit) -> None:
    """Replace line `number` (1-based) of a JSON-lines file by `edit(its object)`."""
    lines = path.read_text().splitlines()
    lines[number - 1] = json.dumps(edit(json.loads(lines[number - 1])))
    path.write_text("\n".join(lines) + "\n")


def _edit_settings(run_dir: Path, edit) -> None:
    path = run_dir / "settings.json"
    path.write_text(json.dumps(edit(json.loads(path.read_text())), indent=2))


# ------------------------------------------------------------------ 1. nested JSON
@pytest.mark.slow
def test_deeply_nested_json_is_refused_by_every_command_naming_the_file(
    tmp_path, tiny, fresh, capsys
):
    """`[[[[…` 100 000 deep in every JSON file a command reads: exit 2, the file named
    (and the line of a JSON-lines file), not `internal error: RecursionError`."""
    deep = tmp_path / "deep.json"
    deep.write_text(DEEP)
    deep_lines = tmp_path / "deep.jsonl"
    deep_lines.write_text(DEEP + "\n")

    # benchmark / diagnose / compare: trials.jsonl (line 1 of 2) and settings.json
    bad_trials = _copy(fresh, tmp_path, "bad_trials")
    lines = (bad_trials / "trials.jsonl").read_text().splitlines()
    (bad_trials / "trials.jsonl").write_text(DEEP + "\n" + lines[1] + "\n")
    bad_settings = _copy(fresh, tmp_path, "bad_settings")
    (bad_settings / "settings.json").write_text(DEEP)
    for run_dir, culprits in (
        (bad_trials, [f"{bad_trials / 'trials.jsonl'}", "line 1", "nested too deeply"]),
        (bad_settings, [f"{bad_settings / 'settings.json'}", "nested too deeply"]),
    ):
        before = _snapshot(run_dir)
        for argv in (
            _bench_argv(run_dir, tiny),
            ["diagnose", run_dir, "--failures"],
            ["diagnose", run_dir, "--out", tmp_path / "diag"],
            ["compare", run_dir, fresh, "--out", tmp_path / "cmp"],
        ):
            assert_user_error(*run(capsys, *argv), *culprits)
        assert _snapshot(run_dir) == before  # nothing touched
    # calibrate fit / collect (resuming into the trace file): the line named
    assert_user_error(
        *run(capsys, "calibrate", "fit", deep_lines, "--out", tmp_path / "m.json"),
        f"{deep_lines}:1",
        "nested too deeply",
    )
    assert_user_error(
        *run(capsys, "calibrate", "collect", "--planners", "dwa", "--out", deep_lines),
        f"{deep_lines}:1",
    )
    # plot: an `emonav sim --json` file
    assert_user_error(*run(capsys, "plot", deep, "--png", tmp_path / "p.png"), str(deep))
    # train: a DAgger configuration's step-response model (`response:`)
    cfg = tmp_path / "dagger.yaml"
    cfg.write_text(f"response: {deep}\n")
    assert_user_error(
        *run(capsys, "train", "--algo", "dagger", "--config", cfg, "--out", tmp_path / "tr"),
        str(deep),
    )
    assert not (tmp_path / "tr").exists()
    assert not list(tmp_path.glob("*.png")) and not (tmp_path / "m.json").exists()


# ------------------------------------------------------------- 2. settings shape
@pytest.mark.parametrize(
    ("content", "culprit"),
    [
        ("[]", "not a JSON object (a list)"),
        ('"settings"', "not a JSON object (a str)"),
        ("{}", "lacks the field"),
        ('{"format": 1, "planners": "dwa"}', "planners"),
    ],
)
def test_settings_that_are_not_a_run_s_settings_are_refused(
    tmp_path, tiny, fresh, capsys, content, culprit
):
    run_dir = _copy(fresh, tmp_path)
    (run_dir / "settings.json").write_text(content)
    before = _snapshot(run_dir)
    for argv in (
        ["diagnose", run_dir, "--failures"],
        ["compare", run_dir, fresh, "--out", tmp_path / "cmp"],
        _bench_argv(run_dir, tiny),
    ):
        assert_user_error(*run(capsys, *argv), str(run_dir / "settings.json"), culprit)
    assert _snapshot(run_dir) == before


def test_a_settings_field_of_the_wrong_kind_is_named(tmp_path, tiny, fresh, capsys):
    for field, value in (("methods", []), ("first_seed", "4"), ("config_yaml", 7)):
        run_dir = _copy(fresh, tmp_path, f"run_{field}")
        _edit_settings(run_dir, lambda s, f=field, v=value: s | {f: v})
        for argv in (["diagnose", run_dir, "--failures"], _bench_argv(run_dir, tiny)):
            assert_user_error(*run(capsys, *argv), str(run_dir / "settings.json"), field)


# -------------------------------------------------------------- 3. --meshcat-host
@pytest.mark.parametrize("host", ["10.254.254.254", "not a host!"])
def test_a_meshcat_host_that_is_not_this_machine_is_refused_before_the_episode(
    tmp_path, capsys, host
):
    cfg = tmp_path / "tiny.yaml"
    cfg.write_text(TINY)
    for argv in (
        ["sim", "--config", cfg, "--meshcat", "--no-wait", "--meshcat-host", host],
        ["walk", "--seconds", "0.1", "--meshcat", "--no-wait", "--meshcat-host", host],
    ):
        line = assert_user_error(*run(capsys, *argv), f"--meshcat-host {host!r}")
        assert "Meshcat failed to open a websocket port" not in line


def test_meshcat_on_ipv6_loopback_prints_a_url_with_brackets(capsys):
    from emonav_drake.diagrams.meshcat_viewing import make_meshcat, start_live_view

    for host in ("::1", "[::1]"):
        meshcat = make_meshcat(live=True, host=host)
        start_live_view(meshcat, wait=False)
        out = capsys.readouterr().out
        assert f"Meshcat: http://[::1]:{meshcat.port()}" in out, out
        del meshcat


# --------------------------------------------------------------- 4. --ray-address
@pytest.mark.slow
@pytest.mark.parametrize(
    ("address", "culprits"),
    [
        ("127.0.0.1:1", ["--ray-address 127.0.0.1:1", "ray start --head"]),
        ("auto", ["--ray-address auto", "ray start --head", "drop --ray-address"]),
    ],
)
def test_a_ray_address_without_a_cluster_fails_at_once_and_leaves_nothing(
    tmp_path, tiny, monkeypatch, address, culprits
):
    """127.0.0.1:1 retried for minutes; `auto` named Ray's `--address` flag and
    RAY_ADDRESS; both left a stub settings.json in --out."""
    monkeypatch.delenv("RAY_ADDRESS", raising=False)
    prefix: tuple[str, ...] = ()
    if address == "auto":  # `auto` finds any Ray running here: see only our own processes
        prefix = ("unshare", "-rpf", "--mount-proc")
        if shutil.which("unshare") is None or subprocess.run([*prefix, "true"]).returncode:
            pytest.skip("no private process namespace (unshare -rpf) to hide other Rays")
    out = tmp_path / "new" / "run"
    argv = _bench_argv(out, tiny)
    argv[argv.index("--workers") : argv.index("--workers") + 2] = ["--ray-address", address]
    try:
        code, err, seconds = emonav(*argv, timeout=90, prefix=prefix)
    except subprocess.TimeoutExpired:
        pytest.fail(f"--ray-address {address}: still waiting after 90 s")
    assert_user_error(code, err, *culprits)
    assert "`--address`" not in err and "RAY_ADDRESS" not in err
    assert seconds < 40, seconds
    assert not (tmp_path / "new").exists()  # the folders it made are gone again
    # an --out that existed stays, untouched
    kept = tmp_path / "kept"
    kept.mkdir()
    argv[argv.index("--out") + 1] = str(kept)
    code, err, _ = emonav(*argv, timeout=90, prefix=prefix)
    assert_user_error(code, err, "--ray-address")
    assert kept.is_dir() and not list(kept.iterdir())


# ------------------------------------------------------------- 5. record checks
def _timeout_line(path: Path) -> int:
    for i, line in enumerate(path.read_text().splitlines(), 1):
        if json.loads(line)["record"]["outcome"] == "timeout":
            return i
    raise AssertionError("no timeout in the run")


RECORD_EDITS = {
    # nav_time is steps × robot.step_time (0.4 s): 2 s more than the steps say
    "nav_time": (lambda t: t | {"record": t["record"] | {"nav_time": 2 + t["record"]["nav_time"]}}),
    # a timeout ends at episode.max_steps (125), never before
    "timeout": (
        lambda t: (
            t | {"record": t["record"] | {"outcome": "timeout", "steps": 60, "nav_time": 60 * 0.4}}
        )
    ),
    # no episode runs past episode.max_steps
    "steps": (
        lambda t: (
            t
            | {"record": t["record"] | {"outcome": "success", "steps": 300, "nav_time": 300 * 0.4}}
        )
    ),
    # top-level fields are as closed as the record's
    "unknown": (lambda t: t | {"weight": 3}),
}
RECORD_CULPRITS = {
    "nav_time": "record.nav_time",
    "timeout": "record.steps = 60",
    "steps": "record.steps = 300",
    "unknown": "unknown field 'weight'",
}


@pytest.mark.parametrize("case", sorted(RECORD_EDITS))
def test_records_that_disagree_with_themselves_or_the_run_are_refused(
    tmp_path, tiny, fresh, capsys, case
):
    """Each edit kept every value in range (accepted into the tables before)."""
    run_dir = _copy(LIP_RUN, tmp_path)
    trials = run_dir / "trials.jsonl"
    number = 2 if case != "timeout" else 3
    _edit_line(trials, number, RECORD_EDITS[case])
    for argv in (
        ["diagnose", run_dir, "--failures"],
        ["compare", run_dir, fresh, "--out", tmp_path / "cmp"],
    ):
        assert_user_error(*run(capsys, *argv), f"{trials}: line {number}", RECORD_CULPRITS[case])
    # resuming a run of this code: refused, nothing touched
    mine = _copy(fresh, tmp_path, "mine")
    _edit_line(mine / "trials.jsonl", 1, RECORD_EDITS[case])
    before = _snapshot(mine)
    assert_user_error(
        *run(capsys, *_bench_argv(mine, tiny, 3)),
        f"{mine / 'trials.jsonl'}: line 1",
        RECORD_CULPRITS[case],
    )
    assert _snapshot(mine) == before


@pytest.mark.slow
def test_every_committed_run_still_loads():
    """The checks refuse no record of a real run (benchmarks/results, all of them)."""
    runs = sorted(Path(p).parent for p in glob.glob(f"{COMMITTED}/**/trials.jsonl", recursive=True))
    assert len(runs) >= 40
    for run_dir in runs:
        settings, trials = load_run(run_dir)
        assert len(trials) == len((run_dir / "trials.jsonl").read_text().splitlines()), run_dir
        assert {t["method"] for t in trials} <= set(settings["planners"])


# ---------------------------------------------------- 6. configuration and its hash
@pytest.mark.parametrize("field", ["config_yaml", "emotion_estimate_yaml"])
def test_a_configuration_edited_without_its_hash_is_refused(tmp_path, tiny, fresh, capsys, field):
    """`diagnose --out` re-simulated the edited configuration silently."""
    if field == "config_yaml":
        run_dir = _copy(fresh, tmp_path)
        edit = lambda s: s | {field: s[field].replace("max_speed: 0.4", "max_speed: 0.6")}  # noqa: E731
    else:
        run_dir = _copy(COMMITTED / "digit_camera", tmp_path)
        edit = lambda s: s | {field: s[field] + "# edited\n"}  # noqa: E731
    _edit_settings(run_dir, edit)
    assert (
        json.loads((run_dir / "settings.json").read_text())[field]
        != json.loads(
            (
                (fresh if field == "config_yaml" else COMMITTED / "digit_camera") / "settings.json"
            ).read_text()
        )[field]
    )
    before = _snapshot(run_dir)
    argvs = [
        ["diagnose", run_dir, "--failures"],
        ["compare", run_dir, fresh, "--out", tmp_path / "cmp"],
        ["diagnose", run_dir, "--out", tmp_path / "diag"],
    ]
    if field == "config_yaml":
        argvs.append(_bench_argv(run_dir, tiny))
    for argv in argvs:
        assert_user_error(
            *run(capsys, *argv),
            f"{run_dir / 'settings.json'}",
            field,
            field.replace("yaml", "sha256"),
        )
    assert _snapshot(run_dir) == before
    assert not (tmp_path / "diag").exists() and not (tmp_path / "cmp").exists()


# ---------------------------------------------------------------- 7. full disk
FULL_DISK_BENCH = textwrap.dedent(
    """
    import json, os, sys
    from pathlib import Path
    from emonav_drake.cli import main
    from emonav_drake.evaluation.run_directory import load_run

    def seed_of(line):
        try:
            return json.loads(line)["seed"]
        except ValueError:
            return None  # a torn line

    full, tiny = Path(sys.argv[1]), sys.argv[2]
    out = full / "run"
    argv = ["benchmark", "--planners", "dwa", "--trials", "40", "--first-seed", "4",
            "--workers", "1", "--quiet", "--config", tiny, "--out", str(out)]
    filler = full / "filler"
    with open(filler, "wb", buffering=0) as f:  # fill the disk, then free three pages:
        try:  # two for settings.json (4.4 kB), one for trials.jsonl (~13 trials)
            while True:
                f.write(b"x" * 4096)
        except OSError:
            pass
    os.truncate(filler, os.path.getsize(filler) // 4096 * 4096 - 3 * 4096)
    code = main(argv)
    lines = (out / "trials.jsonl").read_bytes()
    report = {"code": code, "ends_with_newline": lines.endswith(b"\\n"),
              "seeds": [seed_of(x) for x in lines.splitlines()],
              "files": sorted(p.name for p in out.iterdir())}
    filler.unlink()
    _, trials = load_run(out)  # what a resume reads: every line a whole, valid trial
    report["loaded"] = len(trials)
    print(json.dumps(report))
    """
)


@pytest.mark.slow
def test_a_full_disk_while_appending_a_trial_names_trials_jsonl_and_cuts_the_torn_line(
    tmp_path, tiny
):
    """Before: the error named tables.md (written after the failed append) and
    trials.jsonl kept half a line."""
    full = tmp_path / "full"
    full.mkdir()
    script = tmp_path / "fill.py"
    script.write_text(FULL_DISK_BENCH)
    p = run_on_small_disk(full, 64, [sys.executable, script, full, tiny], cwd=REPO)
    assert p.stdout.strip(), p.stderr
    report = json.loads(p.stdout.splitlines()[-1])
    errors = [line for line in p.stderr.splitlines() if line.startswith("emonav: error: ")]
    assert report["code"] == 2, p.stderr
    assert len(errors) == 1, p.stderr
    trials = full / "run" / "trials.jsonl"
    assert f"No space left on device: {trials} could not be appended to" in errors[0]
    assert "tables.md" not in errors[0]
    assert report["ends_with_newline"]  # no torn line: cut back to the finished trials
    seeds = report["seeds"]
    assert 1 < len(seeds) < 40 and seeds == list(range(4, 4 + len(seeds)))
    assert not [n for n in report["files"] if "tmp" in n], report["files"]
    assert report["loaded"] == len(seeds)  # the same command again continues from there


def test_a_runs_summary_names_the_emotion_source_it_ran_with():
    """The summary line of tables.md says how the robot perceived emotions: the camera
    kept per track is not a "confusion model" (as camera_tracks runs were once labelled)."""
    from emonav_drake.evaluation.run_directory import _estimate_label
    from emonav_drake.perception.noisy_emotions import ESTIMATE_MODES

    labels = {m: _estimate_label(f"mode: {m}\nperiod: 0.4\n") for m in ESTIMATE_MODES}
    assert labels["camera_tracks"] == "head camera, emotion kept per LiDAR track (2.5 Hz)"
    assert labels["camera"].startswith("head camera + face classifier (2.5 Hz")
    assert len(set(labels.values())) == len(ESTIMATE_MODES)  # no two modes alike
    assert _estimate_label(None) == "ground truth"
    assert _estimate_label("mode: camera\nperiod: 2.0\n").startswith(
        "head camera + face classifier (0.5 Hz"
    )


def test_a_run_records_its_blas_kernels_and_a_resume_on_others_says_how_to_match(
    tmp_path, tiny, fresh, caplog
):
    """OpenBLAS picks its kernels by the processor, and they round differently in the
    last bits: a run's settings record the kernels (and OPENBLAS_CORETYPE) it ran on, and
    continuing it on other kernels warns, naming the variable that would match them —
    the trials done stay and the run goes on."""
    from emonav_drake.provenance import numeric_kernels

    settings = json.loads((fresh / "settings.json").read_text())
    here = numeric_kernels()
    assert settings["numerics"] == here
    assert here["blas"] and all(b["architecture"] not in ("", "None") for b in here["blas"])
    # every BLAS the process loaded (numpy's, SciPy's, another wheel's) is named
    line = next(x for x in (fresh / "tables.md").read_text().splitlines() if "BLAS kernels" in x)
    assert all(f"{b['library']} {b['architecture']}" in line for b in here["blas"])
    run_dir = _copy(fresh, tmp_path)
    other = {"library": "openblas", "version": "0.3.0", "architecture": "Cooperlake"}
    _edit_settings(run_dir, lambda s: s | {"numerics": {"blas": [other]}})
    with caplog.at_level("WARNING"):
        assert main(_bench_argv(run_dir, tiny, trials=3)) == 0
    assert "OPENBLAS_CORETYPE=Cooperlake" in caplog.text
    assert len((run_dir / "trials.jsonl").read_text().splitlines()) == 3
    caplog.clear()
    run_same = _copy(fresh, tmp_path, "same")
    with caplog.at_level("WARNING"):
        assert main(_bench_argv(run_same, tiny, trials=3)) == 0
    assert "other numerics" not in caplog.text


def test_kernels_differ_by_their_set_not_by_a_library_version():
    """A fingerprint written before versions were recorded ("?") on SkylakeX kernels and a
    run on SkylakeX kernels of a known version: the same kernels, nothing to say."""
    from emonav_drake.provenance import kernels_difference

    def blas(version: str, arch: str) -> dict:
        return {"blas": [{"library": "openblas", "version": version, "architecture": arch}]}

    assert kernels_difference(blas("?", "SkylakeX"), blas("0.3.30", "SkylakeX")) is None
    words = kernels_difference(blas("?", "SkylakeX"), blas("0.3.30", "Haswell"))
    assert (
        "SkylakeX there, openblas Haswell here" in words and "OPENBLAS_CORETYPE=SkylakeX" in words
    )
