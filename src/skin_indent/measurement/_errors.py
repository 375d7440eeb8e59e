"""The one exception of :mod:`skin_indent.measurement`, and quoting for its messages.

Every other module of the package imports from here, so this module imports
none of them.
"""

from __future__ import annotations

__all__ = ["MeasurementError"]


class MeasurementError(ValueError):
    """A force-depth measurement (file or arrays) cannot be used as given.

    The message is always a single line that names the problem and, where it
    applies, the file, line and column, so it can be shown to a user as it is.
    """

    def __init__(self, message: str):
        super().__init__(str(message).replace("\r", "\\r").replace("\n", "\\n"))


def _quote(value: object, limit: int = 40) -> str:
    """Quote a piece of user input for a one-line error message."""
    text = repr(str(value))
    return text if len(text) <= limit else text[: limit - 4] + "...'"
