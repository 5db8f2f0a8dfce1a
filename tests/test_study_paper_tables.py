"""The paper-tables study in quick mode reproduces its committed reference tables exactly."""
import importlib.util
import os

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
STUDY = os.path.join(ROOT, "studies", "paper_tables")
REF = os.path.join(STUDY, "ref")


def _load_study():
    spec = importlib.util.spec_from_file_location("paper_tables_run", os.path.join(STUDY, "run.py"))
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


@pytest.fixture(scope="module")
def quick_out(tmp_path_factory):
    """Run the study's quick mode into a temporary folder."""
    out = tmp_path_factory.mktemp("paper_tables")
    assert _load_study().main(["--quick", "--out", str(out), "--threads", "2"]) == 0
    return out


def _ref_csvs():
    return sorted(f for f in os.listdir(REF) if f.endswith(".csv"))


def test_reference_tables_are_committed():
    """ref/ holds the quick mode's CSV tables, including the paper-layout rows and the balls comparison."""
    assert {"paper_rows.csv", "balls_vs_paper.csv", "spd_rules.csv"} <= set(_ref_csvs())


@pytest.mark.parametrize("name", _ref_csvs())
def test_quick_run_reproduces_reference_csv(quick_out, name):
    """Each quick-mode CSV equals its committed reference byte for byte (all counts are deterministic)."""
    with open(os.path.join(REF, name)) as f:
        want = f.read()
    with open(quick_out / name) as f:
        got = f.read()
    assert got == want, f"{name} differs from studies/paper_tables/ref/{name}"


def test_quick_run_keeps_counts_grid_independent(quick_out):
    """In the quick run, every count that does not describe the grid is the same at both subdivisions."""
    with open(quick_out / "tables.md") as f:
        assert "identical at every subdivision: yes" in f.read()


def test_numpy_paper_rules_reproduce_the_renderer(quick_out):
    """The NumPy re-implementation of the paper rules, with the renderer's offset, gives the renderer's counts."""
    with open(quick_out / "tables.md") as f:
        assert "with the renderer's offset: yes" in f.read()
