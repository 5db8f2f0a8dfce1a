"""mprt trace and mprt stats: subsets, size estimates, compression, and the invariant check in
bounded memory."""
import dataclasses
import functools
import json
import os
import re
import shutil
import tracemalloc

import numpy as np
import pytest

import mprt
from mprt import Outcome, Stage, tracecheck, tracefile

from test_cli import mprt_main


@functools.cache
def _trace_file(tmp):
    out = tmp / "t.npz"
    code = mprt.cli.main(["trace", "tetra:2", "--grid", "5", "--res", "32x32", "--tile", "8", "--sample", "regular:2",
                          "-o", str(out)])
    assert code == 0
    return out


@pytest.fixture(scope="module")
def trace_file(tmp_path_factory):
    return _trace_file(tmp_path_factory.mktemp("trace"))


def test_trace_command_writes_a_trace_of_the_chosen_tiles(trace_file):
    """mprt trace --sample regular:2 writes a loadable trace of every other tile."""
    t = mprt.load_trace(trace_file)
    assert t.meta["tiles"] == [0, 2, 4, 6, 8, 10, 12, 14] and t.meta["grid"] == [5, 5, 5]


def test_a_random_sample_larger_than_the_image_is_refused(tmp_path, capsys):
    """random:1000:1 on a 16-tile image used to trace all 16 tiles without a word."""
    code, out, err = mprt_main(capsys, "trace", "balls:1", "--res", "64x64", "--sample", "random:1000:1",
                               "-o", tmp_path / "t.npz")
    assert code == 2 and "asks for 1000 tiles" in err and "4x4 = 16 tiles of 16x16" in err
    assert not (tmp_path / "t.npz").exists()


def test_tiles_beyond_the_image_are_refused_with_the_range(tmp_path, capsys):
    code, _, err = mprt_main(capsys, "trace", "balls:1", "--res", "64x64", "--tiles", "3,16", "-o", tmp_path / "t.npz")
    assert code == 2 and "tile 16 does not exist" in err and "tiles 0..15" in err


def _mb(text):
    n, unit = text.split()
    return float(n) * {"bytes": 1e-6, "kB": 1e-3, "MB": 1, "GB": 1e3}[unit]


def test_trace_estimates_its_size_first_and_offers_compression(tmp_path, capsys):
    """Before a run of many tiles, mprt trace prints its size estimate (and --compress's); the
    estimate is within 25% of the file written, and --compress writes a smaller file holding the
    same records."""
    plain, packed = tmp_path / "p.npz", tmp_path / "c.npz"
    args = ["trace", "mount:2", "--grid", "8", "--res", "64x64", "--tile", "4"]
    code, out, err = mprt_main(capsys, *args, "-o", plain)
    assert code == 0, err
    m = re.search(r"size +about ([\d.]+ \w+) \(about ([\d.]+ \w+) with --compress", out)
    assert m, out
    assert out.index("size ") < out.index("trace ")          # printed before the run
    est, est_c = _mb(m.group(1)), _mb(m.group(2))
    actual = plain.stat().st_size / 1e6
    assert abs(est - actual) < 0.25 * actual
    code, out, err = mprt_main(capsys, *args, "--compress", "-o", packed)
    assert code == 0, err
    assert packed.stat().st_size < plain.stat().st_size / 2
    assert abs(est_c - packed.stat().st_size / 1e6) < 0.5 * packed.stat().st_size / 1e6
    a, b = mprt.load_trace(plain), mprt.load_trace(packed)
    assert np.array_equal(a.visits, b.visits) and np.array_equal(a.rays, b.rays)
    assert [p.name for p in tmp_path.iterdir()] == ["p.npz", "c.npz"] or \
        sorted(p.name for p in tmp_path.iterdir()) == ["c.npz", "p.npz"]   # no temporary file left


