"""Encoder accuracy against dataset size, render samples and width (graphics loss, same steps for every run).

Datasets are packed first (here, where they were rendered), so the sweep runs wherever torch is fast:

    python -m benchmarks.bench_encoder_scaling pack --data DIR --out FILE.npz [--max N]
    python -m benchmarks.bench_encoder_scaling sweep --packed NAME=FILE.npz ... [--device cuda] [--results DIR]

Every run trains `training.networks.Encoder` with the graphics loss (hue on the circle) and mirrored/shifted views
for --steps steps (Adam, lr 1e-3, cosine decay, batch 16) on the first N training samples of a packed dataset, and
reports the held-out parameter error on the first packed set's last --val samples (unit ranges): MSE as in training,
and the mean absolute error. Other packed sets must hold other looks than those (e.g. the first looks of the same
seed rendered at other samples per pixel): they are trained on, never validated on. Rows: each --sizes N on the first packed set at width 32; each --widths W at the largest N; every
other packed set (e.g. rendered at other samples per pixel) at the largest N and width 32; and one run
without the mirrored/shifted views.
"""

from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path

import numpy as np

from benchmarks.common import RESULTS, table, write_section


def pack(data: str, out: str, limit: int | None) -> None:
    """A dataset folder's renders (uint8) and unit parameter vectors into one compressed .npz."""
    from vto_core.dataset import DatasetReader

    reader = DatasetReader(data)
    count = len(reader) if limit is None else min(limit, len(reader))
    renders = np.empty((count, *reader[0].render.shape), np.uint8)
    units = np.empty((count, reader.spec.size), np.float32)
    for position in range(count):
        sample = reader[position]
        renders[position] = np.clip(sample.render * 255 + 0.5, 0, 255).astype(np.uint8)
        units[position] = sample.unit
    manifest = {k: reader.manifest[k] for k in ("renderer", "res", "samples", "seed")}
    np.savez_compressed(out, renders=renders, units=units, spec=json.dumps(reader.spec.to_dict()),
                        manifest=json.dumps(manifest))
    print(json.dumps({"out": out, "looks": count, **manifest}))


# Training views by name -> the EncoderConfig switches (augment, photo_views, mouth_views) that training.data's
# encoder_views reads.
VIEWS = {"none": (False, False, False), "augment": (True, False, False), "photo": (True, True, False),
         "mouth": (True, True, True)}


def training_views(batch: dict, views: str) -> dict:
    """The batch as an encoder trained with `views` (a VIEWS name) sees it."""
    from types import SimpleNamespace

    from training.data import encoder_views

    switches = dict(zip(("augment", "photo_views", "mouth_views"), VIEWS[views]))
    return encoder_views(batch, SimpleNamespace(**switches))


def train_once(train: tuple, held_out: tuple, wraps, size: int, width: int, steps: int, device: str,
               views: str = "augment", blocks: int = 0, batch_norm: bool = False,
               open_mouth_errors: bool = False) -> dict[str, float]:
    """One graphics-loss run on the first `size` of train = (renders, units); MSE and MAE on held_out (alike), and
    'errors': the held-out absolute errors (n_val, m) in unit ranges; with `open_mouth_errors`, also
    'open_mouth_errors': the same with teeth painted on every held-out render (training.data.open_mouths, fixed
    seed)."""
    import torch

    from training.data import open_mouths
    from training.losses import graphics_loss, parameter_difference
    from training.networks import Encoder

    torch.manual_seed(0)
    (train_x, train_g), (val_x, val_g) = (t[:size] for t in train), held_out
    encoder = Encoder(train_g.shape[1], width, blocks=blocks, batch_norm=int(batch_norm)).to(device)
    optimiser = torch.optim.Adam(encoder.parameters(), lr=1e-3, betas=(0.5, 0.999))
    schedule = torch.optim.lr_scheduler.LambdaLR(optimiser, lambda s: 0.5 * (1 + math.cos(math.pi * s / steps)))
    started = time.perf_counter()
    for _ in range(steps):
        pick = torch.randint(0, size, (16,), device=device)
        batch = training_views({"render": train_x[pick].float() / 255}, views)
        loss = graphics_loss(train_g[pick], encoder(batch["render"]), wraps)
        optimiser.zero_grad(set_to_none=True)
        loss.backward()
        optimiser.step()
        schedule.step()
    encoder.eval()

    @torch.no_grad()
    def held_out_errors(images):
        return torch.cat([parameter_difference(val_g[i:i + 256], encoder(images[i:i + 256]), wraps)
                          for i in range(0, len(val_g), 256)])

    held_out_images = val_x.float() / 255
    error = held_out_errors(held_out_images)
    figures = {"mse": float(error.square().mean()), "mae": float(error.abs().mean()),
               "seconds": time.perf_counter() - started, "errors": error.abs().cpu().numpy()}
    if open_mouth_errors:
        torch.manual_seed(123)
        with_teeth = open_mouths({"render": held_out_images}, chance=1.0)["render"]
        figures["open_mouth_errors"] = held_out_errors(with_teeth).abs().cpu().numpy()
    return figures


