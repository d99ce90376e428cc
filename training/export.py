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

from .networks import Averaged, MirrorAveraged, build
from .run import RunFolder

PARITY_TOLERANCE = 1e-4


def trained_on_mirrors(checkpoint: dict) -> bool:
    """Whether the run trained on mirrored views (augment): only then is its mirror reading as good as its own."""
    return bool(checkpoint.get("config", {}).get("augment", False))


def input_filter(checkpoint: dict) -> int:
    """The box filter a run's encoder reads its input through (networks.Encoder), 0 for none."""
    return checkpoint["model_args"].get("input_filter", 0)


def filter_text(size: int) -> str:
    """How the metadata names an input filter of `size` pixels (0: none)."""
    return f"box {size}x{size}, edges repeated" if size else "none"


def encoder_metadata(checkpoints: list[dict], mirror_averaged: bool, averaged: str) -> dict[str, str]:
    """What the ONNX file says about itself: spec, renderer, input size and format, mirror averaging, the input's
    filter, how its runs were averaged, versions."""
    height, width = checkpoints[0]["image_size"]
    filters = sorted({input_filter(c) for c in checkpoints})
    spec = checkpoints[0]["spec"]
    return {
        f"{METADATA_PREFIX}kind": "encoder",
        f"{METADATA_PREFIX}spec": json.dumps(spec, sort_keys=True),
        f"{METADATA_PREFIX}renderer": spec["renderer"],
        f"{METADATA_PREFIX}input_size": f"{height}x{width}",
        f"{METADATA_PREFIX}input_normalisation": "NCHW float32, display sRGB values in [0, 1]",
        f"{METADATA_PREFIX}output": "normalised parameters in [0, 1], in the spec's vector order",
        f"{METADATA_PREFIX}mirror_averaged": str(mirror_averaged).lower(),
        f"{METADATA_PREFIX}input_filter": ", ".join(filter_text(k) for k in filters),
        f"{METADATA_PREFIX}averaged_runs": str(len(checkpoints)),
        f"{METADATA_PREFIX}averaged": averaged,
        f"{METADATA_PREFIX}version": vto_core.__version__,
        f"{METADATA_PREFIX}trained_steps": ",".join(str(c["step"]) for c in checkpoints),
    }


def load_encoder_runs(run_paths: list[str]) -> list[dict]:
    """The checkpoints of encoder runs of one spec and input size (VtoError naming the first that differs). An exported
    encoder (.onnx) after the first run reads as a checkpoint of that run's network holding the file's weights."""
    checkpoints = []
    for run_path in run_paths:
        if str(run_path).endswith(".onnx"):
            if not checkpoints:
                raise VtoError(f"{run_path}: an exported encoder needs a run before it, whose network it holds")
            checkpoint = exported_checkpoint(str(run_path), checkpoints[0])
        else:
            checkpoint = RunFolder(run_path).load_checkpoint(required=True)
            if checkpoint.get("kind") != "encoder":
                raise VtoError(f"{run_path} is a {checkpoint.get('kind')} run; export takes an encoder run")
        first = checkpoints[0] if checkpoints else checkpoint
        for key, what in (("spec", "parameter spec"), ("image_size", "input size")):
            if checkpoint[key] != first[key]:
                raise VtoError(f"{run_path} has another {what} than {run_paths[0]}: runs averaged into one file "
                               f"need one")
        checkpoints.append(checkpoint)
    return checkpoints


def exported_checkpoint(path: str, template: dict) -> dict:
    """An exported encoder as a checkpoint like `template` (a run's, whose spec and network it must have): its weights,
    its input size, its mirror training as the file says, its trained steps."""
    from .networks import build

    spec = RendererSpec.from_dict(template["spec"])
    session = EncoderSession(path, expected_spec=spec)  # refuses another spec
    said = {key.removeprefix(METADATA_PREFIX): value for key, value in session.metadata.items()}
    if said.get("input_filter") != filter_text(input_filter(template)):
        raise VtoError(f"{path} reads its input through {said.get('input_filter')}, the runs through "
                       f"{filter_text(input_filter(template))}")
    return {**template, "model": onnx_encoder_weights(path, build("encoder", template["model_args"]), spec),
            "image_size": type(template["image_size"])(session.input_size),  # load_encoder_runs compares it
            "config": {**template.get("config", {}), "augment": said.get("mirror_averaged") == "true"},
            "step": said.get("trained_steps", "?")}


def weight_soup(checkpoints: list[dict]) -> dict:
    """One checkpoint of the same network whose every weight (batch-norm statistics too) is the mean of
    `checkpoints`': a weight soup, read at one encoder's cost. Fine-tunes of one start share a basin, where the mean of
    their weights reads about as the mean of their readings (Wortsman et al. 2022). VtoError for another network."""
    first = checkpoints[0]
    for checkpoint in checkpoints[1:]:
        if checkpoint["model_args"] != first["model_args"]:
            raise VtoError(f"weights average only over one network: {checkpoint['model_args']} is not "
                           f"{first['model_args']}")
    model = {name: (sum(c["model"][name].double() for c in checkpoints) / len(checkpoints)).to(tensor.dtype)
             if tensor.is_floating_point() else tensor for name, tensor in first["model"].items()}
    return {**first, "model": model}


