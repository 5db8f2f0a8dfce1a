"""Study 10 (paper reproduction): its committed full run (ref/full/) holds together, and the parts
of run.py that only the full run reaches (the paper's figures, derived rows, the best subdivision,
figure 6) give what the digest and the tables say.  The quick run itself is reproduced byte for
byte by test_studies.py."""
import csv
import importlib.util
import os

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
STUDY = os.path.join(ROOT, "studies", "10_paper_reproduction")
FULL = os.path.join(STUDY, "ref", "full")
STAGES = ("OS", "IC", "SC")


@pytest.fixture(scope="module")
def run():
    spec = importlib.util.spec_from_file_location("study_10_paper_reproduction", os.path.join(STUDY, "run.py"))
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _num(v):
    if v in ("", "true", "false"):
        return v
    try:
        return int(v)
    except ValueError:
        try:
            return float(v)
        except ValueError:
            return v


def read(name):
    with open(os.path.join(FULL, name)) as f:
        return [{k: _num(v) for k, v in r.items()} for r in csv.DictReader(f)]


def test_full_run_checks_hold():
    """Every check of the committed full run is true, the SimPy sample comparison among them."""
    rows = read("checks.csv")
    assert len(rows) >= 9 and all(r["value"] == "true" for r in rows), [r["check"] for r in rows]
    assert all(r["S_equal"] == "True" and r["M_equal"] == "True" for r in read("fidelity.csv"))


def test_full_table_invariants():
    """In every cell: S runs the same visits on one processor, so S = the stages' processing (the
    same under M) + S's communication; under M each stage's three categories add up to M's time,
    no stage is loaded beyond it, and M is faster than S; all 15 cells are there."""
    rows = read("table2.csv")
    assert sorted((r["scene"], r["subdivision"]) for r in rows) == sorted(
        (s, n) for s in ("balls", "mount", "rings", "tetra", "tree") for n in (20, 50, 100))
    for r in rows:
        assert r["s_cycles"] == sum(r[f"{t}_processing"] for t in STAGES) + r["s_communication"]
        for t in STAGES:
            assert r[f"{t}_processing"] + r[f"{t}_communication"] + r[f"{t}_waiting"] == r["m_cycles"]
        assert r["m_cycles"] <= r["s_cycles"]
        assert abs(r["speedup"] - r["s_cycles"] / r["m_cycles"]) < 1e-4


def test_full_best_subdivision_is_the_fastest():
    """The best subdivision reported per scene is the one with the least M (and S) time in table2."""
    rows = read("table2.csv")
    for b in read("best_subdivision.csv"):
        rs = [r for r in rows if r["scene"] == b["scene"]]
        assert b["best_m"] == min(rs, key=lambda r: r["m_cycles"])["subdivision"]
        assert b["best_s"] == min(rs, key=lambda r: r["s_cycles"])["subdivision"]


def test_paper_figures_as_in_the_digest(run):
    """The digest's balls column at subdivision 50 (section 4) and the figures derived from it by
    hand: speed-up 11,526 / 8,982 = 1.283; S - processing = 11,526 - (1,975 + 8,429 + 180) = 942 M
    cycles over 7,515 + 6,921 + 1,246 = 15,682 K packets = 60.1 cycles per packet; mount's IC at 50
    implied by its per-unit average and count: 46 cycles x 31 M tests = 1,426 M cycles."""
    paper = run.balls_figures(lambda k: run.paper_balls(k, 1))
    assert paper["s_cycles"] == 11526e6 and paper["m_cycles"] == 8982e6
    assert abs(paper["speedup"] - 1.2833) < 1e-4
    assert paper["s_minus_processing"] == 942e6
    assert paper["packets"] == 15682e3
    assert abs(paper["s_minus_processing_per_packet"] - 60.07) < 0.01
    assert run.paper_stage("mount", 1)["IC"] == (1426e6, 31e6)
    assert run.paper_stage("rings", 1) is None


def test_paper_best_subdivision_from_the_digest(run):
    """balls: the paper's times are least at 100; tetra (implied processing, by hand): OS 164 x 3,
    137 x 9, 123 x 20 = 492, 1,233, 2,460 M; IC 51 x 28, 51 x 10, 55 x 6 = 1,428, 510, 330 M: the
    largest stage is least at 50 (1,233), and so is the sum."""
    rows = [{"scene": s, "subdivision": n, "s_cycles": 10 - i, "m_cycles": 10 - i, "speedup": 1.0,
             "m_cycles_open_window": 10 - i} for s in run.SCENES for i, n in enumerate((20, 50, 100))]
    best = {b["scene"]: b for b in run.best_subdivisions(rows, (20, 50, 100))}
    assert best["balls"]["paper_best_m"] == best["balls"]["paper_best_s"] == 100
    assert best["tetra"]["paper_best_m"] == best["tetra"]["paper_best_s"] == 50
    assert best["tree"]["paper_best_m"] == ""
    assert all(b["best_m"] == 100 for b in best.values())        # the synthetic times fall with n


def test_figure6_bars_are_the_stage_totals(run, tmp_path):
    """Each stacked bar of figure 6 (processing + communication + waiting of a stage under M) is as
    long as model M's time, as the categories add up to it."""
    rows = read("table2.csv")
    path = tmp_path / "figure6.png"
    drawn = run.figure6(rows, (20, 50, 100), str(path))
    assert len(drawn) == 5 * 3 * 3
    m = {(r["scene"], r["subdivision"]): r["m_cycles"] for r in rows}
    assert all(v == m[(s, n)] for (s, n, _), v in drawn.items())
    with open(path, "rb") as f:
        assert f.read(8) == b"\x89PNG\r\n\x1a\n"
