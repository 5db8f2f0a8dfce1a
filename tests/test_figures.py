"""Figures a person reads at a glance (issue 36): the checker (mprt.figures.check) catches tiny
text, overlapping labels and text past the figure's edge; readable() mends a crowded figure; the
simulate and sweep plots, drawn from real small runs, pass it at the page's body size."""
import math
from pathlib import Path

import pytest

from mprt import figures
from mprt.cli import main
from mprt.explore import sweep
from mprt.machine.result import SimResult

HERE = Path(__file__).parent
SPEC = HERE / "data" / "explore" / "sweep.toml"


def kinds(problems):
    return sorted({p.kind for p in problems})


def test_page_scale_and_sizes():
    fig, _ = figures.figure(3, width_px=1600)          # 16 inches at 100 dpi: shrunk to the content
    assert figures.page_scale(fig) == pytest.approx(figures.CONTENT_PX / 1600)
    assert figures.text_px(8, fig) == pytest.approx(8 * 100 / 72 * figures.CONTENT_PX / 1600)
    assert figures.text_px(figures.points_for(14, fig), fig) == pytest.approx(14)
    small, _ = figures.figure(3, width_px=800)          # narrower than the content: shown as it is
    assert figures.page_scale(small) == 1.0 and figures.text_px(9, small) == pytest.approx(12.5)
    assert figures.page_scale(small, dpi=200) == pytest.approx(figures.CONTENT_PX / 1600)


def bad_figure():
    """16 inches at 100 dpi (shown at 0.725), a 6-point legend, 21 crowded tick labels with
    thousands separators, a text run off the right edge."""
    from matplotlib import ticker

    fig, axes = figures.figure(4, width_px=1600)
    ax = axes[0][0]
    ax.plot([0, 1_000_000], [0, 2000], label="a design with a long name")
    ax.set_xticks(range(0, 1_000_001, 50_000))
    ax.xaxis.set_major_formatter(ticker.StrMethodFormatter("{x:,.0f}"))
    ax.legend(fontsize=6)
    ax.set_title("cycles", fontsize=14)
    ax.text(0.97, 0.5, "this note runs off the edge", transform=fig.transFigure, fontsize=14)
    return fig


def test_checker_catches_a_bad_figure():
    problems = figures.check(bad_figure())
    assert kinds(problems) == ["clipped", "overlap", "small"]
    small = {p.text: p.detail for p in problems if p.kind == "small"}
    # 6 pt at 100 dpi shrunk to 1160 of 1600 px: 6 * 100 / 72 * 0.725 = 6.0 px
    assert "6.0 px on a page 1160 px wide (at least 12)" in small["a design with a long name"]
    assert "cycles" not in small                                   # 14 pt * 1.39 * 0.725 = 14.1 px
    overlaps = [p for p in problems if p.kind == "overlap"]
    assert any(p.text == "100,000" and "'150,000'" in p.detail for p in overlaps)
    assert [p.text for p in problems if p.kind == "clipped"] == ["this note runs off the edge"]
    assert "runs past the figure's edge" in str([p for p in problems if p.kind == "clipped"][0])


def test_checker_minimum_and_scale_are_parameters():
    fig = bad_figure()
    # on a page as wide as the figure, the legend is 8.3 px: still under 12, over 8
    assert any(p.text == "a design with a long name" for p in figures.check(fig, page_px=1600) if p.kind == "small")
    assert not any(p.kind == "small" for p in figures.check(fig, page_px=1600, min_px=8))


def test_checker_passes_a_plain_figure_and_skips_invisible_text():
    fig, axes = figures.figure(3)
    ax = axes[0][0]
    ax.plot([1, 2, 3], [3, 1, 2], label="a")
    ax.text(0.5, 0.5, "hidden", transform=ax.transAxes, fontsize=2, visible=False)
    ax.text(0.5, 0.5, "   ", transform=ax.transAxes, fontsize=2)
    figures.legend_outside(ax)
    figures.readable(fig)
    assert figures.check(fig, min_px=figures.BODY_PX) == []