def test_a_trace_larger_than_the_free_space_is_refused_with_what_would_fit(tmp_path, capsys, monkeypatch):
    """Before tracing, a trace the output's file system has no room for is refused (exit 2, no
    file left). Without --compress the message offers it with its size; with --compress (which
    streams the trace uncompressed beside the output first) it says what that needs and does not
    offer --compress again."""
    args = ["trace", "mount:2", "--grid", "8", "--res", "64x64", "--tile", "4"]
    real = shutil.disk_usage
    monkeypatch.setattr(shutil, "disk_usage", lambda p: real(p)._replace(free=200_000))
    code, _, err = mprt_main(capsys, *args, "-o", tmp_path / "p.npz")
    assert code == 2 and "has 200 kB free" in err and "or --compress (about " in err, err
    code, _, err = mprt_main(capsys, *args, "--compress", "-o", tmp_path / "c.npz")
    assert code == 2 and "has 200 kB free" in err and "streamed beside the output first" in err, err
    assert "or --compress" not in err, err
    assert list(tmp_path.iterdir()) == []


def test_bytes_per_visit_only_where_the_records_dominate(tmp_path, capsys):
    """One one-pixel tile of a 7382-primitive scene on a fine grid: the static tables dominate the
    file (even with format 3's compact voxel lists), so no 'bytes per visit'."""
    code, out, _ = mprt_main(capsys, "trace", "balls:4", "--grid", "200", "--res", "16x16", "--tile", "1",
                             "--tiles", "0", "-o", tmp_path / "t.npz")
    assert code == 0 and "bytes per visit" not in out and "mostly voxel lists" in out
    code, out, _ = mprt_main(capsys, "trace", "balls:1", "--grid", "4", "--res", "32x32", "-o", tmp_path / "u.npz")
    assert code == 0 and "bytes per visit" in out


def test_stats_command_checks_and_prints_the_paper_rows(trace_file, capsys):
    """mprt stats --check prints the paper's rows and that the invariants hold."""
    code, out, err = mprt_main(capsys, "stats", trace_file, "--check")
    assert code == 0, err
    assert "OS -> IC" in out and "invariants: ok" in out


def test_stats_json_counts_the_primary_rays_and_records_the_settings(trace_file, capsys):
    """mprt stats --json: 8 tiles of 8x8 samples make 512 primary rays; the trace's settings come along."""
    code, out, _ = mprt_main(capsys, "stats", trace_file, "--json")
    j = json.loads(out)
    assert j["os_input_primary"] == 8 * 64
    s = j["settings"]
    assert s["scene"] == "tetra:2" and s["grid"] == [5, 5, 5] and s["resolution"] == [32, 32]
    assert s["scene_sha256"] == mprt.Scene.spd("tetra", 2).content_hash()
    assert s["tiles"] == 8 and s["tiles_total"] == 16 and s["mprt_version"] == mprt.__version__
    assert j["wall_seconds"] > 0 and j["invariants_checked"] is False


def test_stats_on_a_file_that_is_not_a_trace_names_it(tmp_path, capsys):
    """mprt stats on a non-zip file fails with status 1 naming the file; a missing one with status 2."""
    bad = tmp_path / "bad.npz"
    bad.write_bytes(b"not a zip")
    code, _, err = mprt_main(capsys, "stats", bad)
    assert code == 1 and "bad.npz" in err
    code, _, err = mprt_main(capsys, "stats", tmp_path / "none.npz")
    assert code == 2 and "none.npz: no such file" in err


# -- the invariant check in chunks ---------------------------------------------------------------
@functools.cache
def mount_trace():
    """mount at 48x48: its visits are in depth-first order, not in ray id order (blocks matter)."""
    return mprt.Scene.spd("mount", 2).grid(8).trace(48, 48)[1]


def _peak_allocated(tr, chunk):
    tracemalloc.start()
    try:
        tracecheck.check(tr, chunk=chunk)
        return tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


def test_check_keeps_to_bounded_memory():
    """The check's allocations do not grow with the trace: checked 2048 visits at a time, its peak
    on a trace 4 times larger is about the same, and a small fraction of the visits array (the
    whole-trace check allocated several times the visits array)."""
    small, large = mount_trace(), mprt.Scene.spd("mount", 2).grid(8).trace(96, 96)[1]
    assert len(large.visits) > 3.5 * len(small.visits)
    _peak_allocated(small, 2048)           # first calls: numpy's lazy imports are not the check's
    a, b = _peak_allocated(small, 2048), _peak_allocated(large, 2048)
    assert b < 1.5 * a and b < large.visits.nbytes / 20, (a, b, large.visits.nbytes)


def _verdict(tr, chunk):
    try:
        tracecheck.check(tr, chunk=chunk)
        return None
    except mprt.TraceError as e:
        return str(e)


