"""Self-contained HTML reports of ``explore``, ``simulate`` and ``sweep`` (``--report``).

One page per run: the answer first, then what it is compared with, how it was found
(the fidelity ladder's speed against error, the search's history), the plots, and the
command and settings that reproduce it.  Everything is inside the file: images are PNG
data URIs and the style sheet is inline, so the page opens anywhere with no network.
Each section is a ``<section id=...>`` with an ``<h2>``; tests parse the page and check them.
The page is laid out for a 1280-px window (content ``figures.CONTENT_PX`` wide, body text
``figures.BODY_PX``); its figures are drawn for that width with ``mprt.figures`` and pass
``figures.check``; numbers are for people (thousands separators, percentages) and settings a table.
"""
from __future__ import annotations

import base64
import html
import io
import math
import shlex
import sys
import time

from ..util import figures
from ..explore.sweep import row_cycles as _cycles, sweep_answer  # noqa: F401 (report.sweep_answer: kept)
from ..util.atomic import open_replacing

# The content is figures.CONTENT_PX wide in a 1280-px window (its figures are drawn for that width
# and checked at it); body text figures.BODY_PX; an image wider than the content is scaled down
# to it, never up; a table never wider than the content: its cells wrap, long words included.
STYLE = """
body { font: %(body)dpx/1.45 system-ui, sans-serif; margin: 0 auto; max-width: %(content)dpx; padding: 1em 20px;
       color: #222; }
h1 { font-size: 1.6em; margin-bottom: .2em; } h2 { border-bottom: 1px solid #ccc; margin-top: 1.6em; }
table { border-collapse: collapse; margin: .5em 0; max-width: 100%%; }
td, th { border: 1px solid #ccc; padding: .2em .6em; overflow-wrap: anywhere; vertical-align: top; }
th { background: #f2f2f2; text-align: left; } td.num { text-align: right; font-variant-numeric: tabular-nums; }
table table { margin: 0; } table table td, table table th { border: none; padding: 0 .6em 0 0; }
img { max-width: 100%%; height: auto; display: block; margin: .5em 0; border: 1px solid #eee; }
pre { background: #f6f6f6; padding: .6em; overflow-x: auto; white-space: pre-wrap; word-break: break-all; }
summary { cursor: pointer; margin: .5em 0; }
.answer { font-size: 1.15em; background: #eef6ee; padding: .6em 1em; border-left: 4px solid #4a4; }
.warn { background: #fff4e0; border-left-color: #e90; }
""" % {"body": figures.BODY_PX, "content": figures.CONTENT_PX}


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


def figure_png(fig, dpi: int = figures.DPI) -> bytes:
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


def value(v) -> str:
    """A setting's value for people: none as "-", numbers with thousands separators (floats to
    four significant figures), a list of numbers joined (a grid as 18 x 18 x 1), other lists by
    commas; a table (dict) is for table_html."""
    if v is None or v == "":
        return "-"
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, int):
        return f"{v:,}"
    if isinstance(v, float):
        return f"{v:,.0f}" if v.is_integer() and abs(v) >= 1 else f"{v:,.4g}"
    if isinstance(v, (list, tuple)):
        if v and all(isinstance(x, int) and not isinstance(x, bool) for x in v):
            return " x ".join(map(str, v))
        return ", ".join(value(x) for x in v)
    return str(v)


def settings_table(settings: dict) -> str:
    """(setting, value) rows, a value that is itself a table (dict) as a table inside its cell;
    plain text for people, never a Python repr."""
    def cell(v):
        if isinstance(v, dict):
            return "<table>" + "".join(f"<tr><th>{esc(k)}</th><td>{cell(x)}</td></tr>" for k, x in v.items()) \
                + "</table>" if v else "-"
        return esc(value(v))
    rows = "".join(f"<tr><th>{esc(str(k).replace('_', ' '))}</th><td>{cell(v)}</td></tr>"
                   for k, v in (settings or {}).items())
    return f"<table><tr><th>setting</th><th>value</th></tr>{rows}</table>" if rows else ""


def reproduce(argv, settings: dict) -> str:
    from .._lowlevel import EXT_VERSION
    return (f"<p>Run again with (mprt {esc(EXT_VERSION)}, {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}):</p>"
            f"<pre>{esc(command_line(argv))}</pre>" + settings_table(settings))


# -- explore ----------------------------------------------------------------------------------

