"""A data file never makes us import code (issue 46 item 1).

A planner module of the user's own (a `.py` file or a dotted module name,
`planners/plugins.py`) runs only when it is named on the command line with
`--planner-module`. A file that names one — a benchmark run's `settings.json`, a DAgger or
SARL route's YAML, a training run's saved state, the source run of `digit-rounds` — is
refused with one line naming the file, the field and the flag to add, before any work and
before anything is imported, unless the same modules are given on the command line. The
evidence that nothing was imported is a throw-away module whose import writes a marker
file. A benchmark's settings also record each module's source hash: a run continued with
a changed plug-in file is refused as another setting.
"""

import json
import sys
from pathlib import Path

import pytest

from emonav_drake.cli import build_parser, main
from emonav_drake.planners import is_registered, unregister
from emonav_drake.typed_yaml import ConfigError
from tests.cli_errors import assert_user_error, run

ROOT = Path(__file__).resolve().parent.parent
EXAMPLE = ROOT / "examples" / "cautious_planner.py"
PROBE_PLANNER = "trust_probe"
# a tiny DAgger route whose expert is the probe's planner (sizes of test_planner_plugins)
ROUTE = (
    f"expert: !PlannerSpec {{name: {PROBE_PLANNER}}}\nexpert_episodes: 2\n"
    "episodes_per_round: 1\nrounds: 1\ngrad_steps_first: 4\ngrad_steps_per_round: 2\n"
    "batch_size: 8\neval_episodes: 1\nhidden: 16\n"
)


class Probe:
    """A planner module in a folder of its own whose import writes `marker` (and registers
    the DWA as `trust_probe`)."""

    def __init__(self, folder: Path) -> None:
        folder.mkdir(parents=True, exist_ok=True)
        self.folder = folder
        self.module = folder / "trust_probe.py"
        self.marker = folder / "imported.txt"
        self.module.write_text(
            "from pathlib import Path\n\n"
            f"Path({str(self.marker)!r}).write_text('imported\\n')\n\n"
            "from emonav_drake.planners import PlannerKind, register\n"
            "from emonav_drake.planners.specs import DwaSpec\n\n"
            f"register(PlannerKind({PROBE_PLANNER!r}, DwaSpec()), replace=True)\n"
        )

    def imported(self) -> bool:
        """Whether the module was imported since the last `forget`."""
        loaded = any(n.startswith("emonav_user_planner_trust_probe_") for n in sys.modules)
        return self.marker.exists() or loaded or is_registered(PROBE_PLANNER)

    def forget(self) -> None:
        """As if this process had never imported the module."""
        self.marker.unlink(missing_ok=True)
        for name in [n for n in sys.modules if n.startswith("emonav_user_planner_trust_probe_")]:
            del sys.modules[name]
        if is_registered(PROBE_PLANNER):
            unregister(PROBE_PLANNER)


@pytest.fixture()
def probe(tmp_path):
    p = Probe(tmp_path / "plugin")
    p.forget()  # whichever probe an earlier test imported: forgotten
    yield p
    p.forget()


@pytest.fixture(scope="module")
def dagger_run(tmp_path_factory):
    """A tiny DAgger run started with `--planner-module` (the probe): (its folder, the
    probe). Its saved state records the module."""
    folder = tmp_path_factory.mktemp("dagger")
    p = Probe(folder / "plugin")
    route = folder / "route.yaml"
    route.write_text(ROUTE)
    out = folder / "run"
    argv = ["train", "--algo", "dagger", "--planner-module", p.module, "--config", route]
    assert main([str(a) for a in [*argv, "--out", out, "-q"]]) == 0
    p.forget()
    yield out, p
    p.forget()


@pytest.fixture()
def short(tmp_path):
    path = tmp_path / "short.yaml"
    path.write_text("episode: {max_steps: 6}\n")
    return path


def test_the_guard_compares_paths_resolved_and_names_as_strings(tmp_path, monkeypatch):
    from emonav_drake.planners.plugins import recorded_form, require_named_on_command_line

    monkeypatch.chdir(tmp_path)
    (tmp_path / "mine.py").write_text("")
    assert recorded_form("mine.py") == str(tmp_path / "mine.py")
    assert require_named_on_command_line(["mine.py"], [str(tmp_path / "mine.py")], "f") == [
        str(tmp_path / "mine.py")
    ]
    assert require_named_on_command_line([str(tmp_path / "mine.py")], ["./mine.py"], "f")
    assert require_named_on_command_line(None, [], "f") == []
    assert require_named_on_command_line(["pkg.planners"], ["pkg.planners"], "f")
    with pytest.raises(ConfigError) as e:
        require_named_on_command_line(["pkg.planners", "mine.py"], ["pkg"], "runs/b/x.json")
    assert str(e.value) == (
        "runs/b/x.json: planner_modules names pkg.planners, mine.py; code is imported only "
        "from the command line: add --planner-module pkg.planners --planner-module mine.py"
    )
    with pytest.raises(ConfigError, match="not a list of planner modules"):
        require_named_on_command_line("mine.py", ["mine.py"], "f")


