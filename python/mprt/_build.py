"""cffi builder (out-of-line API mode) for the mprt C library.

Two extension modules are built from the same C sources: ``mprt._mprt`` in
double precision and ``mprt._mprt32`` with ``MPRT_SINGLE`` (float geometry),
so precision studies can compare both in one process.  The cdef is the
public header itself with its preprocessor lines removed, so it cannot drift
from the C declarations; the compiler checks it against them.
"""
import glob
import os
import re

from cffi import FFI

ROOT = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", ".."))
INCLUDE = os.path.join(ROOT, "c", "include")
SOURCES = sorted(glob.glob(os.path.join(ROOT, "c", "src", "*.c")))
# the headers too: without them a change to a header alone (dda.h, ic.h) rebuilds nothing
HEADERS = sorted(glob.glob(os.path.join(ROOT, "c", "src", "*.h"))) + [os.path.join(INCLUDE, "mprt.h")]


def _cdef_text():
    with open(os.path.join(INCLUDE, "mprt.h")) as f:
        text = f.read()
    text = re.sub(r"/\*.*?\*/", "", text, flags=re.S)
    text = re.sub(r'extern "C" \{|^\}\s*$', "", text, flags=re.M)
    # Preprocessor lines are dropped, except integer constants (cffi checks them against C).
    const = re.compile(r"#define MPRT_[A-Z0-9_]+ \d+$")
    lines = [ln for ln in text.splitlines() if not ln.lstrip().startswith("#") or const.match(ln.strip())]
    return "\n".join(lines) + "\nconst char *mprt_ext_version(void);\n"


def _make(module, defines):
    ffi = FFI()
    ffi.cdef(_cdef_text())
    ffi.set_source(
        module,
        '#include "mprt.h"\nstatic const char *mprt_ext_version(void) { return MPRT_VERSION; }\n',
        sources=[os.path.relpath(s, ROOT) for s in SOURCES],
        depends=[os.path.relpath(h, ROOT) for h in HEADERS],
        include_dirs=[os.path.relpath(INCLUDE, ROOT), os.path.join("c", "src")],
        define_macros=defines + [("_POSIX_C_SOURCE", "200809L")],
        extra_compile_args=["-std=c99", "-O2", "-ffp-contract=off"],
        libraries=["m", "pthread"],
    )
    return ffi


ffi = _make("mprt._mprt", [])
ffi32 = _make("mprt._mprt32", [("MPRT_SINGLE", "1")])

if __name__ == "__main__":
    os.chdir(ROOT)
    ffi.compile(tmpdir=os.path.join(ROOT, "build", "cffi"), verbose=True)
