"""--report: one self-contained HTML page per explore, simulate and sweep (issue 20).

The page is parsed: every section the report promises is there with content, every image
is an embedded PNG that decodes, and nothing refers outside the file.  Where Debian's
headless Chromium is installed, the page is also opened in it: every image is drawn and
nothing is wider than the window."""
import base64
import os
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
    """(images drawn, images, page width, window width) from headless Chromium, or skip."""
    exe = shutil.which("chromium") or shutil.which("chromium-browser")
    if exe is None:
        pytest.skip("headless Chromium is not installed (apt-get install chromium)")
    probe = tmp_path / "probe.html"
    probe.write_text(Path(path).read_text().replace(
        "</body>", "<script>window.addEventListener('load', () => { const im = [...document.images]; "
                   "document.title = 'PROBE ' + im.filter(i => i.complete && i.naturalWidth > 0).length + ' ' + "
                   "im.length + ' ' + document.documentElement.scrollWidth + ' ' + window.innerWidth; });"
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
    assert list(page.sections) == ["answer", "references", "ladder", "history", "plots", "reproduce"]
    for name, body in page.sections.items():
        assert body, name
    text = " ".join(page.sections["answer"])
    assert "Best design for tetra:1" in text and "cycles at level" in text
    assert "paper 3MPPE" in page.sections["references"] and "model S" in page.sections["references"]
    assert any("mprt explore tetra:1 --res 16x16" in t for t in page.sections["reproduce"])
    sections_with_images = {s for s, _, _ in page.images}
    assert {"ladder", "plots"} <= sections_with_images
    check_images(page)
    drawn, n, width, window = open_in_browser(out, tmp_path)
    assert drawn == n == len(page.images) and width <= window


def test_simulate_report(tmp_path):
    out = tmp_path / "s.html"
    assert main(["simulate", str(TRACE), "--model", "3mppe", "--report", str(out)]) == 0
    page = parse(out)
    assert list(page.sections) == ["answer", "stages", "plots", "reproduce"]
    assert "cycles" in " ".join(page.sections["answer"])
    assert {"OS", "IC", "SC"} <= set(page.sections["stages"])
    check_images(page)


def test_sweep_report(tmp_path):
    out = tmp_path / "w.html"
    assert main(["sweep", str(SPEC), "--out", str(tmp_path / "sw"), "--workers", "0", "--report", str(out)]) == 0
    page = parse(out)
    assert list(page.sections) == ["answer", "results", "plots", "reproduce"]
    assert "12 rows" in " ".join(page.sections["answer"])
    check_images(page)


def test_report_path_checked_before_work(tmp_path, capsys):
    assert main(["simulate", str(TRACE), "--report", str(tmp_path / "s.txt")]) == 2
    assert main(["explore", "tetra:1", "--res", "8x8", "--report", str(tmp_path / "nodir" / "r.html")]) == 2
    assert not os.listdir(tmp_path)
