"""Export a trained encoder to ONNX with the metadata Blender needs, and check it against torch."""

from __future__ import annotations

import contextlib
import io
import json
import os
from pathlib import Path

import numpy as np
import torch

import vto_core
from vto_core.errors import VtoError
from vto_core.inference import INPUT_NAME, METADATA_PREFIX, OUTPUT_NAME, EncoderSession
from vto_core.specs import RendererSpec

from .networks import MirrorAveraged, build
from .run import RunFolder

PARITY_TOLERANCE = 1e-4


def trained_on_mirrors(checkpoint: dict) -> bool:
    """Whether the run trained on mirrored views (augment): only then is its mirror reading as good as its own."""
    return bool(checkpoint.get("config", {}).get("augment", False))


def encoder_metadata(checkpoint: dict, mirror_averaged: bool) -> dict[str, str]:
    """What the ONNX file says about itself: spec, renderer, input size and format, mirror averaging, versions."""
    height, width = checkpoint["image_size"]
    spec = checkpoint["spec"]
    return {
        f"{METADATA_PREFIX}kind": "encoder",
        f"{METADATA_PREFIX}spec": json.dumps(spec, sort_keys=True),
        f"{METADATA_PREFIX}renderer": spec["renderer"],
        f"{METADATA_PREFIX}input_size": f"{height}x{width}",
        f"{METADATA_PREFIX}input_normalisation": "NCHW float32, display sRGB values in [0, 1]",
        f"{METADATA_PREFIX}output": "normalised parameters in [0, 1], in the spec's vector order",
        f"{METADATA_PREFIX}mirror_averaged": str(mirror_averaged).lower(),
        f"{METADATA_PREFIX}version": vto_core.__version__,
        f"{METADATA_PREFIX}trained_steps": str(checkpoint["step"]),
    }


def export_encoder(run_path: str, out_path: str, opset: int = 18, mirror: bool = True) -> dict:
    """RUN/checkpoint.pt -> out_path (.onnx); onnx.checker and onnxruntime-vs-torch parity must pass. With `mirror`,
    a run trained on mirrored views is exported mirror-averaged (networks.MirrorAveraged): twice the encoder's ~1 ms
    for a lower error (blender_addon/models/lipstick_encoder.md)."""
    import onnx

    checkpoint = RunFolder(run_path).load_checkpoint(required=True)
    if checkpoint.get("kind") != "encoder":
        raise VtoError(f"{run_path} is a {checkpoint.get('kind')} run; export takes an encoder run")
    encoder = build("encoder", checkpoint["model_args"])
    encoder.load_state_dict(checkpoint["model"])
    mirror_averaged = mirror and trained_on_mirrors(checkpoint)
    if mirror_averaged:
        spec = RendererSpec.from_dict(checkpoint["spec"])
        encoder = MirrorAveraged(encoder, [p.wraps for p in spec.modelled_params])
    encoder.eval()
    height, width = checkpoint["image_size"]
    out = Path(out_path)
    if not out.parent.is_dir():
        raise VtoError(f"cannot write {out}: folder {out.parent} does not exist")
    tmp = out.with_name(f".tmp-{os.getpid()}-{out.name}")
    try:
        example = torch.rand(2, 3, height, width)
        with contextlib.redirect_stdout(io.StringIO()):  # the exporter narrates on stdout; ours is one JSON line
            torch.onnx.export(encoder, (example,), str(tmp), input_names=[INPUT_NAME], output_names=[OUTPUT_NAME],
                              opset_version=opset, dynamo=True, external_data=False,
                              dynamic_shapes=({0: torch.export.Dim("batch", min=1, max=4096)},))
        model = onnx.load(str(tmp))
        for key, value in encoder_metadata(checkpoint, mirror_averaged).items():
            entry = model.metadata_props.add()
            entry.key, entry.value = key, value
        onnx.checker.check_model(model, full_check=True)
        onnx.save(model, str(tmp))
        parity = _parity(encoder, str(tmp), height, width)
        os.replace(tmp, out)
    finally:
        if tmp.exists():
            tmp.unlink()
    return {"out": str(out), "max_abs_diff": parity, "input_size": [height, width], "mirror_averaged": mirror_averaged,
            "params": checkpoint["spec"]["modelled"]}


def _parity(encoder: torch.nn.Module, path: str, height: int, width: int) -> float:
    """Largest |onnxruntime - torch| over a random batch; VtoError above PARITY_TOLERANCE."""
    images = np.random.default_rng(0).random((3, 3, height, width), dtype=np.float32)
    with torch.no_grad():
        expected = encoder(torch.from_numpy(images)).numpy()
    got = EncoderSession(path).predict_unit_nchw(images)
    difference = float(np.abs(got - expected).max())
    if not difference <= PARITY_TOLERANCE:
        raise VtoError(f"exported encoder differs from torch by {difference:.2e} (> {PARITY_TOLERANCE:g})")
    return difference
