"""Outputs appear whole or not at all, and Ctrl-C is one line and status 130 (issue 19)."""
import os
import subprocess
import sys

import numpy as np
import pytest

import mprt
from mprt import atomic, cli


def test_a_failed_write_leaves_neither_target_nor_temporary(tmp_path):
    target = tmp_path / "out.json"
    with pytest.raises(RuntimeError):
        with atomic.open_replacing(target) as f:
            f.write("{partial")
            raise RuntimeError("disk full")
    assert os.listdir(tmp_path) == []


def test_an_old_file_survives_a_failed_rewrite(tmp_path):
    target = tmp_path / "img.png"
    mprt.write_png(target, np.zeros((4, 4, 3), np.float32))
    before = target.read_bytes()
    with pytest.raises(mprt.InvalidArgument):
        mprt.write_png(target, np.zeros((4, 4), np.float32))
    assert target.read_bytes() == before and os.listdir(tmp_path) == ["img.png"]


def test_stale_temporaries_of_dead_processes_are_removed(tmp_path):
    target = tmp_path / "r.json"
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True,
                          text=True).stdout.strip()
    stale = tmp_path / f".r.json.{dead}.tmp.json"
    stale.write_text("{")
    mine = tmp_path / f".r.json.{os.getpid()}.tmp.json"        # a live writer's: kept until it is done
    other = tmp_path / f".q.json.{dead}.tmp.json"              # another target's: not ours to remove
    other.write_text("{")
    tmp = atomic.temporary(target)
    assert not stale.exists() and other.exists() and tmp == str(mine)
    with atomic.open_replacing(target) as f:
        f.write("{}")
    assert sorted(os.listdir(tmp_path)) == sorted([".q.json." + dead + ".tmp.json", "r.json"])


def test_savefig_keeps_the_format_of_the_target(tmp_path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig = plt.figure()
    with atomic.replacing(tmp_path / "p.png") as tmp:
        fig.savefig(tmp)
    plt.close(fig)
    assert (tmp_path / "p.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_ctrl_c_is_one_line_and_status_130(monkeypatch, capsys, tmp_path):
    def interrupted(_args):
        raise KeyboardInterrupt
    parser = cli.build_parser()
    monkeypatch.setattr(cli, "build_parser", lambda *a, **k: parser)
    for action in parser._subparsers._group_actions[0].choices.values():
        action.set_defaults(func=interrupted)
    assert cli.main(["render", "tetra:1", "--res", "8x8", "-o", str(tmp_path / "x.png")]) == 130
    err = capsys.readouterr().err
    assert err == "mprt render: interrupted\n"
    assert os.listdir(tmp_path) == []
