"""The run spec (`diagrams/run_spec.py`): one record of what decides a result, written by
`sim --json`, `eval --json` and a benchmark's settings, and run again by `--spec` to the
identical record — on the real plants, planners and solvers."""

import json
import shutil

import pytest

from emonav_drake.cli import main
from emonav_drake.diagrams.run_spec import MethodSpec, RunSpec, load_run_spec
from emonav_drake.params import ConfigError
from emonav_drake.typed_yaml import dump_typed_yaml
from tests.cli_errors import assert_user_error, run


def _sim(tmp_path, name: str, *argv: str) -> dict:
    out = tmp_path / f"{name}.json"
    assert main(["sim", *argv, "--json", str(out), "--quiet"]) == 0
    return json.loads(out.read_text())


@pytest.mark.slow
@pytest.mark.parametrize(
    "argv",
    [
        ["--plant", "lip", "--planner", "dwa", "--seed", "3"],
        ["--plant", "lip", "--seed", "5"],  # the default policy, its shipped checkpoint
        ["--plant", "lip", "--planner", "mpc", "--family", "office", "--seed", "2"],
        ["--plant", "lip", "--planner", "dwa", "--scenario", "crossing", "--time-varying"],
        ["--plant", "lip", "--planner", "mpc", "--deployable", "--seed", "7"],
    ],
    ids=["dwa", "policy", "office-route", "scenario-time-varying", "deployable-camera"],
)
def test_a_sim_replayed_from_its_json_gives_the_identical_record(tmp_path, argv):
    a = _sim(tmp_path, "a", *argv)
    b = _sim(tmp_path, "b", "--spec", str(tmp_path / "a.json"))
    assert b == a  # trajectory, outcome and the spec itself
    assert (
        a["spec"]["methods"][0]["name"] == argv[argv.index("--planner") + 1]
        if ("--planner" in argv)
        else a["spec"]["methods"][0]["checkpoint"].endswith(".pt")
    )


@pytest.mark.slow
def test_a_digit_sim_replayed_from_its_json_gives_the_identical_record(tmp_path):
    short = tmp_path / "short.yaml"
    short.write_text("episode: {max_steps: 6}\n")
    a = _sim(
        tmp_path, "a", "--plant", "digit", "--planner", "dwa", "--seed", "1", "--config", str(short)
    )
    assert a["spec"]["plant"] == "digit" and a["spec"]["config"]["episode"]["max_steps"] == 6
    assert _sim(tmp_path, "b", "--spec", str(tmp_path / "a.json")) == a


@pytest.mark.slow
def test_eval_replayed_from_its_json_gives_the_identical_json(tmp_path):
    a, b = tmp_path / "a.json", tmp_path / "b.json"
    argv = ["eval", "--planner", "mpc", "--episodes", "3", "--first-seed", "10", "--quiet"]
    assert main([*argv, "--json", str(a)]) == 0
    assert main(["eval", "--spec", str(a), "--json", str(b), "--quiet"]) == 0
    assert json.loads(b.read_text()) == json.loads(a.read_text())
    assert json.loads(a.read_text())["spec"]["episodes"] == 3


@pytest.mark.slow
def test_a_benchmark_replayed_from_its_settings_runs_the_identical_trials(tmp_path):
    a, b = tmp_path / "a", tmp_path / "b"
    argv = ["--trials", "3", "--first-seed", "5", "--workers", "1", "--quiet"]
    assert (
        main(
            [
                "benchmark",
                "--planners",
                "dwa,policy",
                "--plant",
                "lip",
                *argv[:-1],
                "--out",
                str(a),
                "--quiet",
            ]
        )
        == 0
    )
    assert (
        main(
            [
                "benchmark",
                "--spec",
                str(a / "settings.json"),
                "--workers",
                "1",
                "--out",
                str(b),
                "--quiet",
            ]
        )
        == 0
    )

    def trials(d):
        rows = [json.loads(line) for line in (d / "trials.jsonl").read_text().splitlines()]
        return sorted(
            (t["method"], t["seed"], json.dumps(t["record"], sort_keys=True)) for t in rows
        )

    assert trials(b) == trials(a) and len(trials(a)) == 6
    sa, sb = (json.loads((d / "settings.json").read_text()) for d in (a, b))
    for key in (
        "plant",
        "trials",
        "first_seed",
        "config_sha256",
        "emotion_estimate_sha256",
        "methods",
    ):
        assert sb[key] == sa[key], key


def test_a_spec_written_by_hand_in_yaml_runs_as_the_flags_do(tmp_path):
    spec = RunSpec(plant="lip", methods=[MethodSpec("dwa", "dwa")], first_seed=4)
    spec.config.crowd.family = "blocker"
    f = tmp_path / "spec.yaml"
    f.write_text(dump_typed_yaml(spec))
    by_spec = _sim(tmp_path, "s", "--spec", str(f))
    by_flags = _sim(
        tmp_path, "f", "--planner", "dwa", "--plant", "lip", "--family", "blocker", "--seed", "4"
    )
    by_spec.pop("spec"), by_flags.pop("spec")
    assert by_spec == by_flags


def test_a_flag_that_decides_the_result_is_refused_beside_spec(tmp_path, capsys):
    _sim(tmp_path, "a", "--plant", "lip", "--planner", "dwa", "--seed", "3")
    for flag in (["--planner", "mpc"], ["--seed", "4"], ["--deployable"], ["--no-global-route"]):
        assert_user_error(*run(capsys, "sim", "--spec", tmp_path / "a.json", *flag), flag[0])


def test_a_changed_checkpoint_is_refused_naming_it(tmp_path, capsys):
    from emonav_drake.planners import planner_kind

    ckpt = tmp_path / "mine.pt"
    shutil.copy(planner_kind("policy").default_checkpoint(), ckpt)
    _sim(tmp_path, "a", "--plant", "lip", "--checkpoint", str(ckpt), "--seed", "2")
    ckpt.write_bytes(ckpt.read_bytes() + b"\0")
    assert_user_error(*run(capsys, "sim", "--spec", tmp_path / "a.json"), "has changed since")
    with pytest.raises(ConfigError, match="has changed"):
        load_run_spec(tmp_path / "a.json")


@pytest.mark.slow
def test_a_settings_file_given_to_sim_says_which_command_runs_it(tmp_path, capsys):
    d = tmp_path / "b"
    assert (
        main(
            [
                "benchmark",
                "--planners",
                "dwa",
                "--plant",
                "lip",
                "--trials",
                "1",
                "--workers",
                "1",
                "--out",
                str(d),
                "--quiet",
            ]
        )
        == 0
    )
    assert_user_error(*run(capsys, "sim", "--spec", d / "settings.json"), "benchmark --spec")
