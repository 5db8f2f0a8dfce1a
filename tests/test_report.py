"""--report: one self-contained HTML page per explore, simulate and sweep (issue 20).

The page is parsed: every section the report promises is there with content, every image
is an embedded PNG that decodes, and nothing refers outside the file.  Where Debian's
headless Chromium is installed, the page is also opened in it: every image is drawn and
nothing is wider than the window, and the simulate and sweep pages show their figures at their
natural size (so mprt.figures.check's sizes are the page's).  Issue 36: the answers name what
they found (the sweep's best design per scene and over all scenes, by how much), numbers are
for people (thousands separators, integer cycles, percentages) and settings are a table."""
import base64
import os
import re
import shutil
import subprocess
from html.parser import HTMLParser
from pathlib import Path

import pytest

from mprt.cli import main

HERE = Path(__file__).parent
TRACE = HERE / "data" / "golden" / "tetra-g4.npz"
SPEC = HERE / "data" / "explore" / "sweep.toml"
SMALL_SPACE = HERE / "data" / "explore" / "small_space.toml"


class Page(HTMLParser):
    def __init__(self):
        super().__init__()
        self.sections, self.images, self.links, self.text = {}, [], [], []
        self._section = None

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if tag == "section":
            self._section = a["id"]
            self.sections[self._section] = []
        elif tag == "img":
            self.images.append((self._section, a.get("src", ""), a.get("alt", "")))
        for k in ("src", "href"):
            if k in a and a[k] and not a[k].startswith("data:"):
                self.links.append(a[k])

    def handle_endtag(self, tag):
        if tag == "section":
            self._section = None

    def handle_data(self, data):
        if self._section and data.strip():
            self.sections[self._section].append(data.strip())


def parse(path) -> Page:
    p = Page()
    p.feed(Path(path).read_text())
    return p


def check_images(page: Page):
    assert page.images
    for section, src, alt in page.images:
        assert src.startswith("data:image/png;base64,"), (section, src[:40])
        data = base64.b64decode(src.split(",", 1)[1], validate=True)
        assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 2000, (section, alt)
    assert page.links == []          # nothing outside the file: no network, no side files


def open_in_browser(path, tmp_path):
    """(images drawn, images, page width, window width, the smallest image's shown width over its
    natural width in thousandths) from headless Chromium, or skip."""
    exe = shutil.which("chromium") or shutil.which("chromium-browser")
    if exe is None:
        pytest.skip("headless Chromium is not installed (apt-get install chromium)")
    probe = tmp_path / "probe.html"
    probe.write_text(Path(path).read_text().replace(
        "</body>", "<script>window.addEventListener('load', () => { const im = [...document.images]; "
                   "document.title = 'PROBE ' + im.filter(i => i.complete && i.naturalWidth > 0).length + ' ' + "
                   "im.length + ' ' + document.documentElement.scrollWidth + ' ' + window.innerWidth + ' ' + "
                   "Math.min(1000, ...im.map(i => Math.round(1000 * i.clientWidth / i.naturalWidth))); });"
                   "</script></body>"))
    out = subprocess.run([exe, "--headless", "--no-sandbox", "--disable-gpu", "--window-size=1280,900",
                          "--virtual-time-budget=5000", "--dump-dom", probe.as_uri()],
                         capture_output=True, text=True, timeout=120)
    title = out.stdout.split("<title>", 1)[1].split("</title>", 1)[0]
    assert title.startswith("PROBE "), out.stderr[-2000:]
    return tuple(int(x) for x in title.split()[1:])


def test_explore_report(tmp_path, capsys):
    out = tmp_path / "r.html"
    assert main(["explore", "tetra:1", "--res", "16x16", "--space", str(SMALL_SPACE), "--budget", "2000",
                 "--report", str(out)]) == 0
    assert f"wrote   {out}" in capsys.readouterr().out
    page = parse(out)
    assert list(page.sections) == ["answer", "scenes", "references", "ladder", "history", "plots", "reproduce"]
    for name, body in page.sections.items():
        assert body, name
    text = " ".join(page.sections["answer"])
    assert "One machine for tetra:1" in text and "kGE" in text
    assert "processors" in page.sections["answer"] and "total" in page.sections["answer"]   # the machine and its costs
    assert "tetra:1" in page.sections["scenes"]
    assert "paper 3MPPE" in page.sections["references"] and "model S" in page.sections["references"]
    assert any("mprt explore tetra:1 --res 16x16" in t for t in page.sections["reproduce"])
    sections_with_images = {s for s, _, _ in page.images}
    assert {"ladder", "plots"} <= sections_with_images
    check_images(page)
    drawn, n, width, window, _ = open_in_browser(out, tmp_path)
    assert drawn == n == len(page.images) and width <= window


def settings_rows(path) -> dict:
    """The Reproduce section's (setting, value) rows whose value is text."""
    html = Path(path).read_text().split('<section id="reproduce">', 1)[1]
    return dict(re.findall(r"<tr><th>([^<]*)</th><td>([^<]*)</td></tr>", html))


