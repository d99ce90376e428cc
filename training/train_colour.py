"""The colour imitator (vto_core.colour_imitator): an MLP from unit parameters to the colour statistics of the region
(lips or hair) the default scene shows, trained on a dataset's renders and masks, exported to ONNX.

Each look's target is vto_core.appearance.region_statistics of its render over its mask. The sources vary from look to
look, so the network learns the statistics the default scene shows on average over its sources: what a photo's colour
is compared with. For lipstick it also reads the CIELAB of the skin around the lips (appearance.skin_light): the light
and skin tone a photo shows colour its lips as much as the lipstick does, and the skin is where a photo shows them.
"""

from __future__ import annotations

import contextlib
import io
import json
import os
from dataclasses import asdict
from pathlib import Path

import numpy as np
import torch

import vto_core
from vto_core.appearance import region_statistics, skin_light
from vto_core.colour_imitator import INPUT_NAME, KIND, OUTPUT_NAME, SKIN_SCALE, ColourImitator
from vto_core.dataset import DatasetReader
from vto_core.errors import VtoError
from vto_core.inference import METADATA_PREFIX

from .config import ColourConfig

PARITY_TOLERANCE = 1e-3  # statistics are CIELAB units


def region_targets(folders: list[str], limit: int = 0, skin: bool = False) -> tuple[np.ndarray, np.ndarray, dict]:
    """(inputs (N, m) unit parameters, with `skin` (lipstick) the skin's CIELAB / SKIN_SCALE after them (N, m + 3);
    statistics (N, F); the spec as a dict) of the looks of `folders` (one spec); at most `limit` looks from each
    folder (0: all)."""
    units, targets, spec = [], [], None
    for folder in folders:
        reader = DatasetReader(folder)
        if spec is not None and reader.spec.to_dict() != spec:
            raise VtoError(f"{folder} has another parameter spec than {folders[0]}")
        spec = reader.spec.to_dict()
        for position in range(min(len(reader), limit or len(reader))):
            sample = reader[position]
            if sample.mask is None:
                raise VtoError(f"{folder} has no region masks: render it with `vto dataset ... --masks` (lipstick)")
            light = skin_light(sample.render, sample.mask) if skin else None
            try:
                statistics = region_statistics(sample.render, sample.mask)
            except VtoError:  # a region that fell off the picture: nothing to learn from
                continue
            if skin:
                if light is None:
                    continue
                units.append(np.concatenate([sample.unit, light[1] / SKIN_SCALE]).astype(np.float32))
            else:
                units.append(sample.unit)
            targets.append(statistics)
    if not units:
        raise VtoError(f"no look with a region in {', '.join(folders)}")
    return np.array(units, np.float32), np.array(targets, np.float32), spec


class ColourNet(torch.nn.Module):
    """(N, m) unit parameters -> (N, F) statistics: an MLP on standardised targets, destandardised at the end."""

    def __init__(self, inputs: int, outputs: int, width: int, mean: np.ndarray, scale: np.ndarray):
        super().__init__()
        self.body = torch.nn.Sequential(torch.nn.Linear(inputs, width), torch.nn.SiLU(), torch.nn.Linear(width, width),
                                        torch.nn.SiLU(), torch.nn.Linear(width, width), torch.nn.SiLU(),
                                        torch.nn.Linear(width, outputs))
        self.register_buffer("mean", torch.as_tensor(mean, dtype=torch.float32))
        self.register_buffer("scale", torch.as_tensor(scale, dtype=torch.float32))

    def forward(self, unit: torch.Tensor) -> torch.Tensor:
        return self.body(unit) * self.scale + self.mean


def train_colour(folders: list[str], out: str, config: ColourConfig) -> dict:
    """Train on `folders`' looks, export to `out` (.onnx, checked against torch); returns the held-out error."""
    import onnx

    out_path = Path(out)
    if not out_path.parent.is_dir():
        raise VtoError(f"cannot write {out_path}: folder {out_path.parent} does not exist")
    units, targets, spec = region_targets(folders, config.limit, config.skin)
    torch.manual_seed(config.seed)
    order = np.random.default_rng(config.seed).permutation(len(units))
    held = max(1, int(config.val_fraction * len(units)))
    train, val = order[held:], order[:held]
    mean, scale = targets[train].mean(0), targets[train].std(0) + 1e-3
    net = ColourNet(units.shape[1], targets.shape[1], config.width, mean, scale)
    optimiser = torch.optim.Adam(net.parameters(), lr=config.lr)
    schedule = torch.optim.lr_scheduler.CosineAnnealingLR(optimiser, config.steps)
    x, y = torch.from_numpy(units), torch.from_numpy(targets)
    weights = torch.from_numpy(1.0 / scale)
    for _ in range(config.steps):
        batch = torch.from_numpy(np.random.default_rng().choice(train, min(config.batch_size, len(train))))
        loss = (((net(x[batch]) - y[batch]) * weights) ** 2).mean()
        optimiser.zero_grad()
        loss.backward()
        optimiser.step()
        schedule.step()
    net.eval()
    with torch.no_grad():
        error = (net(x[val]) - y[val]).abs().mean(0).numpy()
    tmp = out_path.with_name(f".tmp-{os.getpid()}-{out_path.name}")
    try:
        with contextlib.redirect_stdout(io.StringIO()):
            torch.onnx.export(net, (x[:2],), str(tmp), input_names=[INPUT_NAME], output_names=[OUTPUT_NAME],
                              opset_version=18, dynamo=True, external_data=False,
                              dynamic_shapes=({0: torch.export.Dim("batch", min=1, max=4096)},))
        model = onnx.load(str(tmp))
        metadata = {"kind": KIND, "spec": json.dumps(spec, sort_keys=True), "renderer": spec["renderer"],
                    "version": vto_core.__version__,
                    "trained_on": json.dumps({"looks": int(len(train)), "datasets": [str(f) for f in folders]}),
                    "config": json.dumps(asdict(config)),
                    "held_out_error": json.dumps([round(float(e), 3) for e in error])}
        if units.shape[1] > len(spec["modelled"]):  # skin-conditioned: the typical skin stands in where none shows
            metadata["typical_skin_lab"] = json.dumps([round(float(v), 3) for v in
                                                       SKIN_SCALE * np.median(units[:, -3:], axis=0)])
        for key, value in metadata.items():
            entry = model.metadata_props.add()
            entry.key, entry.value = f"{METADATA_PREFIX}{key}", value
        onnx.checker.check_model(model, full_check=True)
        onnx.save(model, str(tmp))
        with torch.no_grad():
            expected = net(x[val[:64]]).numpy()
        check = ColourImitator(tmp)
        m = len(spec["modelled"])
        rows = units[val[:64]]
        got = np.array([check.statistics(row[:m], SKIN_SCALE * row[m:] if row.size > m else None) for row in rows])
        difference = float(np.abs(got - expected).max())
        if not difference <= PARITY_TOLERANCE:
            raise VtoError(f"exported colour imitator differs from torch by {difference:.2e}")
        os.replace(tmp, out_path)
    finally:
        if tmp.exists():
            tmp.unlink()
    return {"out": str(out_path), "looks": int(len(units)), "held_out": int(held),
            "held_out_mean_abs_error": [round(float(e), 3) for e in error], "max_abs_diff": difference}
