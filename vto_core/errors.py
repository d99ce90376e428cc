"""The one exception type the project raises for bad input."""


class VtoError(Exception):
    """A user-facing error: its message is one line that says what is wrong."""


def failure_line(exc: Exception) -> str:
    """What a user is told of a failure in one line: a VtoError's own message; any other exception's type and the
    first line of its message (a render or a library that failed)."""
    if isinstance(exc, VtoError):
        return str(exc)
    return f"{type(exc).__name__}: {(str(exc).splitlines() or [''])[0]}"
