"""The records' check in two halves at once (``recordcheck.check(threads=2)``,
``mprt_trace_checker_split``/``_join``) against one pass: the same answer (fault kind and C's
reason) and the same memory keys, wherever the halves meet; a sound trace is settled in the two
halves alone, a fault in the second half or across the halves is found again in one pass (so
its kind and reason are one pass's), a fault in the first half is the first half's."""
import numpy as np
import pytest

from mprt import recordcheck

from test_recordcheck import INVARIANTS, RANGES, golden


def run(meta, a, threads, at=None, chunk=recordcheck.CHUNK, invariants=True, keys=True):
    want = recordcheck.memory_keys(a["prim_material"], len(a["voxel_start"]) - 1) if keys else None
    got = recordcheck.check(recordcheck.limits(meta, a, invariants), a["rays"], a["visits"], chunk, keys=want,
                            threads=threads, split_min=2, split_at=at)
    made = None if want is None or "keys" not in want else (want["keys"], want["voxel_refs"], want["material_refs"])
    return got, made


def same(one, two):
    (r1, k1), (r2, k2) = one, two
    return r1 == r2 and (k1 is None) == (k2 is None) and (k1 is None or all(map(np.array_equal, k1, k2)))


@pytest.fixture
def passes(monkeypatch):
    """The parts each check call ran: a list of the second part's start (0: one pass)."""
    seen = []
    inner = recordcheck._check

    def spy(lim, rays, visits, chunk, keys, mid):
        seen.append(mid)
        return inner(lim, rays, visits, chunk, keys, mid)

    monkeypatch.setattr(recordcheck, "_check", spy)
    return seen


