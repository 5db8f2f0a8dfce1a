"""One grammar for every subcommand (issue 20, item 4): this walks every parser of ``mprt`` and
checks the rules, so that a new option cannot break them.

- every subcommand has a description and an exit-status section;
- every argument has a help text, and every option's help gives its default ("(default: ...)",
  or "(required)");
- an option shared by several subcommands has the same syntax (type, metavar, choices, nargs)
  and the same help text's default everywhere (``DEFAULTS_MAY_DIFFER`` lists, with the reason,
  the few whose default belongs to the command);
- the old spellings are kept as aliases of the new names.
"""
import argparse
import json
import re

import pytest

from mprt import cli

# option: why its default differs between subcommands
DEFAULTS_MAY_DIFFER = {
    "--level": "simulate replays at the configuration's own level; explore measures the ladder (auto)",
    "--verify": "explore verifies its 4 best designs; prepass checks none unless asked (each costs a trace)",
    "--fraction": "explore searches at about 64 pixels across; prepass traces at 1/16",
    "--sample": "trace samples the tiles it traces, simulate the runs it replays, explore the tiles of its polish",
    "--tolerance": "explore's level choice (1%) and simulate's, which also pins a baseline (0 there)",
    "--scheduler": "explore runs in this process, sweep on a LocalCluster",
    "--output": "scene writes NFF to stdout, trace needs a file, render writes an image only when asked",
    "--model": "simulate replays model M unless told; prepass chooses the subdivision for the paper's 3MPPE",
    "--grid": "render, trace and simulate take Scene.default_grid; explore and prepass search the subdivision",
    "--workers": "explore evaluates on a process per core; sweep runs a LocalCluster of one worker per core",
}
# option: why its syntax differs between subcommands
SYNTAX_MAY_DIFFER = {
    "--output": "each command writes its own kind of file (OUT.png, OUT.npz, OUT.nff)",
    "--sample": DEFAULTS_MAY_DIFFER["--sample"],
    "--verify": "explore verifies at least one design (K >= 1); prepass may check none (K >= 0)",
    "--tolerance": "explore takes a fraction of the top level's figure in (0, 1), simulate also 0 (a pinned replay)",
}
# the old spellings, kept: (subcommand, old, new)
ALIASES = [("render", "--stats", "--json"), ("prepass", "--check", "--verify")]


def subparsers():
    p = cli.build_parser()
    sub = next(a for a in p._actions if isinstance(a, argparse._SubParsersAction))
    return dict(sub.choices)


SUBS = subparsers()


def options_of(parser):
    return [a for a in parser._actions if not isinstance(a, (argparse._HelpAction, argparse._VersionAction))]


def default_text(help_text: str):
    m = re.search(r"\((default: .*?|required)\)$", help_text.strip(), re.S)
    return m.group(1) if m else None


def test_every_subcommand_is_walked():
    assert set(SUBS) == {"scene", "render", "trace", "stats", "simulate", "explore", "prepass", "sweep"}


@pytest.mark.parametrize("name", sorted(SUBS))
def test_every_subcommand_has_a_description_and_an_exit_status_section(name):
    p = SUBS[name]
    assert p.description and len(p.description) > 20
    assert "exit status: 0 done; 1 an error during the work" in (p.epilog or "")
    assert "2 a bad option" in p.epilog


@pytest.mark.parametrize("name", sorted(SUBS))
def test_every_argument_has_help_and_every_option_its_default(name):
    for a in options_of(SUBS[name]):
        where = f"mprt {name} {'/'.join(a.option_strings) or a.dest}"
        assert a.help and len(a.help) > 10, f"{where}: no help text"
        if a.option_strings:
            assert default_text(a.help), f"{where}: the help does not end with its (default: ...): {a.help!r}"


def shared_options():
    """{option: [(subcommand, action)]} of the options (by their first long name: an old
    spelling kept as an alias is not the option's name) used by more than one subcommand."""
    seen = {}
    for name, p in SUBS.items():
        for a in options_of(p):
            longs = [o for o in a.option_strings if o.startswith("--")]
            if longs:
                seen.setdefault(longs[0], []).append((name, a))
    return {o: v for o, v in seen.items() if len(v) > 1}


@pytest.mark.parametrize("option", sorted(shared_options()))
def test_a_shared_option_has_one_syntax_and_default(option):
    uses = shared_options()[option]

    def syntax(a):
        kind = getattr(a.type, "__qualname__", a.type)
        return (kind, a.metavar, tuple(a.choices) if a.choices else None, type(a).__name__)

    def shown_default(a):
        return default_text(a.help)

    forms = {(name, syntax(a)) for name, a in uses}
    if option not in SYNTAX_MAY_DIFFER:
        assert len({f for _, f in forms}) == 1, f"{option}: {sorted(forms, key=str)}"
    if option not in DEFAULTS_MAY_DIFFER:
        defaults = {(name, shown_default(a)) for name, a in uses}
        assert len({d for _, d in defaults}) == 1, f"{option}: {sorted(defaults)}"


