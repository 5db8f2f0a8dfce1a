"""Outputs that appear whole or not at all.

Every file a command writes (images, JSON, CSV, plots, reports, NFF) is written to a
temporary file beside its target and renamed onto it only when complete, so an interrupt
(Ctrl-C, SIGKILL, a full disk) never leaves a partial file under the final name.  The
temporary's name is ``.NAME.PID.tmpEXT`` (hidden, the target's extension kept so that
writers that infer the format from it still work), or ``.NAME.PID.TAG.tmpEXT`` for a scratch
file of another kind made on the way (a trace's records before they are deflated); a later
write of the same target removes those left by processes that no longer run (SIGKILL leaves
them: nothing can clean up after it).  Ctrl-C removes them on the way out.

The files are created with ``open`` (mode 0o666 less the umask), not ``tempfile.mkstemp``
(0o600): a file renamed into place keeps the mode it was made with, and every output of mprt
gets the user's usual permissions.
"""
from __future__ import annotations

import contextlib
import glob
import os

TMP = ".tmp"


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:          # exists, owned by someone else
        return True
    return True


def _stale(path: str) -> list:
    """Temporaries of path left by processes that are gone."""
    d, base = os.path.split(os.path.abspath(path))
    ext = os.path.splitext(base)[1]
    out = []
    for p in glob.glob(os.path.join(glob.escape(d), f".{glob.escape(base)}.*{TMP}{glob.escape(ext)}")):
        pid = os.path.basename(p)[len(base) + 2:].split(".", 1)[0]
        if pid.isdigit() and not _alive(int(pid)):
            out.append(p)
    return out


def temporary(path, tag: str = "") -> str:
    """The temporary path used while writing path (stale ones of dead processes removed);
    ``tag`` (letters): that of a scratch file of another kind, ``.NAME.PID.TAG.tmpEXT``."""
    path = os.fspath(path)
    if tag and not tag.isalpha():
        raise ValueError(f"a temporary's tag is letters, not {tag!r}")
    for p in _stale(path):
        with contextlib.suppress(OSError):
            os.remove(p)
    d, base = os.path.split(os.path.abspath(path))
    return os.path.join(d, f".{base}.{os.getpid()}{'.' + tag if tag else ''}{TMP}{os.path.splitext(base)[1]}")


@contextlib.contextmanager
def replacing(path):
    """Yield a temporary path beside ``path``; when the block ends normally it is renamed onto
    ``path`` (atomically), otherwise removed."""
    tmp = temporary(path)
    try:
        yield tmp
        os.replace(tmp, os.fspath(path))
    except BaseException:
        with contextlib.suppress(OSError):
            os.remove(tmp)
        raise


@contextlib.contextmanager
def open_replacing(path, mode: str = "w", **kwargs):
    """``open(path, mode)`` for writing, through a temporary beside it (see ``replacing``)."""
    with replacing(path) as tmp, open(tmp, mode, **kwargs) as f:
        yield f
