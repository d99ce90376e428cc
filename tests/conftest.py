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