def test_the_common_options_are_where_the_issue_asks():
    """--res and --json in every command that takes a scene and writes figures; --threads wherever
    tracing happens; --rules/--threshold/--grid wherever a scene is traced by the render options."""
    shared = shared_options()
    users = {o: {n for n, _ in v} for o, v in shared.items()}
    assert {"render", "trace", "simulate", "explore", "prepass"} <= users["--res"]
    assert {"render", "stats", "simulate", "explore", "prepass"} <= users["--json"]
    assert {"render", "trace", "simulate", "explore", "prepass"} <= users["--threads"]
    assert {"render", "trace", "simulate", "explore", "prepass"} <= users["--rules"] & users["--threshold"] & \
        users["--grid"]
    assert {"simulate", "explore"} <= users["--level"]


def test_every_sample_has_one_metavar_and_grammar():
    """--sample SPEC everywhere, each in the one grammar; a method a command cannot use is refused
    by name."""
    users = shared_options()["--sample"]
    assert {n for n, _ in users} == {"trace", "simulate"}
    assert {a.metavar for _, a in users} == {"SPEC"}
    for name, a in users:
        for spec in ("random:4:1", "stratified:4:1", "regular:4", "runs:4:1"):
            try:
                a.type(spec)
            except argparse.ArgumentTypeError as e:
                assert spec in str(e) or spec.split(":")[0] in str(e), (name, spec, str(e))


@pytest.mark.parametrize("name, old, new", ALIASES)
def test_old_spellings_are_aliases(name, old, new):
    p = SUBS[name]
    a = next(a for a in options_of(p) if new in a.option_strings)
    assert old in a.option_strings and f"{old}" in a.help


def test_render_json_and_its_old_spelling_write_the_same(tmp_path, capsys):
    for flag in ("--json", "--stats"):
        out = tmp_path / f"{flag[2:]}.json"
        assert cli.main(["render", "tetra:1", "--res", "8x8", flag, str(out)]) == 0
        assert json.loads(out.read_text())["settings"]["resolution"] == [8, 8]


def test_stats_json_takes_a_path_and_alone_prints_as_before(tmp_path, capsys):
    from pathlib import Path
    golden = str(Path(__file__).parent / "data" / "golden" / "tetra-g4.npz")
    out = tmp_path / "s.json"
    assert cli.main(["stats", golden, "--json", str(out)]) == 0
    assert json.loads(out.read_text())["rays"] > 0 and "wrote" in capsys.readouterr().out
    for argv in (["stats", golden, "--json"], ["stats", "--json", golden]):
        assert cli.main(argv) == 0
        assert json.loads(capsys.readouterr().out)["rays"] > 0


@pytest.mark.parametrize("argv, words", [
    (["explore", "balls:1", "--space", "nowhere.toml"], "cannot read the space file"),
    (["sweep", "nowhere.toml", "--out", "x"], "cannot read the sweep spec"),
    (["stats", "nowhere.npz"], "nowhere.npz"),
    (["simulate", "nowhere.npz"], "nowhere.npz"),
    (["simulate", "balls:1", "--config", "nowhere.toml"], "nowhere.toml"),
    (["prepass", "balls:1", "--verify", "-1"], "must be 0 or more"),
])
def test_every_problem_found_before_work_exits_2(argv, words, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    try:
        code = cli.main(argv)
    except SystemExit as e:
        code = e.code
    assert code == 2
    assert words in capsys.readouterr().err


# -- no silent long work (issue 20, item 2, in part) ------------------------------------------------
def test_sweep_progress_shows_done_of_total_and_the_time_left():
    import io
    from mprt.explore.cli import sweep_progress
    now = [0.0]
    out = io.StringIO()
    tick = sweep_progress(out, clock=lambda: now[0])
    tick(0, 4)
    for done in (1, 2, 4):
        now[0] = 10.0 * done
        tick(done, 4)
    tick.end()
    lines = out.getvalue().splitlines()
    assert lines[0].startswith("  0/4 tasks done")
    assert lines[1] == "  1/4 tasks done, 10 s, about 30 s left"
    assert lines[2] == "  2/4 tasks done, 20 s, about 20 s left"
    assert lines[-1] == "  4/4 tasks done, 40 s"
    quiet = io.StringIO()
    tick = sweep_progress(quiet, clock=lambda: 0.0)
    tick(0, 0)
    assert quiet.getvalue() == "  every task is in the cache\n"


def test_simulate_says_what_it_will_do_first(capsys):
    from pathlib import Path
    golden = Path(__file__).parent / "data" / "golden" / "tetra-g4.npz"
    assert cli.main(["simulate", str(golden), "--model", "M", "--level", "1"]) == 0
    first = capsys.readouterr().out.splitlines()[0]
    assert first == f"simulate {golden}: read the trace, then replay it on M at level 1"