def test_simulate_report(tmp_path):
    out = tmp_path / "s.html"
    assert main(["simulate", str(TRACE), "--model", "3mppe", "--report", str(out)]) == 0
    page = parse(out)
    assert list(page.sections) == ["answer", "stages", "plots", "reproduce"]
    answer = " ".join(page.sections["answer"])
    assert re.search(r"renders .* in \d{1,3}(,\d{3})* cycles at level", answer)
    assert re.search(r"The busiest stage is (OS|IC|SC) , busy \d+% of the time", answer)
    stages = page.sections["stages"]
    assert {"OS", "IC", "SC"} <= set(stages)
    assert all(re.fullmatch(r"\d{1,3}(,\d{3})* \(\d+%\)", c) for c in stages[stages.index("OS") + 2:][:3])
    settings = settings_rows(out)
    assert re.fullmatch(r"\d+ x \d+ x \d+", settings["grid"]) and settings["model"] == "3mppe"
    assert not any(ch in v for v in settings.values() for ch in "[{")      # no Python repr
    check_images(page)
    drawn, n, width, window, shown = open_in_browser(out, tmp_path)
    assert drawn == n == 1 and width <= window and shown == 1000     # the figure at its natural size


def test_sweep_report(tmp_path):
    import csv

    from mprt.report import sweep_answer

    out = tmp_path / "w.html"
    assert main(["sweep", str(SPEC), "--out", str(tmp_path / "sw"), "--workers", "0", "--report", str(out)]) == 0
    page = parse(out)
    assert list(page.sections) == ["answer", "results", "plots", "reproduce"]
    with open(tmp_path / "sw" / "sweep.csv", newline="") as f:
        found = sweep_answer(list(csv.DictReader(f)))
    best, second = found["ranked"][:2]
    answer = " ".join(page.sections["answer"])
    assert f"Over all 2 scenes, the best design is {best} :" in answer
    assert re.search(rf"{best} : \d{{1,3}}(,\d{{3}})* cycles \(geometric mean .*\), \d+\.\d\dx as fast as {second}, "
                     "the next best", answer)
    assert "Best per scene" in answer and "Designs ranked" in answer
    cells = page.sections["results"]
    assert "All 12 rows (scene x subdivision x design)" in cells
    rows = [cells[i:i + 7] for i in range(9, len(cells), 7)]        # after the title, summary and header
    assert len(rows) == 12
    for scene, sub, design, cycles, cost, bottleneck, util in rows:
        assert re.fullmatch(r"\d{1,3}(,\d{3})*", cycles) or cycles == "deadlock", cycles
        assert re.fullmatch(r"\d{1,3}(,\d{3})*\.\d", cost), cost
        assert re.fullmatch(r"[A-Z+]+ \d+%(, [A-Z+]+ \d+%)*", util), util
    settings = settings_rows(out)
    assert settings["designs"] == "paper, S, twin_ic" and settings["spec"] == str(SPEC)
    assert "12 rows from 8 tasks" in settings["run"]
    check_images(page)
    drawn, n, width, window, shown = open_in_browser(out, tmp_path)
    assert drawn == n == 1 and width <= window and shown == 1000


def test_report_path_checked_before_work(tmp_path, capsys):
    assert main(["simulate", str(TRACE), "--report", str(tmp_path / "s.txt")]) == 2
    assert main(["explore", "tetra:1", "--res", "8x8", "--report", str(tmp_path / "nodir" / "r.html")]) == 2
    assert not os.listdir(tmp_path)


def test_sweep_page_with_deadlocks_names_what_it_can(tmp_path):
    """A sweep's CSV where one design deadlocks everywhere in a scene and every design deadlocks in
    another subdivision: the best is named among those with a figure for every scene; the rest are
    listed as not ranked; a deadlock is a word in the table, not a number."""
    from mprt.report import sweep_html

    csv_path, png = tmp_path / "sweep.csv", tmp_path / "sweep.png"
    head = "scene,subdivision,n,design,cycles,cost,bottleneck,level,costs,util_OS,util_IC,util_SC\n"
    body = ["a,4x4x4,4,fast,1000.0,900.5,OS,1,mprt.cost,0.9,0.5,0.25",
            "a,4x4x4,4,slow,3000.0,300.0,IC,1,mprt.cost,0.3,0.95,0.1",
            "a,4x4x4,4,stuck,,100.0,deadlock,1,mprt.cost,,,",
            "b,4x4x1,4,fast,2000000.0,900.5,OS,1,mprt.cost,0.8,0.4,0.2",
            "b,4x4x1,4,slow,4500000.0,300.0,IC,1,mprt.cost,0.2,0.9,0.1",
            "b,4x4x1,4,stuck,,100.0,deadlock,1,mprt.cost,,,"]
    csv_path.write_text(head + "\n".join(body) + "\n")
    from mprt.figures import figure
    fig, _ = figure(2)
    fig.savefig(png)
    r = {"csv": str(csv_path), "png": str(png), "rows": 6, "tasks": 2, "cached": 0, "seconds": 0.25}
    out = tmp_path / "w.html"
    out.write_text(sweep_html(r, ["sweep", "s.toml", "--out", str(tmp_path)]))
    page = parse(out)
    answer = " ".join(page.sections["answer"])
    # geometric means: fast sqrt(1000 * 2e6) = 44,721; slow sqrt(3000 * 4.5e6) = 116,190
    assert "the best design is fast : 44,721 cycles" in answer
    assert "2.60x as fast as slow, the next best" in answer
    assert "Not ranked (they deadlock at every subdivision of a scene): stuck." in answer
    cells = page.sections["results"]
    assert "deadlock" in cells and "1,000" in cells and "2,000,000" in cells and "900.5" in cells
    assert "OS 90%, IC 50%, SC 25%" in cells
    assert not any(re.search(r"\d\.\d{3,}|\d{5,}\.0", c) for c in cells)     # no raw floats
    assert settings_rows(out)["spec"] == "s.toml"
