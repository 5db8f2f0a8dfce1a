"""The guides are references: links resolve, and measurements live in the studies.

- Every relative markdown link ``[text](path)`` in every README.md (and CHANGELOG.md) names a
  file or folder that exists.
- A README outside ``studies/`` carries no commit hash and no load average outside its fenced
  code blocks: figures measured at a commit under a load belong to a study
  (``studies/NN_name/``), with the command that regenerates them; the history of changes to
  CHANGELOG.md.
"""
import os
import re
import subprocess

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def _markdown_files():
    """Every tracked README.md, and the CHANGELOG, relative to the root."""
    out = subprocess.run(["git", "ls-files", "README.md", "*/README.md"], cwd=ROOT, capture_output=True,
                         text=True, check=False).stdout.split()
    if not out:                    # not a git checkout (a copied tree): walk it
        out = [os.path.relpath(os.path.join(d, "README.md"), ROOT)
               for d, dirs, files in os.walk(ROOT)
               if "README.md" in files and not any(p.startswith(".") or p in ("build", "node_modules")
                                                   for p in os.path.relpath(d, ROOT).split(os.sep))]
    out = sorted(p for p in out if os.path.isfile(os.path.join(ROOT, p)))
    if os.path.isfile(os.path.join(ROOT, "CHANGELOG.md")):
        out.append("CHANGELOG.md")
    return out


FILES = _markdown_files()
GUIDES = [p for p in FILES if not p.startswith("studies/")]

LINK = re.compile(r"(?<!!)\[[^\]]*\]\(([^)\s]+)(?:\s+\"[^\"]*\")?\)")
# A commit-hash-like word: 7 to 40 lower-case hex digits with at least one letter and one digit,
# standing alone (not inside a path, a file name or a longer word).
COMMIT = re.compile(r"(?<![\w./#-])(?=[0-9a-f]*[a-f])(?=[0-9a-f]*[0-9])[0-9a-f]{7,40}(?![\w/-])")
LOAD = re.compile(r"load averages?|\bat (?:a )?load\b|\bunder (?:a )?load (?:of|about|average)?\s*\d"
                  r"|\bload (?:of |about )?\d+(?:\.\d+)?(?:\s*(?:-|to)\s*\d+(?:\.\d+)?)?(?![\d.-])(?!\s?s\b)", re.I)


def prose(path):
    """(line number, text) of every line outside fenced code blocks."""
    lines, fenced = [], False
    with open(os.path.join(ROOT, path), encoding="utf-8") as f:
        for n, line in enumerate(f, 1):
            if line.lstrip().startswith("```"):
                fenced = not fenced
                continue
            if not fenced:
                lines.append((n, line))
    return lines


def findings(path):
    """'path:line: what' for every commit hash or load phrase in the prose of a guide."""
    out = []
    for n, line in prose(path):
        out += [f"{path}:{n}: commit-hash-like {m.group()!r}" for m in COMMIT.finditer(line)]
        out += [f"{path}:{n}: load phrase {m.group()!r}" for m in LOAD.finditer(line)]
    return out


def test_the_scanners_find_what_they_are_for():
    """The patterns catch hashes and load phrases, and pass ordinary prose and numbers."""
    assert COMMIT.search("measured against 8c21b6a on main")
    assert COMMIT.search("before: 9395dea's package")
    assert not COMMIT.search("2,186,640,539 cycles, 19155564 visits, a decade, mprt_replay_run")
    assert not COMMIT.search("tests/data/golden/balls-g9.npz and ref/full/bench_8c21b6a.csv")
    for phrase in ("load average 5 to 6", "At load about 2, the", "under a load of 7-9", "load 1.7:"):
        assert LOAD.search(phrase), phrase
    for phrase in ("the trace's load phase", "load_trace(path)", "it loads 3 s faster", "load 0.5 s"):
        assert not LOAD.search(phrase), phrase


def test_there_are_guides_to_check():
    assert "README.md" in GUIDES and "python/mprt/machine/README.md" in GUIDES
    assert any(p.startswith("studies/") for p in FILES)


@pytest.mark.parametrize("path", FILES)
def test_relative_links_resolve(path):
    """Every relative link of a README names an existing file or folder (anchors aside)."""
    base = os.path.dirname(os.path.join(ROOT, path))
    broken = []
    for n, line in prose(path):
        for target in LINK.findall(line):
            if re.match(r"[a-z][a-z0-9+.-]*:", target) or target.startswith("#"):
                continue                                  # a URL, a mail address, an anchor
            file = target.split("#", 1)[0]
            if not os.path.exists(os.path.normpath(os.path.join(base, file))):
                broken.append(f"{path}:{n}: {target}")
    assert not broken, "links to nothing:\n" + "\n".join(broken)


@pytest.mark.parametrize("path", GUIDES)
def test_guides_carry_no_commit_hashes_or_load_figures(path):
    """Measurements (at a commit, under a load) go to the studies, history to CHANGELOG.md."""
    found = findings(path)
    assert not found, "move these to a study (studies/NN_name/) or CHANGELOG.md:\n" + "\n".join(found)
