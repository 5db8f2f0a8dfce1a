"""Every binding that hands an array to C checks it first (issue 19): a view of the
wrong dtype, shape, contiguity or size is InvalidArgument, never a read past the buffer."""
import numpy as np
import pytest

import mprt
from mprt._lowlevel import RAY_DTYPE, VISIT_DTYPE, binding
from mprt.errors import InvalidArgument
from mprt.fidelity.compiled import Compiled
from mprt.grid import render_desc

LL = binding("double")


@pytest.fixture(scope="module")
def small():
    grid = mprt.Scene.spd("tetra", size=1).grid(4)
    trace = grid.trace(8, 8)[1]
    return grid, trace


def _costs(n):
    one = np.ones(n, dtype=np.int64)
    return type("Costs", (), {"process": one, "receive": one, "send": one})()


def test_compiled_rejects_a_byte_view_of_the_rays(small):
    _, trace = small
    rays = np.asarray(trace.rays)
    bytes_view = np.zeros(4096, dtype=np.uint8)     # 4,096 "rays" in 4,096 bytes: C would read far past it
    h = LL.replay_create({})
    visits = np.asarray(trace.visits)
    with pytest.raises(InvalidArgument, match="dtype uint8"):
        LL.replay_load(h, bytes_view, visits, *[np.ones(len(visits), np.int64)] * 3)
    with pytest.raises(InvalidArgument, match="one-dimensional"):
        LL.replay_load(h, rays.reshape(1, -1), visits, *[np.ones(len(visits), np.int64)] * 3)
    with pytest.raises(InvalidArgument, match="one-dimensional"):
        LL.replay_load(h, rays, visits.reshape(1, -1), *[np.ones(len(visits), np.int64)] * 3)
    with pytest.raises(InvalidArgument, match="dtype"):
        LL.replay_load(h, rays, visits.view(np.uint8), *[np.ones(len(visits), np.int64)] * 3)
    with pytest.raises(InvalidArgument, match="shape"):
        LL.replay_load(h, rays, visits, *[np.ones(len(visits) - 1, np.int64)] * 3)
    with pytest.raises((InvalidArgument, ValueError)):
        Compiled(type("T", (), {"rays": bytes_view, "visits": visits})(), _costs(len(visits)))


def test_replay_log_must_be_int64_and_writable(small):
    _, trace = small
    visits = np.asarray(trace.visits)
    h = LL.replay_create({})
    LL.replay_load(h, np.asarray(trace.rays), visits, *[np.ones(len(visits), np.int64)] * 3)
    with pytest.raises(InvalidArgument, match="dtype int32"):
        LL.replay_run(h, np.zeros(8 * len(visits) * 4, dtype=np.int32))
    ro = np.zeros(8 * (len(visits) + len(trace.rays)), dtype=np.int64)
    ro.setflags(write=False)
    with pytest.raises(InvalidArgument, match="read-only"):
        LL.replay_run(h, ro)
    assert LL.replay_run(h, None)          # the checks refuse only what is wrong


def test_trace_tile_buffers_are_checked(small):
    grid, _ = small
    desc = render_desc(8, 8)
    samples = np.zeros(8 * 8 * 3)
    rays, visits = np.zeros(64, RAY_DTYPE), np.zeros(256, VISIT_DTYPE)
    with pytest.raises(InvalidArgument, match="dtype"):
        grid.trace_tile(desc, 0, samples, np.zeros(64 * RAY_DTYPE.itemsize, np.uint8), visits)
    with pytest.raises(InvalidArgument, match="one-dimensional"):
        grid.trace_tile(desc, 0, samples, rays, visits.reshape(2, -1))
    with pytest.raises(InvalidArgument, match="dtype float32"):
        grid.trace_tile(desc, 0, samples.astype(np.float32), rays, visits)
    with pytest.raises(InvalidArgument, match="C-contiguous"):
        grid.trace_tile(desc, 0, np.zeros(8 * 8 * 6)[::2], rays, visits)


def test_render_and_png_buffers_are_checked(small, tmp_path):
    grid, _ = small
    desc = render_desc(8, 8)
    with pytest.raises(InvalidArgument, match="dtype float64"):
        LL.grid_render(grid._h, desc, np.zeros((8, 8, 3), np.float64))
    with pytest.raises(InvalidArgument, match="shape"):
        LL.image_write_png(tmp_path / "x.png", np.zeros(8 * 8 * 3, np.float32))
    with pytest.raises(InvalidArgument, match="dtype float64"):
        LL.image_write_png(tmp_path / "x.png", np.zeros((8, 8, 3), np.float64))
    with pytest.raises(InvalidArgument, match="C-contiguous"):
        LL.image_write_png(tmp_path / "x.png", np.zeros((8, 16, 3), np.float32)[:, ::2])
    assert not (tmp_path / "x.png").exists()


def test_cost_bindings_check_the_records(small):
    _, trace = small
    rays, visits = np.asarray(trace.rays), np.asarray(trace.visits)
    with pytest.raises(InvalidArgument, match="dtype uint8"):
        LL.cost_children(np.zeros(4096, np.uint8))
    children = LL.cost_children(rays)
    with pytest.raises(InvalidArgument, match="one-dimensional"):
        LL.cost_visits({}, rays, children, np.zeros(1, np.int32), visits.reshape(1, -1))
    with pytest.raises(InvalidArgument, match="dtype"):
        LL.cost_visits({}, rays.view(np.uint8), children, np.zeros(1, np.int32), visits)
