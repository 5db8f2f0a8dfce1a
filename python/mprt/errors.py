"""mprt's exceptions.

Each error is also the built-in exception a caller would expect
(``InvalidArgument`` is a ``ValueError``, ...), so code that does not know
mprt still catches it.  The library's own message (naming the field, file or
line) is the exception's text.
"""


class MprtError(Exception):
    """Base of mprt's errors; never raised itself."""


class InvalidArgument(MprtError, ValueError):
    """An argument is out of range, NaN, degenerate or malformed."""


class SceneParseError(MprtError, ValueError):
    """Scene text is malformed; the message names file and line."""


class SceneStateError(MprtError, RuntimeError):
    """The call is not allowed in the object's current state."""


class WorkLimitError(MprtError, RuntimeError):
    """A work limit was reached: a sample's ray tree needed more rays than its budget."""


class CapacityError(MprtError, RuntimeError):
    """A buffer was too small (internal; callers should not see it)."""


class TraceError(MprtError, ValueError):
    """A trace file or trace object is malformed, truncated, tampered or of an unknown version."""


class UsageError(InvalidArgument):
    """An option or a setting is out of range, options contradict each other, or an output cannot
    be written: found before any work (``mprt`` exits with status 2)."""