def _mutations(tr, seed=3, count=21):
    """Traces with one record changed at random (each of several kinds)."""
    rng = np.random.default_rng(seed)
    for k in range(count):
        v, r = tr.visits.copy(), tr.rays.copy()
        i, j = int(rng.integers(1, len(v))), int(rng.integers(len(r)))
        kind = k % 7
        if kind == 0:
            v = np.delete(v, i)
        elif kind == 1:
            v[[i - 1, i]] = v[[i, i - 1]]
        elif kind == 2:
            v["made"][i] += 1
        elif kind == 3:
            r["parent"][j] = rng.integers(-1, len(r))
        elif kind == 4:
            r["pixel"][j] += 1
        elif kind == 5:
            v["ray"][i] = rng.integers(len(r))
        else:
            v["outcome"][i] = rng.integers(len(Outcome))
        yield dataclasses.replace(tr, visits=v, rays=r)


def test_check_in_small_chunks_gives_the_same_verdict():
    """Chunks of 97 or 997 visits (edges inside rays' runs and inside blocks) give the same verdict
    as one chunk holding the whole trace, on the trace and on broken copies of it (the first
    rule found broken may differ: blocks are checked in turn)."""
    tr = mprt.Scene.spd("mount", 2).grid(8).trace(24, 24)[1]
    whole = len(tr.visits) + 1
    assert _verdict(tr, 97) is None and _verdict(tr, 997) is None
    broken = 0
    for m in _mutations(tr):
        expect = _verdict(m, whole) is None
        broken += not expect
        assert (_verdict(m, 97) is None) == expect and (_verdict(m, 997) is None) == expect
    assert broken >= 15


def test_check_names_the_ray_whose_children_and_made_disagree():
    """A 'made' one short is found (by the count and fingerprint compared at the end, then located)
    and the ray named, with its count of children."""
    tr = mount_trace()
    v = tr.visits.copy()
    sc = np.flatnonzero((v["stage"] == Stage.SC) & (v["outcome"] == Outcome.SHADED) & (v["made"] > 0))[-1]
    v["made"][sc] -= 1
    ray = int(v["ray"][sc])
    kids = int(np.sum(tr.rays["parent"] == ray))
    with pytest.raises(mprt.TraceError, match=rf"made.*ray {ray}: made {kids - 1}, {kids} children"):
        tracecheck.check(dataclasses.replace(tr, visits=v), chunk=1000)


def test_check_refuses_a_parent_that_is_not_a_ray():
    """A parent id past the last ray used to crash the check (IndexError); now it is named."""
    tr = mount_trace()
    r = tr.rays.copy()
    kid = int(np.flatnonzero(r["parent"] >= 0)[0])
    r["parent"][kid] = len(r) + 5
    with pytest.raises(mprt.TraceError, match=f"ray {kid} has parent {len(r) + 5}, which is not a ray"):
        tracecheck.check(dataclasses.replace(tr, rays=r))


def _rss_file_kb():
    with open("/proc/self/status") as f:
        return next(int(line.split()[1]) for line in f if line.startswith("RssFile:"))


@pytest.mark.skipif(not os.path.exists("/proc/self/status"), reason="reads the resident set from Linux's /proc")
def test_reading_a_memory_mapped_array_in_chunks_keeps_the_resident_set_small(tmp_path):
    """tracefile.chunks releases each chunk's pages: reading 64 MB through 1 MB chunks leaves
    (and peaks at) a few MB of the file resident, where reading the memory map whole keeps all
    of it resident."""
    path = tmp_path / "a.npy"
    np.save(path, np.arange(8 << 20, dtype=np.int64))        # 64 MB
    a = np.load(path, mmap_mode="r")
    base = _rss_file_kb()
    total, peak = 0, 0
    for _, part in tracefile.chunks(a, 1 << 17):             # 1 MB
        total += int(part.sum())
        peak = max(peak, _rss_file_kb() - base)
    assert total == (8 << 20) * ((8 << 20) - 1) // 2
    assert peak < 8 << 10 and _rss_file_kb() - base < 4 << 10, peak
    b = np.load(path, mmap_mode="r")
    assert int(b.sum()) == total and _rss_file_kb() - base > 48 << 10   # the memory map read whole
