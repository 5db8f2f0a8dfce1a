"""The mprt command as a user meets it: what it writes, and that it never substitutes silently.

Most tests run ``mprt.cli.main`` in this process (fast); a few run ``python -m mprt`` to
see the real exit status and streams.  Options and their limits: test_cli_options.py;
traces and statistics: test_cli_trace.py.
"""
import json
import os
import subprocess
import sys

import pytest

import mprt
from mprt import cli, options


def run(*args, cwd=None):
    """python -m mprt ARGS: the completed process."""
    return subprocess.run([sys.executable, "-m", "mprt", *map(str, args)], capture_output=True, text=True, cwd=cwd)


def mprt_main(capsys, *args):
    """(exit status, stdout, stderr) of mprt ARGS run in this process."""
    try:
        code = cli.main([str(a) for a in args])
    except SystemExit as e:      # argparse: --help, --version, bad option values
        code = e.code
    out = capsys.readouterr()
    return code, out.out, out.err


def png_size(path):
    data = open(path, "rb").read()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    return int.from_bytes(data[16:20], "big"), int.from_bytes(data[20:24], "big")


def test_render_writes_png_of_the_asked_size(tmp_path, capsys):
    """mprt render --res 40x30 writes a 40x30 PNG."""
    png = tmp_path / "b.png"
    code, _, err = mprt_main(capsys, "render", "balls:1", "--grid", "6", "--res", "40x30", "-o", png)
    assert code == 0, err
    assert png_size(png) == (40, 30)


def test_render_stats_json_holds_the_counters_and_the_settings(tmp_path, capsys):
    """--stats: every counter (equal to Grid.render's for the same settings), the settings that
    made them (scene and its NFF hash, grid, resolution, rules, threshold, threads, version) and
    the wall time."""
    stats = tmp_path / "b.json"
    code, out, err = mprt_main(capsys, "render", "balls:1", "--grid", "6", "--res", "40x30", "--threads", "2",
                               "--stats", stats)
    assert code == 0, err
    j = json.loads(stats.read_text())
    scene = mprt.Scene.spd("balls", 1)
    _, counters = scene.grid(6).render(40, 30)
    assert {k: j[k] for k in counters} == counters
    s = j["settings"]
    assert s["scene"] == "balls:1" and s["scene_sha256"] == scene.content_hash()
    assert s["grid"] == [6, 6, 6] and s["resolution"] == [40, 30] and s["rules"] == "paper"
    assert s["threshold"] == 1 / 512 and s["threads"] == 2 and s["mprt_version"] == mprt.__version__
    assert "--stats" in s["command"] and j["wall_seconds"] > 0


def test_every_counter_printed_is_in_the_json(tmp_path, capsys):
    """The counters render prints on the console are all in its --stats JSON, with the same values."""
    stats = tmp_path / "b.json"
    code, out, _ = mprt_main(capsys, "render", "tetra:1", "--grid", "3", "--res", "16x16", "--stats", stats)
    assert code == 0
    j = json.loads(stats.read_text())
    printed = dict(line.split(None, 1) for line in out.splitlines() if line.startswith("  "))
    assert {"os_visits", "ic_visits", "sc_visits", "polygon_vertices"} <= set(printed)
    for key, text in printed.items():
        assert str(j[key]) == text.strip(), key


def test_version(capsys):
    """mprt --version names the package's version."""
    code, out, _ = mprt_main(capsys, "--version")
    assert code == 0 and out.strip() == f"mprt {mprt.__version__}"


def test_errors_are_one_line_and_status_1(tmp_path):
    """A malformed scene file (found during the work) gives exit status 1 and one line with file and line."""
    bad = tmp_path / "bad.nff"
    bad.write_text("s 0 0 0 1\ns 1 2\n")
    r = run("render", bad)
    assert r.returncode == 1
    assert "bad.nff:2" in r.stderr and "Traceback" not in r.stderr and len(r.stderr.strip().splitlines()) == 1


# -- 1. no silent substitutions -----------------------------------------------------------------
@pytest.mark.parametrize("cmd", ["render", "trace"])
@pytest.mark.parametrize("res", ["0x0", "0x64", "64x0", "70000x8"])
def test_a_resolution_out_of_range_is_refused_not_replaced(tmp_path, capsys, cmd, res):
    """--res 0x0 used to render 512x512 and 0x64 512x64: now status 2 naming the range, nothing written."""
    out = tmp_path / ("x.png" if cmd == "render" else "x.npz")
    code, stdout, err = mprt_main(capsys, cmd, "balls:1", "--res", res, "-o", out)
    assert code == 2 and "1..65536" in err and not out.exists() and stdout == ""


