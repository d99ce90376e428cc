"""Shared fixtures and markers: Blender tests need bpy, torch tests need torch."""

import gc
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


@pytest.fixture(scope="session")
def eyeshadow_encoder(tmp_path_factory):
    """A tiny eye-shadow encoder (opacity and colour), trained a few steps on 8 looks of the default eye at 16 px and
    exported to ONNX: Match, batch and the asset library are tested without the shipped eyeshadow_encoder.onnx."""
    pytest.importorskip("torch")
    data = _render(tmp_path_factory, "eyeshadow", 8, DATASET_PARAMS, renderer="eyeshadow")
    return _tiny_trained_encoder(data, data.parent / "eyeshadow_encoder")


@pytest.fixture(scope="session")
def tiny_trained_encoder():
    """(dataset folder, out) -> the path of an encoder trained 4 steps on it and exported to `out`.onnx."""
    pytest.importorskip("torch")
    return _tiny_trained_encoder


def _tiny_trained_encoder(data, out) -> str:
    """An encoder trained 4 steps (graphics loss, 8 channels, 2 layers) on dataset `data`, exported to `out`.onnx."""
    from training.config import EncoderConfig, resolve_config
    from training.export import export_encoder
    from training.train_encoder import train_encoder

    run = train_encoder(str(data), None, str(out), resolve_config(EncoderConfig, None, [
        "perceptual=ssim_l1", "batch_size=4", "width=8", "n_layers=2", "pool_size=1", "loss=graphics", "steps=4",
        "log_every=2"]))
    model = f"{out}.onnx"
    export_encoder(str(run.path), model)
    return model


def _render(tmp_path_factory, name, n, params, *extra, renderer="lipstick"):
    pytest.importorskip("bpy")
    from blender_addon.datasets.commands import cmd_dataset

    out = tmp_path_factory.mktemp("data") / name
    assert cmd_dataset([renderer, "--out", str(out), "--n", str(n), "--seed", "11", "--res", "16", "--samples", "2",
                        "--params", params, "--quiet", *extra]) == 0
    return out


@pytest.fixture(autouse=True)
def _collected_generators():
    """A fit's generator that a test leaves half run removes its scratch data (blender_addon.scratch.scratch_data's
    finally) whenever the garbage collector reaches it, with every data-block made since it began: a later test's
    material, mid-Match. Collected at the end of the test that left it."""
    yield
    if HAS_BPY:
        gc.collect()