def _finite(x) -> bool:
    """An error with a value (not None, as a report's JSON has it, nor infinite: a design that
    deadlocked at one level only)."""
    return x is not None and math.isfinite(x)


def _err_pct(x) -> str:
    return f"{100 * x:.2f}" if _finite(x) else "none (a deadlock at one level only)"


def ladder_png(ladder: list) -> bytes:
    """ladder_figure as PNG bytes."""
    fig = ladder_figure(ladder)
    return figure_png(fig, fig.dpi)


def ladder_figure(ladder: list):
    """The fidelity ladder: milliseconds per design against the error of each level, side by side,
    drawn to be read at a glance on the page (mprt.figures); a level with no finite error (a design
    that deadlocked at one level only) has no bar and says so."""
    from matplotlib import ticker

    fig, (ax,) = figures.figure(3.6, 1, 2)
    names = [f"level {r['level']}\n({', '.join(r.get('engines', []))})" for r in ladder]
    x = list(range(len(ladder)))
    ax[0].bar(x, [max(r["seconds_per_design"], 1e-9) * 1e3 for r in ladder], color="tab:blue")
    ax[0].set(yscale="log", ylabel="ms per design", title="time per design")
    figures.cycles_axis(ax[0].yaxis, log=True)                     # 1, 2, 5 a decade, then plain numbers
    ax[0].yaxis.set_major_formatter(ticker.FuncFormatter(lambda v, _pos: f"{v:,g}"))
    ax[0].set_xticks(x, names)
    w = 0.38
    dead = False
    for dx, key, label, colour in ((-w / 2, "error_median", "median", "tab:green"),
                                   (w / 2, "error_worst", "worst", "tab:red")):
        ax[1].bar([i + dx for i in x], [100 * r[key] if _finite(r[key]) else 0.0 for r in ladder], w, label=label,
                  color=colour)
        for i, r in zip(x, ladder):     # no finite error (a design deadlocked at one level only): no bar
            if not _finite(r[key]):
                dead = True
                ax[1].annotate("deadlock", (i + dx, 0), rotation=90, ha="center", va="bottom")
    ax[1].set(ylabel="% off the top level", title="error against the top level"
              + (" (deadlock: at one level only, no figure)" if dead else ""))
    ax[1].set_xticks(x, names)
    figures.legend_outside(ax[1])
    return figures.readable(fig)


PAPER = "the paper's 3MPPE"


def _versus(ref: dict, best: dict, title: str) -> str:
    """The best's speed-up over a reference, or that the reference deadlocks (no cycles to compare)."""
    return f"{title} deadlocks" if ref["cycles"] is None else f"{ref['cycles'] / best['cycles']:.2f}x {title}"