def test_threshold_with_spd_rules_is_refused(capsys):
    """--threshold under --rules spd (which has no cutoff) used to be ignored."""
    code, out, err = mprt_main(capsys, "render", "balls:1", "--res", "8x8", "--rules", "spd", "--threshold", "0.5")
    assert code == 2 and "--threshold applies to the paper and paper1992 rules only" in err and out == ""


def test_a_jpg_name_is_refused_rather_than_given_png_data(tmp_path, capsys):
    """-o x.jpg used to write PNG data into x.jpg."""
    code, _, err = mprt_main(capsys, "render", "balls:1", "--res", "8x8", "-o", tmp_path / "x.jpg")
    assert code == 2 and ".png" in err and not (tmp_path / "x.jpg").exists()


NFF_ONE_SPHERE = """v
from 0 0 -5
at 0 0 0
up 0 1 0
angle 40
hither 0
resolution 8 8
b 0 0 0
l 0 0 -5
f 1 1 1 1 0 0 0 1
s 0 0 0 1
"""


def test_an_spd_name_means_the_spd_scene_even_beside_a_file_of_that_name(tmp_path, monkeypatch, capsys):
    """A file named 'tetra' in the working directory used to replace SPD tetra silently: now
    'tetra' is the SPD scene, a note says the file is not read, and './tetra' reads the file."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "tetra").write_text(NFF_ONE_SPHERE)
    code, out, err = mprt_main(capsys, "render", "tetra:1", "--grid", "2", "--res", "8x8")
    assert code == 0 and "tetra:1, SPD scene" in out and "4 primitives" in out
    (tmp_path / "tetra:1").write_text(NFF_ONE_SPHERE)
    code, out, err = mprt_main(capsys, "render", "tetra:1", "--grid", "2", "--res", "8x8")
    assert code == 0 and "4 primitives" in out and "tetra:1 here is not read" in err and "./tetra:1" in err
    code, out, _ = mprt_main(capsys, "render", "./tetra", "--grid", "2", "--res", "8x8")
    assert code == 0 and "NFF file ./tetra" in out and "1 primitives" in out


def test_a_directory_named_like_a_scene(tmp_path, monkeypatch, capsys):
    """A directory 'balls' used to give 'out of memory reading 9223372036854775807 bytes': now
    'balls' is the SPD scene (with a note) and './balls' is refused as a directory."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "balls").mkdir()
    code, out, err = mprt_main(capsys, "render", "balls", "--grid", "2", "--res", "4x4")
    assert code == 0 and "balls:4, SPD scene" in out and "directory balls here is not read" in err
    code, out, err = mprt_main(capsys, "render", "./balls", "--res", "4x4")
    assert code == 2 and "is a directory" in err and "out of memory" not in err


