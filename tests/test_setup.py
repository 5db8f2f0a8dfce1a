"""Set-up (issue 20, item 7): make leaves ./mprt, a wrapper around the venv's mprt that runs
from anywhere, and the project's packaging has nothing setuptools warns about."""
import os
import subprocess
import sys
import tomllib

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def test_pyproject_license_is_a_spdx_string():
    """project.license as a TOML table is deprecated (setuptools warned three times per install);
    a string needs setuptools 77, which the build requires."""
    with open(os.path.join(ROOT, "pyproject.toml"), "rb") as f:
        p = tomllib.load(f)
    assert p["project"]["license"] == "MIT"
    req = [r for r in p["build-system"]["requires"] if r.startswith("setuptools")]
    assert req == ["setuptools>=77"]


def test_one_version_in_pyproject_the_package_and_the_extension():
    """mprt checks at import that its compiled extension is of its own version (PACKAGE_VERSION);
    pyproject.toml's version is that one too, and so is the C library's MPRT_VERSION."""
    import mprt
    with open(os.path.join(ROOT, "pyproject.toml"), "rb") as f:
        p = tomllib.load(f)
    with open(os.path.join(ROOT, "c", "include", "mprt.h")) as f:
        c_version = next(line.split()[2].strip('"') for line in f if line.startswith("#define MPRT_VERSION "))
    assert p["project"]["version"] == mprt.PACKAGE_VERSION == mprt.__version__ == c_version


def test_an_extension_of_another_version_is_refused_at_import():
    # the extension's module loaded first, under a stand-in package (mprt's __init__ not run),
    # as if built at another version; then the package is imported over it
    code = ("import importlib.util, os, sys, types\n"
            "import mprt as _\n"                    # (only to find the sources)
            "d = os.path.dirname(_.__file__)\n"
            "for k in [k for k in sys.modules if k == 'mprt' or k.startswith('mprt.')]: del sys.modules[k]\n"
            "pkg = types.ModuleType('mprt'); pkg.__path__ = [d]; sys.modules['mprt'] = pkg\n"
            "import mprt._lowlevel as L; L.EXT_VERSION = '0.0.0-old'\n"
            "del sys.modules['mprt']\n"
            "try:\n    import mprt\nexcept ImportError as e:\n    print(e)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert "compiled extension is version 0.0.0-old but the package is" in out and "pip install -e ." in out


@pytest.mark.skipif(not os.path.exists(os.path.join(ROOT, ".venv", "bin", "mprt")), reason="needs make install")
def test_make_leaves_a_mprt_wrapper_that_runs_from_anywhere(tmp_path):
    """make mprt writes ./mprt (make install, demo and test do): it runs the venv's mprt from
    another directory, with its arguments and exit status."""
    subprocess.run(["make", "-s", "-C", ROOT, "mprt"], check=True, capture_output=True)
    wrapper = os.path.join(ROOT, "mprt")
    r = subprocess.run([wrapper, "--version"], capture_output=True, text=True, cwd=tmp_path)
    assert r.returncode == 0 and r.stdout.startswith("mprt ")
    r = subprocess.run([wrapper, "render", "nowhere.nff"], capture_output=True, text=True, cwd=tmp_path)
    assert r.returncode == 2 and "nowhere.nff" in r.stderr
