"""What a user reads from the command line: the version, help texts with defaults, quiet
runs, bars only on a terminal, IDT named the same way everywhere, the scene in the output.
"""

import sys

import pytest

from emonav_drake.cli import build_parser, main, package_version
from emonav_drake.navigation.metrics import format_idt


def test_version_is_the_installed_package(capsys):
    with pytest.raises(SystemExit) as e:
        main(["--version"])
    assert e.value.code == 0
    out = capsys.readouterr().out.strip()
    assert out == f"emonav {package_version()}" and package_version()[0].isdigit()


def test_every_subcommand_takes_quiet_and_shows_defaults():
    parser = build_parser()
    sub = next(a for a in parser._actions if a.dest == "command")
    for name, p in sub.choices.items():
        assert "--quiet" in p._option_string_actions, name
        assert "show this help" in p.format_help(), name
    sim_help = " ".join(sub.choices["sim"].format_help().split())
    assert "(default: policy)" in sim_help and "(default: 0)" in sim_help
    assert "emonav planners" in sim_help  # the planner list is one command away, not 28 names
    assert "policy_mpc_shield_digit" not in sim_help
    top = parser.format_help()
    assert "1 kHz" not in top and ".py" not in top  # for users: no module files


@pytest.mark.parametrize("quiet", [[], ["--quiet"], ["-q"]])
def test_eval_writes_bars_only_to_a_terminal(capsys, monkeypatch, tmp_path, quiet):
    """In a pipe or a log (stderr not a terminal) no carriage-return bar; on a terminal the
    bar unless --quiet; the summary on stdout is the same every time."""
    short = tmp_path / "short.yaml"
    short.write_text("episode: {max_steps: 3}\n")
    outs = {}
    for tty in (False, True):
        monkeypatch.setattr(sys.stderr, "isatty", lambda tty=tty: tty)
        argv = ["eval", "--planner", "dwa", "--episodes", "2", "--config", str(short)]
        assert main([*argv, *quiet]) == 0
        captured = capsys.readouterr()
        assert ("\r" in captured.err) == (tty and not quiet), (tty, quiet, captured.err)
        outs[tty] = captured.out
    assert outs[False] == outs[True]
    assert "IDT [static 0; happy " in outs[True] and "(2 episodes)" in outs[True]


def test_idt_is_named_the_same_in_sim_and_eval(capsys, tmp_path):
    assert format_idt([11, 0, 2, 4]) == "IDT [static 11; happy 0, neutral 2, negative 4]"
    short = tmp_path / "short.yaml"
    short.write_text("episode: {max_steps: 3}\n")
    assert main(["sim", "--seed", "5", "--config", str(short), "-q"]) == 0
    sim_out = capsys.readouterr().out
    assert main(["eval", "--episodes", "1", "--first-seed", "5", "--config", str(short)]) == 0
    eval_out = capsys.readouterr().out
    for out in (sim_out, eval_out):
        assert "IDT [static " in out and ", negative " in out, out


def test_sim_names_the_scene_it_ran(capsys, tmp_path):
    short = tmp_path / "short.yaml"
    short.write_text("episode: {max_steps: 2}\n")
    cases = [
        (["--scenario", "crossing"], "scenario crossing (seed 0), policy on LIP: "),
        (["--family", "blocker", "--seed", "3"], "family blocker, seed 3, policy on LIP: "),
        (["--seed", "7", "--planner", "dwa"], "seed 7, dwa on LIP: "),
    ]
    for extra, start in cases:
        assert main(["sim", *extra, "--config", str(short)]) == 0
        assert capsys.readouterr().out.splitlines()[-1].startswith(start), extra


def test_config_list_descriptions_are_whole_sentences(capsys):
    from emonav_drake.cli.config import LIST_WIDTH

    assert main(["config", "--list"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert all(len(line) <= LIST_WIDTH for line in lines)
    # settings and example scenes: each entry (its wrapped lines) ends a sentence
    entries, current = [], None
    for line in lines[
        : lines.index("scenario families (--family NAME; each seed samples one scene):")
    ]:
        if not line.startswith(" "):
            continue
        if not line.startswith("   "):  # a new entry: two spaces, then its name
            current = [line]
            entries.append(current)
        else:
            current.append(line)
    assert len(entries) >= 7
    for entry in entries:
        assert entry[-1].rstrip().endswith((".", ")")), entry


def test_replay_caption_names_the_planner_and_a_file_only_if_chosen(tmp_path):
    import shutil

    from emonav_drake.diagrams.meshcat_viewing import ReplayCaption
    from emonav_drake.params import EmoNavConfig
    from emonav_drake.planners import make_planner, planner_kind
    from emonav_drake.scenarios.scenario import sample_scenario

    cfg = EmoNavConfig()
    scenario = sample_scenario(3, cfg)
    shipped = make_planner("policy", cfg)
    cap = ReplayCaption.for_episode(shipped, "Digit", scenario)
    assert cap.title() == "emonav: policy on Digit, seed 3"
    mine = tmp_path / "my_run.pt"
    shutil.copy(planner_kind("policy").default_checkpoint(), mine)
    cap = ReplayCaption.for_episode(make_planner("policy", cfg, mine), "LIP", scenario)
    assert cap.title() == "emonav: policy (my_run.pt) on LIP, seed 3"
    assert ReplayCaption.for_episode(make_planner("mpc", cfg), "LIP", scenario).planner == "mpc"


def test_a_replay_of_a_scene_file_names_the_scene_not_a_seed(tmp_path):
    out = tmp_path / "r.html"
    argv = ["sim", "--scenario", "crossing", "--planner", "dwa", "--record", str(out)]
    assert main([*argv, "--config", str(_short_config(tmp_path)), "--quiet"]) == 0
    html = out.read_text()
    assert "emonav: dwa on LIP, scenario crossing" in html and "seed 0" not in html


def _short_config(tmp_path):
    short = tmp_path / "short.yaml"
    short.write_text("episode: {max_steps: 2}\n")
    return short
