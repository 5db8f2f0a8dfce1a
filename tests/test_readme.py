"""The README's examples run, and the README names only what exists.

Every ```sh and ```python block of README.md must be preceded by a marker line:

    <!-- example: run -->
    <!-- example: run; small: "512x512" -> "32x32", "512, 512" -> "32, 32" -->
    <!-- example: skip: REASON (where it is run instead, or why it cannot be) -->

'small' lists text substitutions that make a block quick; they are applied before it runs
(each must occur in its block, so they cannot go stale).  Shell blocks run in order in one
scratch directory with ``mprt`` being this interpreter's ``python -m mprt``; Python blocks run
in order in one namespace, in the same directory.  So an example may use what an earlier one
made (a file, a variable), as a reader following the README would.
"""
import os
import re
import subprocess
import sys
import tomllib

import pytest

from mprt import cli

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
README = os.path.join(ROOT, "README.md")
MARKER = re.compile(r"<!-- example: (run|skip: .+?)(?:; small: (.*?))? -->$")
PAIR = re.compile(r'"([^"]*)" -> "([^"]*)"')


def examples(path=README):
    """(line, language, code, marker) of every sh/python block of a README, in order."""
    lines = open(path).read().splitlines()
    out = []
    for i, line in enumerate(lines):
        m = re.fullmatch(r"```(sh|python)", line.strip())
        if not m:
            continue
        end = next(j for j in range(i + 1, len(lines)) if lines[j].strip() == "```")
        out.append((i + 1, m.group(1), "\n".join(lines[i + 1:end]) + "\n", lines[i - 1].strip() if i else ""))
    return out


def prepared(line, code, marker):
    """The block's code with its small substitutions applied, or None to skip it."""
    m = MARKER.fullmatch(marker)
    assert m, f"README.md:{line}: the block needs a marker line before it (see tests/test_readme.py)"
    if m.group(1) != "run":
        assert len(m.group(1)) > len("skip: ") + 10, f"README.md:{line}: say why the block is skipped"
        return None
    for old, new in PAIR.findall(m.group(2) or ""):
        assert old in code, f"README.md:{line}: {old!r} is not in the block"
        code = code.replace(old, new)
    return code


def test_every_example_has_a_marker():
    blocks = examples()
    assert len(blocks) >= 5
    for line, _, code, marker in blocks:
        prepared(line, code, marker)


def run_examples(path, tmp_path) -> int:
    """Run a README's examples not marked skip (small), shell and Python, in its order, in
    ``tmp_path``; returns how many ran."""
    namespace = {"__name__": "__readme__"}
    shell_prelude = f'set -euo pipefail\nmprt() {{ "{sys.executable}" -m mprt "$@"; }}\n'
    name = os.path.relpath(path, ROOT)
    ran = 0
    for line, lang, code, marker in examples(path):
        code = prepared(line, code, marker)
        if code is None:
            continue
        if lang == "sh":
            r = subprocess.run(["bash", "-c", shell_prelude + code], capture_output=True, text=True, cwd=tmp_path)
            assert r.returncode == 0, f"{name}:{line}:\n{code}\n{r.stdout}\n{r.stderr}"
        else:
            exec(compile(code, f"{name}:{line}", "exec"), namespace)
        ran += 1
    return ran


def test_the_examples_run(tmp_path, monkeypatch):
    """Every example not marked skip runs (small), shell and Python, in README order."""
    monkeypatch.chdir(tmp_path)
    assert run_examples(README, tmp_path) >= 4
    assert (tmp_path / "b.png").exists() and (tmp_path / "mount.png").exists() and (tmp_path / "t.npz").exists()


GUIDES = [os.path.join(ROOT, "python", "mprt", "explore", "README.md")]


@pytest.mark.parametrize("guide", GUIDES, ids=lambda p: os.path.relpath(p, ROOT))
def test_the_guides_examples_run(guide, tmp_path, monkeypatch):
    """A package guide's marked examples run too (small), in its order, in a folder of their own."""
    monkeypatch.chdir(tmp_path)
    assert run_examples(guide, tmp_path) >= 1


def test_the_subcommands_the_readme_uses_exist():
    """Every 'mprt WORD' in the README's examples is a subcommand (or option) of mprt."""
    commands = set(cli.build_parser()._subparsers._group_actions[0].choices)
    used = {w for _, lang, code, _ in examples() if lang == "sh" for w in re.findall(r"^mprt (\S+)", code, re.M)}
    assert used and used <= commands | {"--version", "--help"}, used - commands


# Components the README's "what is here now" and the package description may name, and where
# each lives: naming one that does not exist yet fails.
COMPONENTS = {
    "SimPy machine model": "python/mprt/machine",
    "machine model": "python/mprt/machine",
    "design-space explorer": "python/mprt/explore",
    "explorer": "python/mprt/explore",
    "prepass": "python/mprt/explore",
    "cost model": "python/mprt/cost",
    "per-ray stage traces": "python/mprt/trace/tracing.py",
    "per-ray traces": "python/mprt/trace/tracing.py",
}


def _claims(text):
    return [(name, path) for name, path in COMPONENTS.items() if name.lower() in text.lower()]


def test_the_package_description_names_only_what_exists():
    with open(os.path.join(ROOT, "pyproject.toml"), "rb") as f:
        description = tomllib.load(f)["project"]["description"]
    for name, path in _claims(description):
        assert os.path.exists(os.path.join(ROOT, path)), f"pyproject.toml description names {name!r}: no {path}"


def test_what_is_here_now_exists():
    """The README's list of what is here now names only components that exist."""
    text = open(README).read()
    here = text[text.index("What is here now"):text.index("The renderer's main loop")]
    for name, path in _claims(here):
        assert os.path.exists(os.path.join(ROOT, path)), f"README names {name!r} as here now: no {path}"


def test_the_layout_table_lists_files_that_exist():
    """Every file or folder in the README's layout table exists."""
    text = open(README).read()
    table = text[text.index("## Layout"):text.index("## Bad input")]
    package = None
    for row in re.findall(r"^\| (.+?) \|", table, re.M):
        for name in re.findall(r"`([^`]+)`", row):
            if row.startswith("&nbsp;"):
                path = os.path.join("python", "mprt", name)
            else:
                path = name
                package = path
            assert os.path.exists(os.path.join(ROOT, path.rstrip("/"))), f"layout table: {path} does not exist"
    assert package is not None