def explore_html(rep: dict, argv, plot_path) -> str:
    """The page of an explore report (its JSON) with its plot (a PNG file, as explore.plots.plot draws it)."""
    b, refs, lv = rep["best"], rep["references"], rep["level"]
    rows = rep["per_scene"]
    names = ", ".join(r["scene"] for r in rows)
    budget = f" within {rep['budget']:g} kGE" if rep.get("budget") else ""
    geo = b.get("speedup_geomean")
    what = (f"The front of {len(rep['front'])} machines for {esc(names)} (the table below); its knee"
            if rep.get("front") else f"One machine for {esc(names)}{esc(budget)}")
    answer = (f'<p class="answer{"" if b["feasible"] else " warn"}">{what}: '
              f'<b>{esc(b["described"])}</b>, {num(b["cost"])} kGE; '
              + (f"{geo:.2f}x the paper's 3MPPE (weighted geometric mean)" if geo else "no speed-up figure")
              + f", at level {lv['search']}"
              + ("" if b["feasible"] else " (over the budget: no design in the space meets it)") + ".</p>")
    pes = b["machine"]["pes"]
    proc = table(("stage", "per PE", "PEs", "processors", "units", "FIFOs (packets)", "memories"),
                 [(r["stage"], r["copies_per_pe"], pes, r["processors"],
                   " + ".join(f"{n} {k}" for k, n in r["units"].items()),
                   "-" if r["send_fifo"] is None else f"{r['send_fifo']} / {r['receive_fifo']}", r["memories"] or "-")
                  for r in b["processors"]])
    costs = table(("part", "kGE"), [(k, num(v)) for k, v in b["cost_breakdown"].items()] + [("total", num(b["cost"]))])
    scenes = table(("scene", "weight", "resolution", "subdivision", "cycles", "x 3MPPE", "sharing", "bottleneck"),
                   [(r["scene"], f"{r['weight']:g}", "x".join(map(str, r["resolution"])),
                     "x".join(map(str, r["subdivision"])), num(r["cycles"]),
                     "-" if r["speedup"] is None else f"{r['speedup']:.2f}", f"{r['sharing']:.3f}", r["bottleneck"])
                    for r in rows])
    ref_rows = []
    for name, title in (("3mppe", "paper 3MPPE"), ("M", "model M"), ("S", "model S")):
        r = refs[name]
        ref_rows.append((title, num(r["cost"]), "; ".join(
            f"{p['scene']}: " + ("deadlocks" if p["cycles"] is None else num(p["cycles"])) for p in r["per_scene"])))
    refs_html = table(("machine", "cost (kGE)", "cycles per scene (its own best subdivision)"), ref_rows)
    ladder = lv.get("ladder") or []
    lad_rows = [(r["level"], ", ".join(r.get("engines", [])), f"{1e3 * r['seconds_per_design']:.3g}",
                 _err_pct(r["error_median"]), _err_pct(r["error_worst"])) for r in ladder]
    lad_html = (f"<p>Everything ran at level {lv['search']}"
                + (f" (the ladder's choice within {100 * rep['tolerance']:g}%)" if lv.get("asked") == "auto" else "")
                + ".</p>" + (table(("level", "engines", "ms per design", "median error %", "worst error %"), lad_rows)
                             + png_img(ladder_png(ladder), "fidelity ladder: speed and error") if ladder else ""))
    ev = rep["evaluations"]
    phases: dict = {}
    for r in rep.get("history") or []:
        phases[r["phase"]] = phases.get(r["phase"], 0) + 1
    hist_html = table(("what", "count"), [("machines searched", num(ev["machines"])),
                                          ("scene replays", num(ev["replayed"])),
                                          ("from the cache", num(ev["reused_from_cache"]))]
                      + [(f"history rows: {k}", num(v)) for k, v in phases.items()]
                      + [("seconds", f"{rep['seconds']:.1f}")])
    plots = file_png(plot_path, "search history, cost against the objective, per-scene speed-ups")
    front = ""
    if rep.get("front"):
        keys = list(rep["front"][0]["differs"])
        front = ("<h3>Pareto front</h3><p>Cheapest first; the answer is the front, its knee (where the figure stops falling fast for the cost added) marked"
                 + (", and the best within the budget is marked" if rep.get("budget") else "")
                 + "; the columns are what differs between the machines.</p>"
                 + table(("cost (kGE)", "geometric mean of cycles", *keys, ""),
                         [(num(f["cost"]), num(f["objective"]), *(str(f["differs"][k]) for k in keys),
                           " ".join(w for w, on in (("knee: the answer", f["knee"]),
                                                    ("best within the budget", f["budget_best"])) if on))
                          for f in rep["front"]]))
    st = rep.get("settings") or {}
    settings = {"objective": rep["objective"], "budget": rep.get("budget"), "space": rep["space"]["source"],
                "grid": st.get("grid"), "mprt_version": st.get("mprt_version")}
    for e in st.get("scenes") or []:
        settings[f"scene {e['name']}"] = ", ".join(f"{k} {v}" for k, v in e.items() if k != "name" and v is not None)
    sections = [section("answer", "Answer", answer + proc + costs),
                section("scenes", "Per scene", scenes + front),
                section("references", "References", refs_html),
                section("ladder", "Fidelity ladder: speed against error", lad_html),
                section("history", "Search", hist_html), section("plots", "Plots", plots),
                section("reproduce", "Reproduce", reproduce(argv, settings))]
    return page(f"mprt explore {names}", f"objective {rep['objective']}{budget}", sections)


# -- simulate ---------------------------------------------------------------------------------

def _pct(x) -> str:
    return f"{100 * x:.0f}%" if isinstance(x, (int, float)) else "-"


def _share(part, whole) -> str:
    """A count with its share of the whole: 2,244,773 (72%)."""
    return f"{part:,} ({100 * part / whole:.0f}%)" if whole else f"{part:,}"


