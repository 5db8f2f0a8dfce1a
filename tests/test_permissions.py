"""Every output gets the user's permissions: mode 0o666 less the umask, whatever wrote it (issue 36;
uncompressed traces were written 0o600, from the temporary file they are renamed from)."""
import contextlib
import os
import stat

import pytest

from mprt import cli
from mprt.explore.distributed import DiskCache


@contextlib.contextmanager
def umask(mask: int):
    old = os.umask(mask)
    try:
        yield
    finally:
        os.umask(old)


def mode(path) -> int:
    return stat.S_IMODE(os.stat(path).st_mode)


@pytest.mark.parametrize("mask", [0o022, 0o027, 0o002])
def test_every_output_has_the_mode_the_umask_gives(tmp_path, mask):
    with umask(mask):
        assert cli.main(["trace", "tetra:1", "--res", "16x16", "--grid", "4", "-o", str(tmp_path / "t.npz")]) == 0
        assert cli.main(["trace", "tetra:1", "--res", "16x16", "--grid", "4", "--compress",
                         "-o", str(tmp_path / "c.npz")]) == 0
        assert cli.main(["render", "tetra:1", "--res", "16x16", "-o", str(tmp_path / "r.png"),
                         "--json", str(tmp_path / "r.json")]) == 0
        assert cli.main(["stats", str(tmp_path / "t.npz"), "--json", str(tmp_path / "s.json")]) == 0
        assert cli.main(["scene", "tetra:1", "-o", str(tmp_path / "s.nff")]) == 0
        DiskCache(tmp_path / "cache").put("ab" * 32, {"cycles": 1})
    want = 0o666 & ~mask
    outputs = ["t.npz", "c.npz", "r.png", "r.json", "s.json", "s.nff"]
    assert {f: oct(mode(tmp_path / f)) for f in outputs} == {f: oct(want) for f in outputs}
    assert mode(tmp_path / "cache" / "ab" / ("ab" * 32 + ".json")) == want
    assert sorted(os.listdir(tmp_path)) == sorted(outputs + ["cache"])      # no temporary left beside them
