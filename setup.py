"""Registers the cffi builders; all metadata lives in pyproject.toml."""
from setuptools import setup

setup(cffi_modules=["python/mprt/_build.py:ffi", "python/mprt/_build.py:ffi32"])
