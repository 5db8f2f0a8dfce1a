"""Every study (studies/NN_name/) in quick mode reproduces its committed ref/ byte for byte.

Counts are deterministic, so a quick run's tables equal the reference; timings
are kept out of the references.  A study's checks of its own results
(checks.csv) must all be true.
"""
import csv
import importlib.util
import os

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
STUDIES = os.path.join(ROOT, "studies")
NAMES = sorted(d for d in os.listdir(STUDIES) if d[:2].isdigit() and os.path.isdir(os.path.join(STUDIES, d)))


def ref_files(study):
    """The files of a study's ref/ (a subfolder such as ref/full/ holds a full run's results, not compared)."""
    d = os.path.join(STUDIES, study, "ref")
    return sorted(f for f in os.listdir(d) if os.path.isfile(os.path.join(d, f))) if os.path.isdir(d) else []


REF_FILES = [(s, f) for s in NAMES for f in ref_files(s)]


@pytest.fixture(scope="module")
def quick_runs(tmp_path_factory):
    """Run a study's quick mode once into a temporary folder; returns that folder."""
    done = {}

    def run(study):
        if study not in done:
            spec = importlib.util.spec_from_file_location(f"study_{study}", os.path.join(STUDIES, study, "run.py"))
            mod = importlib.util.module_from_spec(spec)
            spec.loader.exec_module(mod)
            out = tmp_path_factory.mktemp(study)
            assert mod.main(["--quick", "--out", str(out), "--threads", "2"]) == 0
            done[study] = out
        return done[study]

    return run


def test_studies_are_numbered_from_01():
    """The studies are numbered folders, at least the three this repository started with."""
    assert {"01_paper_tables", "02_precision", "03_bench"} <= set(NAMES)


@pytest.mark.parametrize("study", NAMES)
def test_study_has_readme_run_and_reference(study):
    """Each study has README.md with Overview, Steps and Observations sections, run.py and a non-empty ref/."""
    d = os.path.join(STUDIES, study)
    with open(os.path.join(d, "README.md")) as f:
        headings = [line.strip() for line in f if line.startswith("## ")]
    assert headings[:3] == ["## Overview", "## Steps", "## Observations"]
    assert os.path.isfile(os.path.join(d, "run.py"))
    assert os.listdir(os.path.join(d, "ref"))


@pytest.mark.parametrize("study, name", REF_FILES, ids=[f"{s}/{f}" for s, f in REF_FILES])
def test_quick_run_reproduces_reference_file(quick_runs, study, name):
    """Each file of ref/ equals the quick run's, byte for byte."""
    with open(os.path.join(STUDIES, study, "ref", name)) as f:
        want = f.read()
    with open(quick_runs(study) / name) as f:
        got = f.read()
    assert got == want, f"{name} differs from studies/{study}/ref/{name}"


@pytest.mark.parametrize("study", NAMES)
def test_quick_run_writes_only_what_ref_holds(quick_runs, study):
    """The quick run writes no file that ref/ lacks (a reference that is not regenerated would hide it)."""
    assert sorted(os.listdir(quick_runs(study))) == ref_files(study)


@pytest.mark.parametrize("study", [s for s in NAMES if os.path.exists(os.path.join(STUDIES, s, "ref", "checks.csv"))])
def test_study_checks_hold(quick_runs, study):
    """Every check the study makes of its own results (checks.csv) is true in the quick run."""
    with open(quick_runs(study) / "checks.csv") as f:
        rows = list(csv.DictReader(f))
    assert rows and all(r["value"] == "true" for r in rows), [r["check"] for r in rows if r["value"] != "true"]
