"""A small real dataset, rendered once per test session with Blender, for the training tests."""

import pytest

PARAMS = "opacity,red,green,blue"


@pytest.fixture(scope="session")
def lipstick_dataset(tmp_path_factory):
    """24 lipstick samples at 16 px with sensitivity renders (opacity and colour modelled)."""
    return _render(tmp_path_factory, "sensitivity", 24, PARAMS, "--sensitivity")


@pytest.fixture(scope="session")
def colour_dataset(tmp_path_factory):
    """160 lipstick samples at 16 px, colour only, no sensitivity: enough to learn an encoder on a CPU."""
    return _render(tmp_path_factory, "colour", 160, "red,green,blue")


def _render(tmp_path_factory, name, n, params, *extra):
    pytest.importorskip("bpy")
    from blender_addon.commands import cmd_dataset

    out = tmp_path_factory.mktemp("data") / name
    assert cmd_dataset(["lipstick", "--out", str(out), "--n", str(n), "--seed", "11", "--res", "16", "--samples", "2",
                        "--params", params, "--quiet", *extra]) == 0
    return out
