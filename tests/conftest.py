import os

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SPD_REF = os.path.join(ROOT, "tests", "data", "spd-reference")


@pytest.fixture(scope="session")
def spd_ref():
    """Folder of the original SPD programs' NFF output (a copy in tests/data, with its credit)."""
    return SPD_REF