def simulate_html(out: dict, argv=None, plot_path=None) -> str:
    """The page of a simulate run (its JSON, as --json writes it) with its plot (a PNG file, as
    SimResult.plot draws it)."""
    st, settings = out["stages"], dict(out.get("settings") or {})
    scene = settings.get("scene", "")
    res, grid = settings.get("resolution"), settings.get("grid")
    where = ", ".join(x for x in (value(res) if res else "", f"grid {value(grid)}" if grid else "") if x)
    util = {k: v.get("utilisation") for k, v in st.items() if isinstance(v.get("utilisation"), (int, float))}
    bottleneck = max(util, key=util.get) if util else None
    lo, hi = (out.get("cycles_interval") or [None, None])[:2]
    sampled = out.get("sampled", 1.0)
    estimate = (f" (estimated from {100 * sampled:.0f}% of the rays: {num(lo)} to {num(hi)})"
                if isinstance(sampled, float) and sampled < 1 and lo is not None else "")
    rays = out.get("rays") or {}
    ans = (f'<p class="answer">Model {esc(out.get("model"))} renders {esc(scene)}'
           + (f" ({esc(where)})" if where else "")
           + f' in <b>{num(out["cycles"])} cycles</b>{esc(estimate)} at level {esc(out.get("level"))} '
           f'({esc(out.get("engine"))} engine).</p>'
           + (f"<p>The busiest stage is <b>{esc(bottleneck)}</b>, busy {_pct(util[bottleneck])} of the time; "
              + ", ".join(f"{esc(k)} {_pct(v)}" for k, v in util.items() if k != bottleneck)
              + f". {num(out.get('visits', 0))} stage visits by {num(sum(rays.values()))} rays ("
              + ", ".join(f"{num(v)} {esc(k)}" for k, v in rays.items()) + ").</p>" if bottleneck else ""))
    rows = []
    for s, v in st.items():
        whole = sum(v.get(c, 0) for c in ("processing", "communication", "waiting"))
        rows.append((s, num(v.get("rays_in", 0)), _share(v["processing"], whole),
                     _share(v["communication"], whole), _share(v["waiting"], whole), _pct(v.get("utilisation"))))
    stages = ("<p>Cycles summed over the PEs, with each category's share of the stage's time.</p>"
              + table(("stage", "rays in", "processing", "communication", "waiting", "utilisation"), rows))
    fifos = [(name, num(f["packets"]), f"{f['mean']:,.1f}", num(f["max"]), value(f.get("capacity")))
             for name, f in (out.get("fifos") or {}).items() if f.get("packets")]
    if fifos:
        stages += "<h3>FIFOs</h3>" + table(("FIFO", "packets", "mean occupancy", "most", "capacity"), fifos)
    sections = [section("answer", "Answer", ans), section("stages", "Stages", stages)]
    if plot_path:
        sections.append(section("plots", "Plots", file_png(plot_path, "stage loads and timelines")))
    settings["replay_seconds"] = out.get("replay_seconds")
    sections.append(section("reproduce", "Reproduce", reproduce(argv, settings)))
    return page(f"mprt simulate {scene}", f"model {out.get('model')}", sections)


# -- sweep -------------------------------------------------------------------------------------

def _times(a, b) -> str:
    """How much faster a is than b (cycles): 1.23x, or 'as fast as'."""
    return "as fast as" if a == b else f"{b / a:.2f}x as fast as"


def _utilisation(row) -> str:
    return ", ".join(f"{k[5:]} {100 * float(v):.0f}%" for k, v in row.items() if k.startswith("util_") and v != "")


