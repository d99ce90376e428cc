"""vto_core.errors: what a user is told of a failure."""

from vto_core.errors import VtoError, failure_line


def test_a_failure_is_told_in_one_line():
    assert failure_line(VtoError("no face found in the photo")) == "no face found in the photo"
    assert failure_line(RuntimeError("render failed\ntraceback follows")) == "RuntimeError: render failed"
    assert failure_line(KeyError()) == "KeyError: "
