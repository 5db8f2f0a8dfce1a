"""Self-contained HTML reports of ``explore``, ``simulate`` and ``sweep`` (``--report``).

One page per run: the answer first, then what it is compared with, how it was found
(the fidelity ladder's speed against error, the search's history), the plots, and the
command and settings that reproduce it.  Everything is inside the file: images are PNG
data URIs and the style sheet is inline, so the page opens anywhere with no network.
Each section is a ``<section id=...>`` with an ``<h2>``; tests parse the page and check them.
"""
from __future__ import annotations

import base64
import html
import io
import math
import shlex
import sys
import time

from .atomic import open_replacing

STYLE = """
body { font: 14px/1.45 system-ui, sans-serif; margin: 0 auto; max-width: 1200px; padding: 1em 2em; color: #222; }
h1 { font-size: 1.6em; margin-bottom: .2em; } h2 { border-bottom: 1px solid #ccc; margin-top: 1.6em; }
table { border-collapse: collapse; margin: .5em 0; } td, th { border: 1px solid #ccc; padding: .2em .6em; }
th { background: #f2f2f2; text-align: left; } td.num { text-align: right; font-variant-numeric: tabular-nums; }
img { max-width: 100%; height: auto; display: block; margin: .5em 0; border: 1px solid #eee; }
pre { background: #f6f6f6; padding: .6em; overflow-x: auto; white-space: pre-wrap; word-break: break-all; }
.answer { font-size: 1.15em; background: #eef6ee; padding: .6em 1em; border-left: 4px solid #4a4; }
.warn { background: #fff4e0; border-left-color: #e90; }
"""


# -- building blocks ------------------------------------------------------------------------

def esc(x) -> str:
    return html.escape(str(x), quote=True)


def num(x, digits: int = 0) -> str:
    if isinstance(x, float) and digits:
        return f"{x:,.{digits}f}"
    return f"{x:,.0f}" if isinstance(x, (int, float)) else esc(x)


def table(headers, rows) -> str:
    head = "".join(f"<th>{esc(h)}</th>" for h in headers)
    body = "".join("<tr>" + "".join(f'<td class="num">{esc(c)}</td>' if isinstance(c, (int, float)) or
                                    (isinstance(c, str) and c[:1].isdigit()) else f"<td>{esc(c)}</td>"
                                    for c in r) + "</tr>" for r in rows)
    return f"<table><tr>{head}</tr>{body}</table>"


def png_img(data: bytes, alt: str) -> str:
    """An <img> holding PNG bytes as a data URI."""
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        raise ValueError(f"{alt}: not a PNG image")
    return f'<img alt="{esc(alt)}" src="data:image/png;base64,{base64.b64encode(data).decode()}">'


def figure_png(fig, dpi: int = 100) -> bytes:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi)
    return buf.getvalue()


def file_png(path, alt: str) -> str:
    with open(path, "rb") as f:
        return png_img(f.read(), alt)


def section(ident: str, title: str, body: str) -> str:
    return f'<section id="{esc(ident)}"><h2>{esc(title)}</h2>\n{body}\n</section>\n'


def command_line(argv) -> str:
    return "mprt " + " ".join(shlex.quote(str(a)) for a in argv) if argv is not None else \
        " ".join(shlex.quote(a) for a in sys.argv)


def page(title: str, subtitle: str, sections: list) -> str:
    return ("<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
            f"<title>{esc(title)}</title><style>{STYLE}</style></head><body>\n"
            f"<h1>{esc(title)}</h1><p>{esc(subtitle)}</p>\n" + "".join(sections) + "</body></html>\n")


def write(path, text: str) -> None:
    with open_replacing(path) as f:
        f.write(text)


def _plt():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def reproduce(argv, settings: dict) -> str:
    from ._lowlevel import EXT_VERSION
    rows = [(k, v if isinstance(v, (int, float, str)) else repr(v)) for k, v in (settings or {}).items()]
    return (f"<p>Run again with (mprt {esc(EXT_VERSION)}, {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}):</p>"
            f"<pre>{esc(command_line(argv))}</pre>" + (table(("setting", "value"), rows) if rows else ""))


# -- explore ----------------------------------------------------------------------------------