def test_scene_load_follows_the_same_rule(tmp_path, monkeypatch):
    """Scene.load: an SPD name is the generator even beside a file of that name."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "rings").write_text(NFF_ONE_SPHERE)
    assert mprt.Scene.load("rings:1").info()["prims"] == mprt.Scene.spd("rings", 1).info()["prims"]
    assert mprt.Scene.load("./rings").info()["prims"] == 1
    with pytest.raises(mprt.InvalidArgument, match="directory"):
        mprt.Scene.load(str(tmp_path))


# -- 3. outputs checked before any work --------------------------------------------------------
def test_an_unwritable_png_fails_before_rendering(tmp_path, capsys):
    """-o nodir/x.png used to render the whole image and then say 'input/output error'."""
    bad = tmp_path / "nodir" / "x.png"
    code, out, err = mprt_main(capsys, "render", "balls:1", "--res", "8x8", "-o", bad)
    assert code == 2 and str(bad) in err and "does not exist" in err and out == ""


def test_an_unwritable_json_fails_before_the_png_is_written(tmp_path, capsys):
    """--stats nodir/x.json used to write the PNG and then fail."""
    png = tmp_path / "a.png"
    code, _, err = mprt_main(capsys, "render", "balls:1", "--res", "8x8", "-o", png,
                             "--stats", tmp_path / "nodir" / "x.json")
    assert code == 2 and "nodir" in err and not png.exists()


def test_two_outputs_naming_one_file_are_refused(tmp_path, capsys):
    code, _, err = mprt_main(capsys, "render", "balls:1", "--res", "8x8", "-o", tmp_path / "a.png",
                             "--stats", tmp_path / "a.png")
    assert code == 2 and "both name" in err


def test_an_unwritable_trace_names_the_users_path_not_a_temporary_file(tmp_path, capsys):
    """trace -o nodir/x.npz used to name a temporary directory the user never asked for."""
    bad = tmp_path / "nodir" / "x.npz"
    code, out, err = mprt_main(capsys, "trace", "balls:1", "--res", "8x8", "-o", bad)
    assert code == 2 and str(bad) in err and "mprt-trace" not in err and out == ""


def test_an_output_that_is_a_directory_is_refused(tmp_path, capsys):
    (tmp_path / "d.png").mkdir()
    code, _, err = mprt_main(capsys, "render", "balls:1", "--res", "8x8", "-o", tmp_path / "d.png")
    assert code == 2 and "is a directory" in err


# -- 5. progress -----------------------------------------------------------------------------
def test_render_shows_progress_when_asked_and_only_then(tmp_path, capsys):
    """render --progress draws a bar on stderr (off a terminal, only when asked); the image is the same."""
    a, b = tmp_path / "a.png", tmp_path / "b.png"
    code, _, err = mprt_main(capsys, "render", "balls:1", "--grid", "4", "--res", "32x32", "--progress", "-o", a)
    assert code == 0 and "render (time estimated)" in err and "100%" in err
    code, _, err = mprt_main(capsys, "render", "balls:1", "--grid", "4", "--res", "32x32", "-o", b)
    assert code == 0 and err == ""
    assert a.read_bytes() == b.read_bytes()


# -- 6. scene ------------------------------------------------------------------------------------
def test_scene_command_writes_nff_that_reads_back(tmp_path, capsys):
    """mprt scene NAME writes NFF (stdout or -o) that loads to the same scene."""
    code, text, _ = mprt_main(capsys, "scene", "tetra", "--size", "1")
    assert code == 0
    s = mprt.Scene.from_text(text, "stdout.nff")
    assert s.info()["count"]["polygon"] == 4  # 4^size triangles
    out = tmp_path / "t.nff"
    assert mprt_main(capsys, "scene", "tetra", "--size", "1", "-o", out)[0] == 0
    assert out.read_text() == text


def test_scene_accepts_name_colon_size_like_render(capsys):
    """'mprt scene balls:2' used to be refused although 'render balls:2' works."""
    code, a, _ = mprt_main(capsys, "scene", "balls:2")
    assert code == 0 and a == mprt_main(capsys, "scene", "balls", "--size", "2")[1]
    assert a == mprt.Scene.spd("balls", 2).to_nff()
    code, _, err = mprt_main(capsys, "scene", "balls:2", "--size", "3")
    assert code == 2 and "give the size once" in err


@pytest.mark.parametrize("how", [("balls", "--size", "{}"), ("balls:{}",)])
def test_spd_sizes_out_of_range_give_one_message_at_either_end(capsys, how):
    """--size 0 used to say 'must be a positive integer' and --size 20 'allowed 1..8, or <= 0 for
    the default': now one message naming the range and the default at both ends."""
    msgs = []
    for size in (0, 20):
        code, _, err = mprt_main(capsys, "scene", *[h.format(size) for h in how])
        assert code == 2
        msgs.append(err.strip())
    assert msgs == [f"mprt scene: error: SPD size {n} for balls is not in 1..8 (default 4)" for n in (0, 20)]


def test_broken_pipe_is_not_an_error():
    """'mprt scene balls | head -1' ends quietly."""
    r = subprocess.run(f"{sys.executable} -m mprt scene balls:3 | head -1", shell=True, capture_output=True,
                       text=True)
    assert r.stdout.startswith("#") and r.stderr == ""


def test_help_states_the_defaults_and_ranges():
    """--help shows each option's range and default (threshold 1/512, rules, threads = cores)."""
    text = cli.build_parser()._subparsers._group_actions[0].choices["render"].format_help()
    text = " ".join(text.split())
    for part in ("1..1024", "1..65536", "default: 1/512", "default: paper", "1..64",
                 f"default: {options.default_threads()}, the machine's cores", f"1..{options.TILE_MAX}"):
        assert part in text, part


def test_default_threads_are_the_machines_cores(tmp_path, capsys):
    """Without --threads a render uses every core this process may run on (it used to use 1)."""
    stats = tmp_path / "s.json"
    assert mprt_main(capsys, "render", "balls:1", "--res", "8x8", "--stats", stats)[0] == 0
    assert json.loads(stats.read_text())["settings"]["threads"] == min(len(os.sched_getaffinity(0)), 64)