def onnx_tensors(path: str) -> dict[str, torch.Tensor]:
    """An exported model's stored tensors (its initializers) by name."""
    import onnx
    from onnx import numpy_helper

    return {t.name: torch.from_numpy(numpy_helper.to_array(t).copy()) for t in onnx.load(path).graph.initializer}


def onnx_encoder_weights(path: str, encoder: torch.nn.Module, spec: RendererSpec) -> dict[str, torch.Tensor]:
    """The weights of an exported encoder (`vto export`) as `encoder`'s state dict: what fine-tuning starts from.
    VtoError where the file is for another spec or another network (its tensors' names or shapes differ)."""
    EncoderSession(path, expected_spec=spec)  # refuses a file that is not an encoder, or one of another spec
    # the encoder's own names, without the MirrorAveraged / Averaged wrappers' prefixes
    stored = {name.split("encoders.0.", 1)[-1].split("encoder.", 1)[-1]: tensor
              for name, tensor in onnx_tensors(path).items()}
    state = {}
    for name, current in encoder.state_dict().items():
        if name.endswith("num_batches_tracked"):
            state[name] = current
        elif name not in stored or stored[name].shape != current.shape:
            raise VtoError(f"{path} holds another network than this run's (no {name} of shape "
                           f"{tuple(current.shape)}): set width, n_layers, blocks and batch_norm as it was trained")
        else:
            state[name] = stored[name].to(current.dtype)
    return state


def onnx_colour_net(path: str, spec: RendererSpec) -> torch.nn.Module:
    """An exported colour imitator (`vto train colour`) as a frozen torch ColourNet for the colour loss. VtoError
    for another spec, or a skin-conditioned one (it reads the skin as well as the parameters)."""
    from vto_core.colour_imitator import ColourImitator

    from .train_colour import ColourNet

    imitator = ColourImitator(path)  # refuses a file that is not a colour imitator
    if not imitator.spec.same_as(spec) or imitator.typical_skin is not None:
        raise VtoError(f"{path} is not a colour imitator of the data's spec that reads the parameters alone")
    stored = onnx_tensors(path)
    net = ColourNet(spec.size, stored["body.6.bias"].numel(), stored["body.0.bias"].numel(), stored["mean"].numpy(),
                    stored["scale"].numpy())
    net.load_state_dict({name: stored[name] for name in net.state_dict()})
    net.eval()
    for parameter in net.parameters():
        parameter.requires_grad_(False)
    return net


def export_encoder(run_paths: str | list[str], out_path: str, opset: int = 18, mirror: bool = True,
                   smooth: bool = False, average: str = "outputs") -> dict:
    """RUN/checkpoint.pt (or several runs, averaged) -> out_path (.onnx); onnx.checker and onnxruntime-vs-torch parity
    must pass. Several runs of one spec and size are averaged by `average`: "outputs" reads each and averages the
    readings (networks.Averaged, n times the time), "weights" reads once through their averaged weights (weight_soup:
    one network's runs only); an exported encoder (.onnx) may stand among them after the first run. With `mirror`,
    runs all trained on mirrored views are exported mirror-averaged (networks.MirrorAveraged): twice the encoder's
    ~1 ms for a lower error (blender_addon/models/lipstick_encoder.md). With `smooth`, a run trained without an input
    filter reads its input box-filtered over 3 x 3 pixels all the same (networks.Encoder's input_filter), steadier
    against a framing a pixel off."""
    import onnx

    if average not in ("outputs", "weights"):
        raise VtoError(f"average must be 'outputs' or 'weights', got {average!r}")
    run_paths = [run_paths] if isinstance(run_paths, (str, os.PathLike)) else list(run_paths)
    checkpoints = load_encoder_runs(run_paths)
    if smooth:
        checkpoints = [{**c, "model_args": {**c["model_args"], "input_filter": input_filter(c) or 3}}
                       for c in checkpoints]
    mirror_averaged = mirror and all(trained_on_mirrors(c) for c in checkpoints)
    averaged = average if len(checkpoints) > 1 else "none"
    networks = [weight_soup(checkpoints)] if average == "weights" else checkpoints
    spec = RendererSpec.from_dict(checkpoints[0]["spec"])
    wraps = [p.wraps for p in spec.modelled_params]
    encoders = []
    for checkpoint in networks:
        encoder = build("encoder", checkpoint["model_args"])
        encoder.load_state_dict(checkpoint["model"])
        encoders.append(MirrorAveraged(encoder, wraps) if mirror_averaged else encoder)
    encoder = encoders[0] if len(encoders) == 1 else Averaged(encoders, wraps)
    encoder.eval()
    height, width = checkpoints[0]["image_size"]
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
        for key, value in encoder_metadata(checkpoints, mirror_averaged, averaged).items():
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
            "input_filter": [input_filter(c) for c in checkpoints],
            "averaged_runs": len(checkpoints), "averaged": averaged,
            "params": checkpoints[0]["spec"]["modelled"]}


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