def test_overlapping_titles_and_labels_on_one_axes_are_found():
    fig, axes = figures.figure(3)
    ax = axes[0][0]
    ax.set_title("a title", fontsize=12)
    ax.text(0.5, 1.0, "a note on the title", transform=ax.transAxes, ha="center", va="bottom", fontsize=12)
    found = [p for p in figures.check(fig) if p.kind == "overlap"]
    assert {p.text for p in found} & {"a title", "a note on the title"}


def test_readable_mends_tiny_text_and_crowded_ticks():
    from matplotlib import ticker

    fig, axes = figures.figure(3, 1, 2)
    a, b = axes[0]
    a.plot([0, 3e6], [300, 2000])
    a.xaxis.set_major_locator(ticker.MaxNLocator(nbins=30))
    a.xaxis.set_major_formatter(ticker.StrMethodFormatter("{x:,.0f}"))
    a.set_xlabel("cycles", fontsize=5)
    b.plot([1e3, 1e9], [1, 2])
    b.set_xscale("log")
    figures.cycles_axis(b.xaxis, log=True)                       # 1, 2, 5 a decade over six decades
    assert kinds(figures.check(fig)) == ["overlap", "small"]
    figures.readable(fig)
    assert figures.check(fig, min_px=figures.BODY_PX) == []
    labels = [t.get_text() for t in b.get_xticklabels() if t.get_text()]
    assert "1 M" in labels and "2 M" not in labels                # thinned to one a decade


def test_index_axis_names_categories_and_thins_them():
    fig, axes = figures.figure(3)
    ax = axes[0][0]
    names = [f"{n}x{n}x{n}" for n in range(10, 70)]
    ax.plot(range(len(names)), range(len(names)))
    figures.index_axis(ax.xaxis, names)
    figures.readable(fig)
    assert figures.check(fig, min_px=figures.BODY_PX) == []
    shown = [t.get_text() for t in ax.get_xticklabels() if t.get_text()]
    assert 3 <= len(shown) < len(names) and set(shown) <= set(names)


# -- the simulate and sweep plots, from real runs ---------------------------------------------

@pytest.fixture
def simulate_figures(monkeypatch):
    drawn = []
    plot = SimResult.plot
    monkeypatch.setattr(SimResult, "plot", lambda self, *a, **k: drawn.append(plot(self, *a, **k)))
    return drawn


@pytest.mark.parametrize("extra, panels", [([], 3), (["--engine", "simpy"], 3), (["--level", "0"], 1)])
def test_simulate_plot_reads_at_a_glance(tmp_path, simulate_figures, extra, panels):
    png = tmp_path / "s.png"
    assert main(["simulate", "balls:1", "--res", "32x32", "--plot", str(png)] + extra) == 0
    (fig,) = simulate_figures
    assert len([ax for ax in fig.axes if ax.get_visible() and ax.axison]) == panels
    assert fig.get_figwidth() * fig.dpi == figures.CONTENT_PX          # shown at its natural size
    assert figures.check(fig, min_px=figures.BODY_PX) == []
    import matplotlib.image
    assert matplotlib.image.imread(png).shape[1] == figures.CONTENT_PX
    title = fig.get_suptitle()
    assert title.startswith("balls:1, grid ") and "[" not in title and " cycles" in title


@pytest.fixture
def sweep_figures(monkeypatch):
    drawn = []
    plot = sweep._plot
    monkeypatch.setattr(sweep, "_plot", lambda *a, **k: drawn.append(plot(*a, **k)))
    return drawn


