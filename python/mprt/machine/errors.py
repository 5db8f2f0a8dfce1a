"""Errors of the machine model."""
from __future__ import annotations

from ..errors import MprtError


class ConfigError(MprtError, ValueError):
    """A machine configuration is invalid; the message names the field and the file."""


class DeadlockError(MprtError, RuntimeError):
    """The machine stopped with rays still in it: every stage waits on another.

    ``state`` holds each stage's and FIFO's state when it stopped (also in the message)."""

    def __init__(self, message: str, state: dict):
        super().__init__(message)
        self.state = state