@pytest.mark.slow
def test_diagnose_simulates_a_run_of_ones_own_planners_only_with_their_modules(
    tmp_path, probe, short, capsys, monkeypatch
):
    run_dir = tmp_path / "runs" / "b"
    argv = ["benchmark", "--planner-module", EXAMPLE, "--planner-module", probe.module]
    argv += ["--planners", f"cautious,{PROBE_PLANNER}", "--trials", "1", "--config", short]
    assert main([str(a) for a in [*argv, "--workers", "1", "--out", run_dir, "-q"]]) == 0
    probe.forget()
    out = tmp_path / "diag"
    # an unmodified run someone sent you: its settings name the modules, the command not
    code, err = run(capsys, "diagnose", run_dir, "--out", out, "-q")
    line = assert_user_error(code, err, f"{run_dir}/settings.json", "planner_modules")
    assert line.endswith(
        f"code is imported only from the command line: add --planner-module {EXAMPLE.resolve()} "
        f"--planner-module {probe.module}"
    )
    assert not probe.imported() and not out.exists()
    # one of the two given: the other is named, still nothing imported
    code, err = run(capsys, "diagnose", run_dir, "--out", out, "--planner-module", EXAMPLE)
    line = assert_user_error(code, err, "planner_modules", f"--planner-module {probe.module}")
    assert str(EXAMPLE.resolve()) not in line.split("add ")[1]
    assert not probe.imported() and not out.exists()
    # the same modules on the command line (the probe's path given relatively): simulated
    monkeypatch.chdir(probe.folder)
    argv = ["diagnose", run_dir, "--out", out, "--planner-module", EXAMPLE]
    assert main([str(a) for a in [*argv, "--planner-module", "trust_probe.py", "-q"]]) == 0
    assert probe.marker.exists()
    rows = json.loads((out / "diagnosis.json").read_text())
    assert {r["method"] for r in rows} == {"cautious", PROBE_PLANNER}
    # listing the failures imports nothing, and needs no flag
    probe.forget()
    assert main(["diagnose", str(run_dir), "--failures", "-q"]) == 0
    assert not probe.imported()


@pytest.mark.slow
def test_a_dagger_route_naming_a_module_is_refused_unless_given(
    tmp_path, dagger_run, capsys, monkeypatch
):
    run_dir, probe = dagger_run
    probe.forget()
    monkeypatch.chdir(probe.folder)
    route = tmp_path / "route.yaml"
    route.write_text(ROUTE + "planner_modules: [trust_probe.py]\n")
    out = tmp_path / "student"
    code, err = run(capsys, "train", "--algo", "dagger", "--config", route, "--out", out)
    line = assert_user_error(code, err, str(route), "planner_modules names trust_probe.py")
    assert line.endswith("add --planner-module trust_probe.py")
    assert not probe.imported() and not out.exists()
    # the same module on the command line (as an absolute path): the route is trained, as
    # the run of the fixture was (`emonav train --planner-module … --config route.yaml`)
    from emonav_drake.learning.dagger_state import STATE_FILE, read_dagger_state

    cfg, _, _ = read_dagger_state(run_dir / STATE_FILE)
    assert cfg.planner_modules == [str(probe.module)]
    assert (run_dir / "policy.pt").is_file()
    # and a relative spec in the YAML is recorded once, resolved
    from emonav_drake.cli.train import _training_config

    argv = ["train", "--algo", "dagger", "--config", str(route)]
    args = build_parser().parse_args([*argv, "--planner-module", str(probe.module)])
    assert _training_config(args).planner_modules == [str(probe.module)]
    probe.forget()


def test_a_sarl_route_naming_a_module_is_refused_unless_given(tmp_path, probe, capsys):
    route = tmp_path / "sarl.yaml"
    route.write_text(  # tiny (sizes of test_planner_plugins), were it to run
        f"expert: !PlannerSpec {{name: {PROBE_PLANNER}}}\nplanner_modules: [{probe.module}]\n"
        "il_episodes: 2\nil_epochs: 1\nrl_episodes: 1\ntrain_batches: 1\neval_episodes: 1\n"
        "eval_every: 1\n"
    )
    out = tmp_path / "sarl"
    code, err = run(capsys, "train", "--algo", "sarl", "--config", route, "--out", out)
    assert_user_error(code, err, str(route), "planner_modules", f"--planner-module {probe.module}")
    assert not probe.imported() and not out.exists()


