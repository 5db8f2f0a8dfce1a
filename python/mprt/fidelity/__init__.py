"""The fidelity ladder (see README.md)."""
from .compiled import replay, unsupported

__all__ = ["replay", "unsupported"]