def sweep_html(r: dict, argv=None, spec=None) -> str:
    """The page of a sweep (run_sweep's result: its CSV and PNG), spec (load_spec's) adding its
    settings where given: the best design per scene and over all scenes first, then every row."""
    import csv

    with open(r["csv"], newline="") as f:
        rows = list(csv.DictReader(f))
    a = sweep_answer(rows)
    ranked, geo, best = a["ranked"], a["geomean"], a["best"]
    n_sc = len(a["scenes"])
    if ranked:
        top = ranked[0]
        ans = (f'<p class="answer">Over {"the scene" if n_sc == 1 else f"all {n_sc} scenes"}, the best design is '
               f'<b>{esc(top)}</b>: {num(geo[top])} cycles'
               + (" (geometric mean over the scenes of each design's cycles at its best subdivision)" if n_sc > 1
                  else " at its best subdivision")
               + (f", {_times(geo[top], geo[ranked[1]])} {esc(ranked[1])}, the next best" if len(ranked) > 1 else "")
               + (f", {_times(geo[top], geo[ranked[-1]])} {esc(ranked[-1])}, the slowest" if len(ranked) > 2 else "")
               + ".</p>")
    else:
        ans = '<p class="answer warn">Every design deadlocks at every subdivision of some scene: no best design.</p>'
    dead = [d for d in a["designs"] if geo[d] is None]
    if dead and ranked:
        ans += f"<p>Not ranked (they deadlock at every subdivision of a scene): {esc(', '.join(dead))}.</p>"
    per_scene = []
    for sc in a["scenes"]:
        mine = sorted((best[(sc, d)][0], a["designs"].index(d), d) for d in a["designs"] if (sc, d) in best)
        if not mine:
            per_scene.append((sc, "every design deadlocks", "-", "-", "-", "-"))
            continue
        c, _, d = mine[0]
        row = best[(sc, d)][1]
        per_scene.append((sc, d, row["subdivision"], num(c),
                          f"{mine[1][0] / c:.2f}x ({mine[1][2]})" if len(mine) > 1 else "-", row["bottleneck"]))
    ans += ("<h3>Best per scene</h3>" + table(("scene", "best design", "subdivision", "cycles",
                                                "the next design's time", "bottleneck"), per_scene))
    kge = lambda x: "-" if _cycles(x["cost"]) is None else num(_cycles(x["cost"]), 1)   # noqa: E731
    cost = {}                      # per design: its cost, or the range of its costs over the rows
    for d in a["designs"]:
        cs = [c for c in (_cycles(x["cost"]) for x in rows if x["design"] == d) if c is not None]
        cost[d] = "-" if not cs else num(min(cs), 1) if min(cs) == max(cs) else \
            f"{num(min(cs), 1)} to {num(max(cs), 1)}"
    rank_rows = [(i + 1, d, num(geo[d]), f"{geo[d] / geo[ranked[0]]:.2f}", cost[d],
                  "; ".join(f"{s}: {best[(s, d)][1]['subdivision']}" for s in a["scenes"]))
                 for i, d in enumerate(ranked)]
    rank_rows += [("-", d, "deadlocks", "-", cost[d], "-") for d in dead]
    ranking = ("<h3>Designs ranked</h3>" + table(
        ("rank", "design", "cycles (geometric mean)" if n_sc > 1 else "cycles", "x the best's time", "cost (kGE)",
         "best subdivision"), rank_rows))
    results = [(x["scene"], x["subdivision"], x["design"],
                "deadlock" if _cycles(x["cycles"]) is None else num(_cycles(x["cycles"])),
                kge(x), x["bottleneck"], _utilisation(x)) for x in rows]
    shown = results[:500]
    detail = (f"<details{' open' if len(rows) <= 40 else ''}><summary>All {num(len(rows))} rows "
              f"(scene x subdivision x design)</summary>"
              + table(("scene", "subdivision", "design", "cycles", "cost (kGE)", "bottleneck", "utilisation"), shown)
              + (f"<p>({num(len(rows) - 500)} more rows in the CSV)</p>" if len(rows) > 500 else "") + "</details>")
    grids = {sc: ", ".join(dict.fromkeys(x["subdivision"] for x in rows if x["scene"] == sc)) for sc in a["scenes"]}
    settings = {"spec": argv[1] if argv and len(argv) > 1 and argv[0] == "sweep" else None,
                "scenes": ", ".join(a["scenes"]), "subdivisions": grids, "designs": ", ".join(a["designs"])}
    if spec:
        settings.update({"resolution": f"{spec['width']} x {spec['height']}", "shape": spec["shape"],
                         "level": spec["level"], "rules": spec["rules"], "batch": spec["batch"]})
    else:
        settings["level"] = ", ".join(dict.fromkeys(x["level"] for x in rows))
    settings.update({"cost model": ", ".join(dict.fromkeys(x.get("costs", "") for x in rows)), "csv": r["csv"],
                     "run": f"{num(r['rows'])} rows from {num(r['tasks'])} tasks ({num(r['cached'])} from the "
                            f"cache) in {r['seconds']:.1f} s"})
    sections = [section("answer", "Answer", ans + ranking), section("results", "Results", detail),
                section("plots", "Plots", file_png(r["png"], "cycles against subdivision per scene and design")),
                section("reproduce", "Reproduce", reproduce(argv, settings))]
    n_sub = max((len(g.split(", ")) for g in grids.values()), default=0)
    return page("mprt sweep", f"{n_sc} scene(s) x {n_sub} subdivision(s) x {len(a['designs'])} design(s): "
                f"{num(r['rows'])} rows", sections)
