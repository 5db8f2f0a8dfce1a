import os

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SPD_REF = os.path.join(os.path.dirname(ROOT), "shared", "spd-reference")


@pytest.fixture(scope="session")
def spd_ref():
    """Folder of the original SPD programs' NFF output (shared/spd-reference)."""
    if not os.path.isdir(SPD_REF):
        pytest.fail(f"shared SPD reference files not found at {SPD_REF}")
    return SPD_REF
