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
