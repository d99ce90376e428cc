"""Shared fixtures and markers: Blender tests need bpy, torch tests need torch."""

import importlib.util
import os
import tempfile

import pytest
from hypothesis import settings

# A loaded CI machine must not fail a property test on wall-clock time.
settings.register_profile("vto", deadline=None)
settings.load_profile("vto")

HAS_BPY = importlib.util.find_spec("bpy") is not None
HAS_TORCH = importlib.util.find_spec("torch") is not None

# Nothing a test does may land in the user's Blender config.
os.environ.setdefault("BLENDER_USER_RESOURCES", tempfile.mkdtemp(prefix="vto-blender-user-"))


def pytest_collection_modifyitems(config, items):
    """Skip blender/torch-marked tests where the module is missing (said in the summary)."""
    for item in items:
        if "blender" in item.keywords and not HAS_BPY:
            item.add_marker(pytest.mark.skip(reason="bpy is not installed"))
        if "torch" in item.keywords and not HAS_TORCH:
            item.add_marker(pytest.mark.skip(reason="torch is not installed"))


# A small real dataset, rendered once per test session with Blender, for the training and pipeline tests.
DATASET_PARAMS = "opacity,red,green,blue"


@pytest.fixture(scope="session")
def lipstick_dataset(tmp_path_factory):
    """24 lipstick samples at 16 px with sensitivity renders (opacity and colour modelled)."""
    return _render(tmp_path_factory, "sensitivity", 24, DATASET_PARAMS, "--sensitivity")


@pytest.fixture(scope="session")
def colour_dataset(tmp_path_factory):
    """160 lipstick samples at 16 px, colour only, no sensitivity: enough to learn an encoder on a CPU."""
    return _render(tmp_path_factory, "colour", 160, "red,green,blue")


def _render(tmp_path_factory, name, n, params, *extra):
    pytest.importorskip("bpy")
    from blender_addon.datasets.commands import cmd_dataset

    out = tmp_path_factory.mktemp("data") / name
    assert cmd_dataset(["lipstick", "--out", str(out), "--n", str(n), "--seed", "11", "--res", "16", "--samples", "2",
                        "--params", params, "--quiet", *extra]) == 0
    return out
