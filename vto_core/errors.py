"""The one exception type the project raises for bad input."""


class VtoError(Exception):
    """A user-facing error: its message is one line that says what is wrong."""