def _finite(x) -> bool:
    """An error with a value (not None, as a report's JSON has it, nor infinite: a design that
    deadlocked at one level only)."""
    return x is not None and math.isfinite(x)


def _err_pct(x) -> str:
    return f"{100 * x:.2f}" if _finite(x) else "none (a deadlock at one level only)"


def ladder_png(ladder: list) -> bytes:
    """The fidelity ladder: seconds per design against the error of each level, side by side."""
    plt = _plt()
    fig, ax = plt.subplots(1, 2, figsize=(10, 3.4))
    names = [f"level {r['level']}\n({', '.join(r.get('engines', []))})" for r in ladder]
    x = range(len(ladder))
    ax[0].bar(x, [max(r["seconds_per_design"], 1e-9) * 1e3 for r in ladder], color="tab:blue")
    ax[0].set(yscale="log", ylabel="ms per design", title="speed")
    ax[0].set_xticks(list(x), names, fontsize=8)
    w = 0.38
    for dx, key, label, colour in ((-w / 2, "error_median", "median", "tab:green"),
                                   (w / 2, "error_worst", "worst", "tab:red")):
        ax[1].bar([i + dx for i in x], [100 * r[key] if _finite(r[key]) else 0.0 for r in ladder], w, label=label,
                  color=colour)
        for i, r in zip(x, ladder):     # no finite error (a design deadlocked at one level only): no bar
            if not _finite(r[key]):
                ax[1].annotate("deadlock", (i + dx, 0), rotation=90, ha="center", va="bottom", fontsize=7)
    ax[1].set(ylabel="% off the top level", title="error (deadlock: at one level only, no figure)")
    ax[1].set_xticks(list(x), names, fontsize=8)
    ax[1].legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.0, 1.0))
    fig.tight_layout()
    data = figure_png(fig)
    plt.close(fig)
    return data


PAPER = "the paper's 3MPPE"


def _versus(ref: dict, best: dict, title: str) -> str:
    """The best's speed-up over a reference, or that the reference deadlocks (no cycles to compare)."""
    return f"{title} deadlocks" if ref["cycles"] is None else f"{ref['cycles'] / best['cycles']:.2f}x {title}"


