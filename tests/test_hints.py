"""Every message suggests only options that exist (issue 36, item 4): each ``--option`` written in
a string of the package's Python sources (messages, help, docstrings) or in a C string literal of
the library is an option of a parser ``mprt.cli.build_parser()`` builds; in the modules of one
subcommand (``mprt simulate``: cli/simulate.py, cli/fidelity.py), an option of that subcommand;
in ``mprt.cost.calibrate`` and its command ``mprt.cli.calibrate`` or a string naming either, an option of
calibrate's own parser."""
import argparse
import ast
import pathlib
import re

import pytest

from mprt import cli

ROOT = pathlib.Path(__file__).resolve().parent.parent
PACKAGE = ROOT / "python" / "mprt"
HINT = re.compile(r"(?<![\w-])--([a-z][a-z0-9]*(?:-[a-z0-9]+)*)")
C_STRING = re.compile(r'"((?:[^"\\\n]|\\.)*)"')
# the modules whose messages are shown by one subcommand only
SUBCOMMAND_OF = {"cli/simulate.py": "simulate", "cli/fidelity.py": "simulate"}


def _parsers(p, name="mprt"):
    yield name, p
    for a in p._actions:
        if isinstance(a, argparse._SubParsersAction):
            for sub, sp in a.choices.items():
                yield from _parsers(sp, sub)


def _options(p) -> set:
    return {o for a in p._actions for o in a.option_strings}


def _calibrate_options(capsys) -> set:
    from mprt.cli import calibrate

    with pytest.raises(SystemExit):
        calibrate.main(["--help"])
    return {"--" + m.group(1) for m in HINT.finditer(capsys.readouterr().out)}


def python_hints():
    """(module path relative to the package, line, option, the string) of every --option in a
    string."""
    for f in sorted(PACKAGE.rglob("*.py")):
        rel = f.relative_to(PACKAGE).as_posix()
        for node in ast.walk(ast.parse(f.read_text(), str(f))):
            if isinstance(node, ast.Constant) and isinstance(node.value, str):
                for m in HINT.finditer(node.value):
                    yield rel, node.lineno, "--" + m.group(1), node.value


def c_hints():
    for f in sorted((ROOT / "c" / "src").glob("*.c")):
        text = f.read_text()
        for s in C_STRING.finditer(text):
            for m in HINT.finditer(s.group(1)):
                yield f"c/src/{f.name}", text.count("\n", 0, s.start()) + 1, "--" + m.group(1), s.group(1)


def test_the_collector_finds_hints_and_options():
    """The collector sees the hints it is meant to check (a message naming --skip-unknown, the
    budget error's --max-depth) and the options of every subcommand (--max-depth among them)."""
    found = {(path, opt) for path, _, opt, _ in python_hints()}
    assert ("cli/options.py", "--skip-unknown") in found and ("grid.py", "--max-depth") in found
    parsers = dict(_parsers(cli.build_parser()))
    assert {"render", "trace", "simulate", "explore", "prepass", "sweep"} <= set(parsers)
    for command in ("render", "trace", "simulate"):
        assert {"--max-rays", "--max-depth"} <= _options(parsers[command]), command


def test_every_hinted_option_exists(capsys):
    parsers = dict(_parsers(cli.build_parser()))
    anywhere = set().union(*(_options(p) for p in parsers.values()))
    calibrate = _calibrate_options(capsys)
    missing = []
    for path, line, opt, text in list(python_hints()) + list(c_hints()):
        if path in ("cost/calibrate.py", "cli/calibrate.py") or "mprt.cost.calibrate" in text \
                or "mprt.cli.calibrate" in text:
            known = calibrate
        elif path in SUBCOMMAND_OF:
            known = _options(parsers[SUBCOMMAND_OF[path]])
        else:
            known = anywhere
        if opt not in known:
            missing.append(f"{path}:{line}: {opt}")
    assert not missing, "messages name options that no parser has:\n" + "\n".join(missing)