@pytest.mark.parametrize("name", ["balls-g4", "gears-g9", "rings-g9"])
def test_a_sound_trace_split_anywhere_is_sound_in_two_parts(name, passes):
    meta, a = golden(name)
    one = run(meta, a, 1)
    assert one[0] == (recordcheck.SOUND, "") and one[1] is not None
    n = len(a["visits"])
    ats = sorted({1, 2, 3, n // 3, n // 2, n - 2, n - 1, *np.random.default_rng(5).integers(1, n, 12).tolist()})
    passes.clear()
    for at in ats:
        for chunk in (recordcheck.CHUNK, 777):
            passes.clear()
            assert same(run(meta, a, 2, at, chunk), one), at
            assert passes == [at]            # settled in two parts: no second pass
        assert same(run(meta, a, 2, at, invariants=False), run(meta, a, 1, invariants=False))


@pytest.mark.parametrize("edit", INVARIANTS + RANGES, ids=lambda f: f.__name__)
def test_each_crafted_fault_is_one_passs_answer(edit):
    meta, a = golden()
    edit(meta, a)
    one = run(meta, a, 1)
    assert one[0][0] != recordcheck.SOUND and one[1] is None
    n = len(a["visits"])
    for at in (1, 7, n // 2, n - 1) if n > 1 else ():
        assert same(run(meta, a, 2, at), one), at
        assert same(run(meta, a, 2, at, chunk=5), one), at


def _run_of(v, ray):
    idx = np.flatnonzero(v["ray"] == ray)
    return int(idx[0]), int(idx[-1]) + 1


def test_faults_across_the_halves_are_found_again_in_one_pass(passes):
    """What only the two halves together break: a ray's visits in both halves, a child in the
    second half before its parent's SC visit there; each named as one pass names it."""
    meta, base = golden("balls-g9")
    v0 = base["visits"]
    n = len(v0)
    mid = n // 2
    cases = []
    a = {k: x.copy() for k, x in base.items()}      # a ray of the first half visited again in the second
    r = int(a["visits"]["ray"][mid // 2])
    a["visits"]["ray"][mid + 40] = r
    cases.append(a)
    a = {k: x.copy() for k, x in base.items()}      # a shadow ray's whole run again in the second half
    shadow = np.flatnonzero(base["rays"]["kind"] == 3)
    s = int(shadow[np.searchsorted(shadow, int(v0["ray"][mid // 2]))])
    slo, shi = _run_of(v0, s)
    at = _run_of(v0, int(v0["ray"][mid + 60]))[1]       # after a run ends: each half alone is sound
    a["visits"] = np.concatenate([v0[:at], v0[slo:shi], v0[at:]])
    cases.append(a)
    a = {k: x.copy() for k, x in base.items()}      # the split inside a ray's run: sound
    lo, hi = _run_of(v0, int(v0["ray"][mid]))
    cases.append(a)
    rays = base["rays"]
    kids = np.flatnonzero(rays["parent"] >= 0)
    for c in kids:          # a child whose parent's SC visit comes after it, both in the second half
        p = int(rays["parent"][c])
        plo, phi = _run_of(v0, p)
        clo, chi = _run_of(v0, int(c))
        if plo > mid + 2 and chi == plo:       # the child's run right before its parent's: swap them
            a = {k: x.copy() for k, x in base.items()}
            v = a["visits"]
            a["visits"] = np.concatenate([v[:clo], v[plo:phi], v[clo:plo], v[phi:]])
            break
    else:       # (traces made by mprt put a parent's run first: make such an order by moving runs)
        c = int(kids[np.searchsorted(kids, int(v0["ray"][mid + 50]))])
        p = int(rays["parent"][c])
        plo, phi = _run_of(v0, p)
        clo, chi = _run_of(v0, c)
        a = {k: x.copy() for k, x in base.items()}
        v = a["visits"]
        if plo < clo:       # move the child's run before its parent's
            a["visits"] = np.concatenate([v[:plo], v[clo:chi], v[plo:clo], v[chi:]])
    cases.append(a)
    kinds = []
    for a in cases:
        one = run(meta, a, 1)
        for at in (mid, mid - 1, mid + 1, lo + 1, hi - 1):
            passes.clear()
            assert same(run(meta, a, 2, at), one), at
            assert passes == ([at] if one[0][0] == recordcheck.SOUND else [at, 0])
        kinds.append(one[0][0])
    assert kinds == [recordcheck.INVARIANT, recordcheck.INVARIANT, recordcheck.SOUND, recordcheck.INVARIANT]


def test_random_edits_one_pass_and_two_halves_agree():
    meta, base = golden("tetra-g4")
    rng = np.random.default_rng(81)
    n, nv = len(base["rays"]), len(base["visits"])
    fields = [("visits", "ray", lambda: rng.integers(0, n)), ("visits", "stage", lambda: rng.integers(0, 3)),
              ("visits", "outcome", lambda: rng.integers(0, 9)), ("visits", "made", lambda: rng.integers(0, 4)),
              ("visits", "steps", lambda: rng.integers(0, 3)), ("visits", "voxel_id", lambda: rng.integers(-2, 3)),
              ("rays", "parent", lambda: rng.integers(-1, n)), ("rays", "kind", lambda: rng.integers(0, 5))]
    kinds = set()
    for _ in range(120):
        a = {k: v.copy() for k, v in base.items()}
        member, field, value = fields[rng.integers(len(fields))]
        where = rng.integers(0, nv if member == "visits" else n)
        a[member][field][where] = value()
        one = run(meta, a, 1)
        at = int(np.clip(where + rng.integers(-30, 30), 1, nv - 1)) if member == "visits" else nv // 2
        assert same(run(meta, a, 2, at), one), (member, field, where, at)
        kinds.add(one[0][0])
    assert kinds == {recordcheck.SOUND, recordcheck.RANGE, recordcheck.INVARIANT}


def test_default_threads_split_only_large_traces(monkeypatch, passes):
    meta, a = golden("balls-g4")
    lim = recordcheck.limits(meta, a, True)
    passes.clear()
    recordcheck.check(lim, a["rays"], a["visits"])
    assert passes == [0]                         # fewer than SPLIT_MIN visits: one pass
    passes.clear()
    monkeypatch.setenv(recordcheck.THREADS_ENV, "1")
    recordcheck.check(lim, a["rays"], a["visits"], split_min=2)
    assert passes == [0]
    passes.clear()
    monkeypatch.setenv(recordcheck.THREADS_ENV, "2")
    recordcheck.check(lim, a["rays"], a["visits"], split_min=2)
    assert passes == [len(a["visits"]) // 2]


def _halves(meta, a, at):
    """(first part's answer, second part's answer, join's answer) of a split at ``at``, in C."""
    from mprt._lowlevel import binding

    lib = binding("double")
    ffi, c = lib.ffi, lib.lib
    rays, v = a["rays"], a["visits"]
    rb = lib._in("mprt_trace_ray", rays)
    h = ffi.gc(c.mprt_trace_checker_create(ffi.new("mprt_trace_limits *", recordcheck.limits(meta, a, True)), rb,
                                           len(rays)), c.mprt_trace_checker_destroy)
    assert c.mprt_trace_checker_rays(h, 0, len(rays)) == 0
    p = ffi.gc(c.mprt_trace_checker_split(h, lib._in("mprt_trace_visit", v[at - 1:at]), at),
               c.mprt_trace_checker_destroy)
    one = c.mprt_trace_checker_visits(h, lib._in("mprt_trace_visit", v[:at]), at)
    two = c.mprt_trace_checker_visits(p, lib._in("mprt_trace_visit", v[at:]), len(v) - at)
    return one, two, c.mprt_trace_checker_join(h, p)


def test_what_each_half_cannot_see_is_found_by_the_join():
    meta, base = golden("balls-g9")
    v0 = base["visits"]
    mid = len(v0) // 2
    assert _halves(meta, base, mid) == (0, 0, recordcheck.SOUND)
    shadow = np.flatnonzero(base["rays"]["kind"] == 3)
    s = int(shadow[np.searchsorted(shadow, int(v0["ray"][mid // 2]))])
    slo, shi = _run_of(v0, s)
    at = _run_of(v0, int(v0["ray"][mid + 60]))[1]
    a = dict(base, visits=np.concatenate([v0[:at], v0[slo:shi], v0[at:]]))     # a run in both halves
    assert _halves(meta, a, mid) == (0, 0, recordcheck.REDO)
    rays = base["rays"]
    for c in np.flatnonzero(rays["parent"] >= 0):      # a child's run before its parent's SC visit
        p = int(rays["parent"][c])
        plo, phi = _run_of(v0, p)
        clo, chi = _run_of(v0, int(c))
        if plo < mid - 5 and clo >= mid:        # parent in the first half, child in the second: sound
            continue
        if mid < plo and phi <= clo:
            v = v0[:plo]
            a = dict(base, visits=np.concatenate([v, v0[clo:chi], v0[plo:clo], v0[chi:]]))
            assert _halves(meta, a, mid) == (0, 0, recordcheck.REDO)
            break
    else:
        pytest.fail("no parent and child in the second half")


def test_release_since_lets_go_of_the_second_half_only(tmp_path, monkeypatch):
    """pages.release(part, since=half): the range let go starts at the page of ``since`` (the
    first half's reader keeps its pages); without it, at the map's start."""
    import mmap as _mmap

    from mprt import pages

    page = _mmap.PAGESIZE
    n = 64 * page
    path = tmp_path / "m.bin"
    path.write_bytes(bytes(n))
    m = np.memmap(path, dtype=np.uint8, mode="r")
    calls = []
    monkeypatch.setattr(pages, "_madvise", lambda start, length, advice: calls.append((start, length)))
    half = m[n // 2 + 100:]
    pages.release(half[:page], since=half)
    pages.release(half[:page])
    base = m.ctypes.data
    first = half.ctypes.data - half.ctypes.data % page
    end = min(half.ctypes.data + page + pages._AROUND, base + n)
    assert calls == [(first, end - first), (base, end - base)]


def test_kept_pages_are_not_let_go_in_any_thread(tmp_path, monkeypatch):
    """Within pages.kept() no release lets pages go, from this thread or another; after the
    block (nested blocks included) they are let go again."""
    import threading

    from mprt import pages

    path = tmp_path / "m.bin"
    path.write_bytes(bytes(8 * pages.mmap.PAGESIZE))
    m = np.memmap(path, dtype=np.uint8, mode="r")
    calls = []
    monkeypatch.setattr(pages, "_madvise", lambda start, length, advice: calls.append(start))
    with pages.kept():
        with pages.kept():
            pages.release(m[:100])
        t = threading.Thread(target=pages.release, args=(m[:100],))
        t.start()
        t.join()
        assert calls == []
    pages.release(m[:100])
    assert calls == [m.ctypes.data]


def test_simulate_keeps_a_trace_files_pages_for_the_compiled_replay_only(tmp_path, monkeypatch):
    """mprt simulate of a trace file: its checksums and check let no page go when the compiled
    replay loads the whole file next (every pass's releases happen within pages.kept), and let
    them go for SimPy, which reads it a window at a time."""
    import mprt
    from mprt import cli, pages

    path = tmp_path / "t.npz"
    mprt.Scene.spd("balls", 1).grid(4).trace(16, 16, path=path)
    seen = []
    real = pages.release
    monkeypatch.setattr(pages, "release", lambda *a, **k: (seen.append(pages._KEPT[0] > 0), real(*a, **k))[1])
    for mod in ("tracefile", "recordcheck", "tracevalid", "tracecheck"):
        monkeypatch.setattr(f"mprt.{mod}.release", pages.release, raising=False)
    for engine, want in (("compiled", True), ("simpy", False)):
        seen.clear()
        assert cli.main(["simulate", str(path), "--model", "M", "--engine", engine]) == 0
        assert seen and set(seen) == {want}, (engine, seen)
