"""The mprt command."""
import json
import subprocess
import sys

import mprt


def run(*args, cwd=None):
    return subprocess.run([sys.executable, "-m", "mprt", *args], capture_output=True, text=True, cwd=cwd)


def test_render_writes_png_of_the_asked_size(tmp_path):
    """mprt render --res 40x30 writes a 40x30 PNG."""
    png = tmp_path / "b.png"
    r = run("render", "balls:1", "--grid", "6", "--res", "40x30", "-o", str(png))
    assert r.returncode == 0, r.stderr
    data = png.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    assert int.from_bytes(data[16:20], "big") == 40 and int.from_bytes(data[20:24], "big") == 30


def test_render_stats_are_the_counters_of_the_same_render(tmp_path):
    """mprt render --stats writes every counter, equal to Grid.render's for the same settings."""
    stats = tmp_path / "b.json"
    r = run("render", "balls:1", "--grid", "6", "--res", "40x30", "--stats", str(stats))
    assert r.returncode == 0, r.stderr
    _, counters = mprt.Scene.spd("balls", 1).grid(6).render(40, 30)
    assert json.loads(stats.read_text()) == counters
    assert counters["eye_rays"] == 1200 and set(counters["tests"]) == set(mprt.KINDS)


def test_scene_command_writes_nff_that_reads_back(tmp_path):
    """mprt scene NAME writes NFF (stdout or -o) that loads to the same scene."""
    r = run("scene", "tetra", "--size", "1")
    assert r.returncode == 0
    s = mprt.Scene.from_text(r.stdout, "stdout.nff")
    assert s.info()["count"]["polygon"] == 4  # 4^size triangles
    out = tmp_path / "t.nff"
    assert run("scene", "tetra", "--size", "1", "-o", str(out)).returncode == 0
    assert out.read_text() == r.stdout


def test_errors_are_one_line_and_nonzero(tmp_path):
    """A malformed scene file gives exit status 1 and a message with file and line."""
    bad = tmp_path / "bad.nff"
    bad.write_text("s 0 0 0 1\ns 1 2\n")
    r = run("render", str(bad))
    assert r.returncode == 1
    assert "bad.nff:2" in r.stderr and "Traceback" not in r.stderr


def trace_file(tmp_path):
    out = tmp_path / "t.npz"
    r = run("trace", "tetra:2", "--grid", "5", "--res", "32x32", "--tile", "8", "--sample", "regular:2", "-o", str(out))
    assert r.returncode == 0, r.stderr
    return r, out


def test_trace_command_writes_a_trace_of_the_chosen_tiles(tmp_path):
    """mprt trace --sample regular:2 writes a loadable trace of every other tile."""
    r, out = trace_file(tmp_path)
    assert "bytes per visit" in r.stdout
    t = mprt.load_trace(out)
    assert t.meta["tiles"] == [0, 2, 4, 6, 8, 10, 12, 14] and t.meta["grid"] == [5, 5, 5]


def test_stats_command_checks_and_prints_the_paper_rows(tmp_path):
    """mprt stats --check prints the paper's rows and that the invariants hold."""
    _, out = trace_file(tmp_path)
    s = run("stats", str(out), "--check")
    assert s.returncode == 0, s.stderr
    assert "OS -> IC" in s.stdout and "invariants: ok" in s.stdout


def test_stats_command_json_counts_the_primary_rays(tmp_path):
    """mprt stats --json: 8 tiles of 8x8 samples make 512 primary rays."""
    _, out = trace_file(tmp_path)
    j = run("stats", str(out), "--json")
    assert json.loads(j.stdout)["os_input_primary"] == 8 * 64


def test_stats_command_on_a_file_that_is_not_a_trace_names_it(tmp_path):
    """mprt stats on a non-zip file fails with status 1 naming the file."""
    bad = tmp_path / "bad.npz"
    bad.write_bytes(b"not a zip")
    b = run("stats", str(bad))
    assert b.returncode == 1 and "bad.npz" in b.stderr
