"""mprt.options: one validation per option, shared by every subcommand, with the library's limits."""
import argparse

import pytest

import mprt
from mprt import options

from test_cli import mprt_main


@pytest.fixture(scope="module")
def grid():
    return mprt.Scene.spd("balls", 1).grid(2)


def test_the_resolution_and_threads_limits_are_the_librarys(grid):
    """RES_MAX and THREADS_MAX are exactly the library's limits (its resolve accepts the maximum
    and refuses one more)."""
    for field, top in (("width", options.RES_MAX), ("threads", options.THREADS_MAX)):
        grid.resolve({field: top})
        with pytest.raises(mprt.InvalidArgument):
            grid.resolve({field: top + 1})


def test_the_grid_limit_is_the_librarys():
    """GRID_MAX is the library's: one more voxel per axis is refused with the same range."""
    scene = mprt.Scene.spd("tetra", 1)
    with pytest.raises(mprt.InvalidArgument, match=f"1..{options.GRID_MAX}"):
        scene.grid((options.GRID_MAX + 1, 1, 1))
    scene.grid((options.GRID_MAX, 1, 1))


@pytest.mark.parametrize("name", mprt.SPD_SCENES)
def test_the_spd_size_limits_are_the_librarys(name):
    """SPD_MAX_SIZES: the library refuses one more, naming the same range."""
    top = options.SPD_MAX_SIZES[name]
    with pytest.raises(mprt.InvalidArgument, match=f"allowed 1..{top},"):
        mprt.Scene.spd(name, top + 1)


def test_defaults_in_help_are_the_librarys():
    """The threshold and tile defaults shown are those the library fills in."""
    d = mprt.Scene.spd("balls", 1).grid(2).resolve({})
    assert options.default_threshold() == d["threshold"] == 1 / 512
    assert options.default_tile() == d["tile"]
    assert options.fraction_text(d["threshold"]) == "1/512" and options.fraction_text(0.3) == "0.3"


@pytest.mark.parametrize("parse, text, message", [
    (options.threads_arg, "0", "threads 0 is not in 1..64"),
    (options.threads_arg, "65", "threads 65 is not in 1..64"),
    (options.threads_arg, "two", "'two' is not a whole number (threads must be in 1..64)"),
    (options.tile_arg, "0", "tile edge 0 is not in 1..256"),
    (options.grid_arg, "0", "voxels per axis 0 is not in 1..1024"),
    (options.grid_arg, "4,4", "grid must be N or NX,NY,NZ, not '4,4'"),
    (options.grid_arg, "4,2000,4", "voxels per axis 2000 is not in 1..1024"),
    (options.resolution_arg, "0x64", "width 0 is not in 1..65536"),
    (options.resolution_arg, "64x0", "height 0 is not in 1..65536"),
    (options.resolution_arg, "64", "resolution must be WxH (e.g. 512x512), not '64'"),
    (options.threshold_arg, "1", "threshold 1 is not in [0, 1)"),
    (options.threshold_arg, "nan", "threshold nan is not in [0, 1)"),
    (options.threshold_arg, "-0.1", "threshold -0.1 is not in [0, 1)"),
    (options.sample_arg, "random:0:1", "sample must be 'random:N:SEED', 'stratified:K:SEED', 'regular:K'"),
    (options.sample_arg, "every:2", "sample must be 'random:N:SEED', 'stratified:K:SEED', 'regular:K'"),
    (options.sample_arg, "runs:16:1", "runs:16:1: runs sample the replay of a whole frame's trace"),
    (options.tiles_arg, "1,x", "tiles must be a comma-separated list"),
    (options.tiles_arg, "-1", "tiles must be a comma-separated list"),
])
def test_each_option_names_its_range(parse, text, message):
    with pytest.raises(argparse.ArgumentTypeError) as e:
        parse(text)
    assert str(e.value).startswith(message)


def test_good_values_parse():
    assert options.grid_arg("8") == 8 and options.grid_arg("8,4,2") == (8, 4, 2)
    assert options.resolution_arg("640X480") == (640, 480)
    assert options.threshold_arg("1/512") == 1 / 512 and options.threshold_arg("0") == 0.0
    assert options.sample_arg("random:5:-3") == "random:5:-3" and options.tiles_arg("3,1,") == [3, 1]


@pytest.mark.parametrize("option, value, message", [
    ("--threads", "0", "threads 0 is not in 1..64"),
    ("--tile", "0", "tile edge 0 is not in 1..256"),
])
def test_render_and_trace_refuse_the_same_values_with_the_same_message(tmp_path, capsys, option, value, message):
    """render --threads 0 used to be accepted while trace refused it; --tile 0 used to be
    replaced by 16 (or fail deep in the library)."""
    errs = []
    for cmd, out in (("render", "x.png"), ("trace", "x.npz")):
        code, _, err = mprt_main(capsys, cmd, "balls:1", "--res", "8x8", option, value, "-o", tmp_path / out)
        assert code == 2
        errs.append(err.strip().splitlines()[-1].split(": error: ", 1)[1])
    assert errs[0] == errs[1] == f"argument {option}: {message}"


def test_check_outputs(tmp_path):
    """Outputs: the directory must exist, the name must not be a directory, fixed formats need their suffix."""
    options.check_outputs(("-o", tmp_path / "a.png", "png"), ("--json", tmp_path / "a.json", "json"),
                          ("--x", None, "png"))
    for path, kind, words in ((tmp_path / "no" / "a.png", "png", "does not exist"), (tmp_path, "any", "is a directory"),
                              (tmp_path / "a.PNG.gz", "png", "ending in .png"), (tmp_path / "t.zip", "npz", ".npz")):
        with pytest.raises(options.UsageError, match=words) as e:
            options.check_output("-o", path, kind)
        assert str(e.value).startswith(f"-o {path}")


def test_run_settings_record_what_made_a_result():
    scene = mprt.Scene.spd("tetra", 1)
    grid = scene.grid(3)
    desc = grid.resolve({"width": 10, "height": 12, "rules": 1})
    s = options.run_settings(scene, grid, desc, "SPD scene (generated)", argv=["render", "tetra:1"], extra=1)
    assert s["resolution"] == [10, 12] and s["rules"] == "spd" and s["threshold"] is None
    assert s["scene_sha256"] == scene.content_hash() and s["grid"] == [3, 3, 3] and s["extra"] == 1
    assert s["command"] == "mprt render tetra:1" and s["mprt_version"] == mprt.__version__