def explore_html(rep: dict, argv, plot_path) -> str:
    """The page of an explore report (its JSON) with its plot (a PNG file, as explorer.plot draws it)."""
    b, refs, lv = rep["best"], rep["references"], rep["level"]
    feasible = b.get("feasible", True)
    budget = f" within {rep['budget']:g} kGE" if rep.get("budget") else ""
    answer = (f'<p class="answer{"" if feasible else " warn"}">Best design for {esc(rep["scene"])} at '
              f'{rep["width"]}x{rep["height"]}{esc(budget)}: <b>{esc(b["described"])}</b>, subdivision '
              f'{esc("x".join(map(str, b["subdivision"])))}, {num(b["cycles"])} cycles at level {lv["verify"]}, '
              f'{num(b["cost"])} kGE, {esc(_versus(refs["S"], b, "model S"))}, '
              f'{esc(_versus(refs["3mppe"], b, PAPER))}'
              + ("" if feasible else " (over the budget: no design in the space meets it)") + ".</p>")
    util = ", ".join(f"{k} {v:.0%}" for k, v in b["utilisation"].items())
    answer += f"<p>Bottleneck {esc(b['bottleneck'])}; utilisation {esc(util)}.</p>"
    ref_rows = [("best", num(b["cycles"]), num(b["cost"]), "1.00", util)]
    for name, title in (("3mppe", "paper 3MPPE"), ("M", "model M"), ("S", "model S")):
        r = refs[name]
        dead = r["cycles"] is None
        ref_rows.append((title, "deadlocks" if dead else num(r["cycles"]), num(r["cost"]),
                         "-" if dead else f"{r['cycles'] / b['cycles']:.2f}",
                         ", ".join(f"{k} {v:.0%}" for k, v in r["utilisation"].items())))
    refs_html = table(("machine", "cycles", "cost (kGE)", "x best's time", "utilisation"), ref_rows)
    ladder = lv.get("ladder") or []
    lad_rows = [(r["level"], ", ".join(r.get("engines", [])), f"{1e3 * r['seconds_per_design']:.3g}",
                 _err_pct(r["error_median"]), _err_pct(r["error_worst"])) for r in ladder]
    lad_html = (f"<p>The search ran at level {lv['search']} and the answer was verified at level {lv['verify']}"
                + (f" (the ladder's choice within {100 * rep['tolerance']:g}%)" if lv.get("asked") == "auto" else "")
                + ".</p>" + table(("level", "engines", "ms per design", "median error %", "worst error %"), lad_rows)
                + (png_img(ladder_png(ladder), "fidelity ladder: speed and error") if ladder else ""))
    h = rep.get("history") or []
    phases: dict = {}
    for r in h:
        phases[r["phase"]] = phases.get(r["phase"], 0) + 1
    hist_html = (f"<p>{rep['evaluations']} designs evaluated in {rep['seconds']:.1f} s "
                 f"({', '.join(f'{k}: {v}' for k, v in phases.items())}); algorithm "
                 f"{esc(rep.get('algorithm'))}.</p>")
    plots = file_png(plot_path, "search history, cycles against cost, utilisation")
    front = ""
    if "front" in rep:
        front = table(("cost (kGE)", "cycles", "mapping", "PEs", "subdivision"),
                      [(num(f["cost"]), num(f["cycles"]), f["design"]["mapping"], f["design"]["pes"],
                        "x".join(map(str, f["subdivision"]))) for f in rep["front"]])
    settings = dict(rep.get("settings") or {})
    settings.update({"objective": rep["objective"], "budget": rep.get("budget"), "space": rep["space"]["source"],
                     "search resolution": "x".join(map(str, rep.get("search_resolution") or []))})
    sections = [section("answer", "Answer", answer), section("references", "References", refs_html + front),
                section("ladder", "Fidelity ladder: speed against error", lad_html),
                section("history", "Search history", hist_html), section("plots", "Plots", plots),
                section("reproduce", "Reproduce", reproduce(argv, settings))]
    return page(f"mprt explore {rep['scene']}", f"{rep['width']}x{rep['height']}, objective {rep['objective']}",
                sections)


# -- simulate ---------------------------------------------------------------------------------

def simulate_html(out: dict, argv=None, plot_path=None) -> str:
    st = out["stages"]
    rows = [(s, num(v["processing"]), num(v["communication"]), num(v["waiting"]),
             f"{v.get('utilisation', 0):.0%}" if isinstance(v.get("utilisation"), float) else "")
            for s, v in st.items()]
    ans = (f'<p class="answer">{esc(out.get("model"))}: <b>{num(out["cycles"])} cycles</b> at level '
           f'{esc(out.get("level"))} ({esc(out.get("engine"))} engine), {num(out.get("visits", 0))} visits.</p>')
    sections = [section("answer", "Answer", ans),
                section("stages", "Stages", table(("stage", "processing", "communication", "waiting",
                                                    "utilisation"), rows))]
    if plot_path:
        sections.append(section("plots", "Plots", file_png(plot_path, "stage loads and timelines")))
    sections.append(section("reproduce", "Reproduce", reproduce(argv, out.get("settings"))))
    return page(f"mprt simulate {out.get('settings', {}).get('scene', '')}", f"model {out.get('model')}", sections)


# -- sweep -------------------------------------------------------------------------------------

def sweep_html(r: dict, argv=None) -> str:
    import csv

    with open(r["csv"], newline="") as f:
        rows = list(csv.reader(f))
    head, body = (rows[0], rows[1:]) if rows else ([], [])
    ans = (f'<p class="answer">{r["rows"]} rows from {r["tasks"]} tasks ({r["cached"]} from the cache) in '
           f'{r["seconds"]:.1f} s.</p>')
    sections = [section("answer", "Answer", ans), section("results", "Results", table(head, body[:500])
                                                           + (f"<p>({len(body) - 500} more rows in the CSV)</p>"
                                                              if len(body) > 500 else "")),
                section("plots", "Plots", file_png(r["png"], "sweep")),
                section("reproduce", "Reproduce", reproduce(argv, {"csv": r["csv"]}))]
    return page("mprt sweep", f"{r['rows']} rows", sections)
