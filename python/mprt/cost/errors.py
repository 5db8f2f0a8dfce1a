"""The cost model's error: bad processor configurations, kernel names, model files."""
from __future__ import annotations

from .. import InvalidArgument


class CostModelError(InvalidArgument):
    """A processor configuration, kernel name, packet flow or cost-model file is invalid;
    the message names the field (and file) at fault."""