def test_sweep_plot_reads_at_a_glance(tmp_path, sweep_figures):
    assert main(["sweep", str(SPEC), "--out", str(tmp_path / "sw"), "--workers", "0"]) == 0
    (fig,) = sweep_figures
    assert [ax.get_title() for ax in fig.axes] == ["balls:1", "tetra:1"]
    assert figures.check(fig, min_px=figures.BODY_PX) == []
    (legend,) = fig.legends
    assert [t.get_text() for t in legend.get_texts()] == ["paper", "S", "twin_ic"]


def test_sweep_plot_many_designs_scenes_and_deadlocks(tmp_path):
    """Synthetic rows: 3 scenes (one panel left empty), 9 subdivisions, 12 designs (8 named, the
    rest grey), deadlocks (an x on the axis, a legend entry saying so)."""
    scenes = ["balls:3", "tetra:4", "gears:2"]
    designs = {f"design {i:02d}": None for i in range(12)}
    rows = []
    for s, sc in enumerate(scenes):
        for n in range(4, 13):
            for i, d in enumerate(designs):
                dead = (i == 3 and n in (5, 6)) or (i == 11 and s == 2)
                rows.append({"scene": sc, "subdivision": f"{n}x{n}x{n // 2}", "design": d,
                             "cycles": "" if dead else int(1e5 * (1 + i) * (1 + s) * (1 + abs(n - 8) / 4))})
    fig = sweep._plot(rows, {"scenes": scenes, "designs": designs}, tmp_path / "p.png")
    assert figures.check(fig, min_px=figures.BODY_PX) == []
    assert [ax.get_title() for ax in fig.axes if ax.get_visible()] == scenes
    labels = [t.get_text() for t in fig.legends[0].get_texts()]
    assert labels[:8] == [f"design {i:02d}" for i in range(8)]     # the 8 fastest by geometric mean
    assert labels[8:] == ["4 more designs", "deadlocks there\n(no cycles)"]


def test_sweep_answer_ranks_by_geometric_mean():
    from mprt.report import sweep_answer

    rows = [{"scene": sc, "subdivision": sub, "design": d, "cycles": c} for sc, sub, d, c in [
        ("a", "4", "x", 100.0), ("a", "8", "x", 80.0), ("a", "4", "y", 90.0), ("a", "8", "y", ""),
        ("b", "4", "x", 400.0), ("b", "8", "x", 500.0), ("b", "4", "y", 300.0), ("b", "8", "y", 600.0),
        ("a", "4", "z", 10.0), ("b", "4", "z", ""), ("b", "8", "z", "")]]
    a = sweep_answer(rows)
    assert a["best"][("a", "x")][0] == 80.0 and a["best"][("a", "x")][1]["subdivision"] == "8"
    assert a["geomean"]["x"] == pytest.approx(math.sqrt(80 * 400))
    assert a["geomean"]["y"] == pytest.approx(math.sqrt(90 * 300))
    assert a["geomean"]["z"] is None                        # deadlocks at every subdivision of b
    assert a["ranked"] == ["y", "x"]


@pytest.mark.parametrize("deadlock", [False, True])
def test_ladder_figure_reads_at_a_glance_and_its_title_is_true(deadlock):
    from mprt.report import ladder_figure

    ladder = [{"level": 0, "engines": ["analytical"], "seconds_per_design": 1e-4, "error_median": 0.12,
               "error_worst": 0.3},
              {"level": 1, "engines": ["compiled"], "seconds_per_design": 2e-3, "error_median": 0.02,
               "error_worst": math.inf if deadlock else 0.05},
              {"level": 3, "engines": ["simpy"], "seconds_per_design": 0.5, "error_median": 0.0, "error_worst": 0.0}]
    fig = ladder_figure(ladder)
    assert figures.check(fig, min_px=figures.BODY_PX) == []
    title = fig.axes[1].get_title()
    assert ("deadlock" in title) == deadlock
    ms = [t.get_text() for t in fig.axes[0].get_yticklabels() if t.get_text()]
    assert {"0.1", "1", "100"} <= set(ms) and all(x.replace(".", "").replace(",", "").isdigit() for x in ms)