def test_resuming_a_run_started_with_a_module_needs_the_module(dagger_run, capsys):
    run_dir, probe = dagger_run
    probe.forget()
    before = sorted(p.name for p in run_dir.iterdir())
    for route in ([], ["--algo", "dagger"]):
        code, err = run(capsys, "train", *route, "--resume", run_dir)
        line = assert_user_error(code, err, f"{run_dir}/dagger_state.pt", "planner_modules")
        assert line.endswith(f"add --planner-module {probe.module}")
        assert not probe.imported()
    assert sorted(p.name for p in run_dir.iterdir()) == before


def test_resuming_a_sarl_run_whose_state_names_a_module_needs_the_module(tmp_path, probe, capsys):
    """A SARL state (written by the project's writer; the configuration is all the
    check reads) whose configuration names the probe."""
    from emonav_drake.learning.config import SarlConfig
    from emonav_drake.learning.run_state import write_run_state
    from emonav_drake.learning.sarl_run import SARL_STATE_FORMAT, STATE_FILE
    from emonav_drake.planners.specs import PlannerSpec
    from emonav_drake.typed_yaml import to_plain

    cfg = SarlConfig(expert=PlannerSpec(PROBE_PLANNER), planner_modules=[str(probe.module)])
    run_dir = tmp_path / "sarl"
    run_dir.mkdir()
    write_run_state(run_dir / STATE_FILE, SARL_STATE_FORMAT, {"config": to_plain(cfg)}, {})
    before = (run_dir / STATE_FILE).read_bytes()
    code, err = run(capsys, "train", "--resume", run_dir)
    line = assert_user_error(code, err, f"{run_dir}/{STATE_FILE}", "planner_modules")
    assert line.endswith(f"add --planner-module {probe.module}")
    assert not probe.imported()
    assert (run_dir / STATE_FILE).read_bytes() == before


def test_digit_rounds_from_a_run_with_a_module_needs_the_module(tmp_path, dagger_run, capsys):
    run_dir, probe = dagger_run
    probe.forget()
    out = tmp_path / "digit"
    for resume in (["--resume"], []):  # continuing the rounds, or starting them
        argv = ["digit-rounds", "--from", run_dir, "--out", out, "--episodes", 1, *resume]
        code, err = run(capsys, *argv)
        line = assert_user_error(code, err, f"{run_dir}/dagger_state.pt", "planner_modules")
        assert line.endswith(f"add --planner-module {probe.module}")
        assert not probe.imported() and not out.exists()
    # with the module the source is accepted: what stops `--resume` into an empty --out is
    # the next check, the missing state of the rounds
    argv = ["digit-rounds", "--from", run_dir, "--out", out, "--planner-module", probe.module]
    code, err = run(capsys, *argv, "--resume")
    assert_user_error(code, err, "digit_rounds.pt", "nothing to resume")
    assert probe.marker.exists()  # named on the command line: imported
    probe.forget()


@pytest.mark.slow
def test_a_benchmark_continued_with_a_changed_plug_in_file_is_refused(
    tmp_path, probe, short, capsys
):
    out = tmp_path / "bench"
    argv = ["benchmark", "--planner-module", probe.module, "--planners", PROBE_PLANNER]
    argv += ["--trials", "1", "--config", short, "--workers", "1", "--out", out, "-q"]
    assert main([str(a) for a in argv]) == 0
    assert main([str(a) for a in argv]) == 0  # unchanged: continued (nothing to add)
    trials = (out / "trials.jsonl").read_bytes()
    with probe.module.open("a") as f:
        f.write("SLOW_RADIUS = 2.0  # an edit after the run\n")
    code, err = run(capsys, *argv)
    assert_user_error(code, err, str(out), "other settings", "planner_modules", "source")
    assert (out / "trials.jsonl").read_bytes() == trials
    settings = json.loads((out / "settings.json").read_text())
    assert set(settings["planner_modules_sha256"]) == {str(probe.module)}
    # a run directory written before the hashes were recorded opens (not compared)
    del settings["planner_modules_sha256"]
    (out / "settings.json").write_text(json.dumps(settings))
    assert main([str(a) for a in argv]) == 0
