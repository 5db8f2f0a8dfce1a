"""The cost model's error: bad processor configurations, kernel names, model files."""
from __future__ import annotations

from .. import InvalidArgument


class CostModelError(InvalidArgument):
    """A processor configuration, kernel name, packet flow or cost-model file is invalid;
    the message names the field (and file) at fault."""


def int_table(where: str, table, keys, lo: int, hi: int | None = None, default: int | None = None,
              what: str = "entry") -> dict:
    """Validate a mapping key -> whole number in lo..hi (hi None: no limit)
    whose keys are among `keys`; missing keys take `default` (None: required).
    Returns a dict in the order of `keys`; errors name `where[key]`."""
    if table is None:
        table = {}
    if not hasattr(table, "items"):
        raise CostModelError(f"{where} must be a table of {what} to whole numbers, not {table!r}")
    for k in table:
        if k not in keys:
            raise CostModelError(f"{where}[{k!r}]: unknown {what} (known: {', '.join(keys)})")
    out = {}
    for k in keys:
        if k not in table:
            if default is None:
                raise CostModelError(f"{where}: {what} {k!r} is missing")
            out[k] = default
            continue
        v = table[k]
        if not isinstance(v, int) or isinstance(v, bool) or v < lo or (hi is not None and v > hi):
            rng = f">= {lo}" if hi is None else f"in {lo}..{hi}"
            raise CostModelError(f"{where}[{k!r}] = {v!r}: must be a whole number {rng}")
        out[k] = v
    return out