def sweep(packed: list[tuple[str, str]], sizes: list[int], widths: list[int], steps: int, val: int, device: str,
          results: Path) -> None:
    """The rows described in the module docstring, into RESULTS/encoder_scaling.md."""
    import torch

    from vto_core.specs import RendererSpec

    loaded = {}
    for name, path in packed:
        with np.load(path) as archive:
            spec = RendererSpec.from_dict(json.loads(str(archive["spec"])))
            renders = torch.from_numpy(archive["renders"]).permute(0, 3, 1, 2).contiguous().to(device)
            loaded[name] = (renders, torch.from_numpy(archive["units"]).to(device),
                            torch.tensor([p.wraps for p in spec.modelled_params], device=device),
                            json.loads(str(archive["manifest"])), spec)
    first = packed[0][0]
    renders, units, wraps, manifest, spec = loaded[first]
    usable, held_out = len(units) - val, (renders[-val:], units[-val:])
    sizes = [n for n in sizes if n <= usable]
    rows = []

    def add(label: str, name: str, size: int, width: int, views: str = "augment") -> None:
        renders, units, _, manifest, _ = loaded[name]
        figures = train_once((renders, units), held_out, wraps, size, width, steps, device, views)
        rows.append([label, name, manifest["samples"], size, width, f"{figures['mse']:.4f}", f"{figures['mae']:.3f}",
                     f"{figures['seconds']:.0f}"])
        figures.pop("errors")
        print(json.dumps({"label": label, "data": name, "size": size, "width": width, **figures}), flush=True)

    for size in sizes:
        add("dataset size", first, size, 32)
    for width in widths:
        add("width", first, sizes[-1], width)
    add("no mirrored/shifted views", first, sizes[-1], 32, views="none")
    for name, _ in packed[1:]:
        add("render samples", name, min(sizes[-1], len(loaded[name][1])), 32)
    device_name = torch.cuda.get_device_name() if device.startswith("cuda") else "cpu"
    write_section("encoder_scaling", f"scaling-{spec.renderer}", (
        f"## {spec.renderer} ({', '.join(spec.modelled)}; {manifest['res']} px)\n\n"
        f"Graphics loss, {steps} steps of batch 16 (Adam lr 1e-3, cosine), mirrored/shifted views; held-out error "
        f"on the last {val} samples of `{first}` (unit ranges, hue on the circle); trained on {device_name}.\n\n"
        + table(["varied", "data", "spp", "training samples", "width", "held-out MSE", "held-out MAE", "s"], rows)
        + "\n\nReproduce: `python -m benchmarks.bench_encoder_scaling pack --data DIR --out FILE.npz`, then "
          "`python -m benchmarks.bench_encoder_scaling sweep --packed NAME=FILE.npz ... --device cuda`."),
        results=results)


def main() -> None:
    """python -m benchmarks.bench_encoder_scaling pack|sweep ..."""
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = parser.add_subparsers(dest="phase", required=True)
    packer = sub.add_parser("pack")
    packer.add_argument("--data", required=True)
    packer.add_argument("--out", required=True)
    packer.add_argument("--max", type=int, default=None)
    sweeper = sub.add_parser("sweep")
    sweeper.add_argument("--packed", action="append", required=True, metavar="NAME=FILE.npz")
    sweeper.add_argument("--sizes", default="250,500,1000,2000,4000")
    sweeper.add_argument("--widths", default="16,32,64")
    sweeper.add_argument("--steps", type=int, default=6000)
    sweeper.add_argument("--val", type=int, default=500)
    sweeper.add_argument("--device", default="cpu")
    sweeper.add_argument("--results", default=str(RESULTS))
    args = parser.parse_args()
    if args.phase == "pack":
        pack(args.data, args.out, args.max)
    else:
        packed = [tuple(item.split("=", 1)) for item in args.packed]
        sweep(packed, [int(v) for v in args.sizes.split(",")], [int(v) for v in args.widths.split(",")], args.steps,
              args.val, args.device, Path(args.results))


if __name__ == "__main__":
    main()
