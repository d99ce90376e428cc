"""Torch views of a `vto dataset` folder: train/validation split and batches of tensors."""

from __future__ import annotations

import math

import numpy as np
import torch
from torch.utils.data import DataLoader, Dataset, DistributedSampler

from vto_core.dataset import DatasetReader
from vto_core.errors import VtoError

CACHE_BYTES = 2e9


def _chw(image: np.ndarray) -> torch.Tensor:
    """(H, W, 3) float -> (3, H, W) float32 tensor."""
    return torch.from_numpy(np.ascontiguousarray(image.transpose(2, 0, 1), dtype=np.float32))


class RenderDataset(Dataset):
    """Samples of a dataset folder as dicts of tensors: source (where the dataset has them), render, g (unit) and,
    if asked for, sensitivity."""

    def __init__(self, reader: DatasetReader, positions: list[int], need_sensitivity: bool = False,
                 cache_bytes: float = CACHE_BYTES, need_source: bool = True):
        if need_sensitivity and not reader.manifest["sensitivity"]:
            raise VtoError(f"{reader.root} has no sensitivity renders; make it with `vto dataset ... --sensitivity`")
        if need_source and not reader.has_sources:
            raise VtoError(f"{reader.root} was made with --no-source: it has no source images X, which the imitator "
                           "and the rendering loss need (train the encoder with --set loss=graphics)")
        self.reader, self.positions, self.need_sensitivity = reader, positions, need_sensitivity
        res = reader.manifest["res"]
        images_per_sample = (2 if reader.has_sources else 1) + (reader.spec.size if need_sensitivity else 0)
        # Decoded samples stay in memory when they fit: PNG decoding otherwise dominates small-model steps.
        self.cache = {} if len(positions) * images_per_sample * res * res * 3 * 4 <= cache_bytes else None

    def __len__(self) -> int:
        return len(self.positions)

    def __getitem__(self, item: int) -> dict[str, torch.Tensor]:
        if self.cache is not None and item in self.cache:
            return self.cache[item]
        sample = self.reader[self.positions[item]]
        batch = {"render": _chw(sample.render), "g": torch.from_numpy(sample.unit)}
        if sample.source is not None:
            batch["source"] = _chw(sample.source)
        if self.need_sensitivity:
            batch["moved_render"] = torch.stack([_chw(image) for image in sample.sensitivity])  # (m, 3, H, W)
            batch["moved_g"] = torch.from_numpy(sample.sensitivity_unit)  # (m, m)
        if self.cache is not None:
            self.cache[item] = batch
        return batch


def split(reader: DatasetReader, val_fraction: float, each: bool = True) -> tuple[list[int], list[int]]:
    """Positions of training and held-out samples: the last `val_fraction` of every folder (each) or of all of them
    together (the tail, whole folders of it when the last is small: a folder given last may never be trained on)."""
    count = len(reader)
    if count < 2:
        raise VtoError(f"{reader.root} holds {count} finished samples; training needs at least 2")
    starts = getattr(reader, "starts", [0, count]) if each else [0, count]
    val = []
    for start, end in zip(starts[:-1], starts[1:]):
        size = end - start
        val += range(end - min(int(round(size * val_fraction)), size - 1), end)
    if val_fraction > 0 and not val:
        val = [count - 1]
    held = set(val)
    return [i for i in range(count) if i not in held], val


def held_out_folders(reader, val_positions: list[int]) -> list[dict]:
    """Which folders the held-out looks come from: [{"folder", "held_out", "of"}], in the order given."""
    parts = getattr(reader, "parts", [reader])
    starts = getattr(reader, "starts", [0, len(reader)])
    counts = np.bincount(np.searchsorted(starts, val_positions, side="right") - 1, minlength=len(parts))
    return [{"folder": str(part.root), "held_out": int(n), "of": len(part)} for part, n in zip(parts, counts) if n]


def held_out_text(held: list[dict]) -> str:
    """One line for the log: 'held out for validation (not trained on): all 3000 of A, 600 of 3000 of B'."""
    words = [f"all {h['of']} of {h['folder']}" if h["held_out"] == h["of"] else f"{h['held_out']} of {h['of']} of "
             f"{h['folder']}" for h in held]
    return "held out for validation (not trained on): " + (", ".join(words) if words else "none")


class EpochSampler(torch.utils.data.Sampler):
    """This process's sample positions forever, epoch after epoch; each epoch a DistributedSampler shard.

    Epoch e is torch's DistributedSampler permutation for (seed, e), of which rank r takes every world_size-th
    position. `start` counts positions this process has already consumed (step x per-process batch): a resumed run
    continues the order an unbroken one saw without loading the samples before it. With world_size processes and a
    global batch B, the union of the ranks' batches at each step is the batch one process would draw with batch B
    (when the dataset size divides by world_size; otherwise DistributedSampler repeats a few samples per epoch).
    """

    def __init__(self, size: int, seed: int, start: int = 0, rank: int = 0, world_size: int = 1):
        self.shard = DistributedSampler(range(size), num_replicas=world_size, rank=rank, shuffle=True, seed=seed)
        self.start = start

    def __iter__(self):
        epoch, offset = divmod(self.start, len(self.shard))
        while True:
            self.shard.set_epoch(epoch)
            yield from list(self.shard)[offset:]
            epoch, offset = epoch + 1, 0


def per_process_batch(batch_size: int, dataset_size: int, world_size: int = 1) -> int:
    """The global batch (capped at the dataset size) split evenly over `world_size` processes."""
    batch_size = min(batch_size, dataset_size)
    if batch_size % world_size:
        raise VtoError(f"batch_size {batch_size} does not split evenly over {world_size} processes")
    return batch_size // world_size


def training_batches(dataset: RenderDataset, batch_size: int, seed: int, position: int = 0, num_workers: int = 0,
                     rank: int = 0, world_size: int = 1):
    """Endless batches for this process, from global sample `position` (= steps done x global batch) on."""
    local_batch = per_process_batch(batch_size, len(dataset), world_size)
    sampler = EpochSampler(len(dataset), seed, position // world_size, rank, world_size)
    return iter(DataLoader(dataset, batch_size=local_batch, sampler=sampler, num_workers=num_workers))


def make_loader(dataset: RenderDataset, batch_size: int, seed: int, num_workers: int = 0, shuffle: bool = True):
    """A DataLoader whose shuffling depends only on `seed`; keeps the last partial batch."""
    generator = torch.Generator().manual_seed(seed)
    return DataLoader(dataset, batch_size=min(batch_size, len(dataset)), shuffle=shuffle, drop_last=False,
                      generator=generator, num_workers=num_workers)


def _on_images(batch: dict, change) -> dict:
    """The batch with `change` applied to each of its 'source' and 'render' images (the others kept)."""
    return {**batch, **{k: change(batch[k]) for k in ("source", "render") if k in batch}}


def photo_views(batch: dict, max_tilt: float = 0.17, zoom: tuple[float, float] = (0.8, 1.25),
                max_blur: float = 1.0, max_noise: float = 0.02) -> dict:
    """What a photo of lips shows and a render does not, at random per sample: a tilt of up to `max_tilt` rad, the
    lips `zoom` times as large in the crop (edges repeated), a Gaussian blur of up to `max_blur` px and sensor noise
    of up to `max_noise` (std, display units). Tilt and zoom move 'source' and 'render' (B, 3, H, W) together; blur
    and noise touch the render only (the reference). Colour is kept: a constant image stays that constant."""
    render = batch["render"]
    count, device = len(render), render.device
    angle = (torch.rand(count, device=device) * 2 - 1) * max_tilt
    scale = torch.exp(torch.empty(count, device=device).uniform_(-math.log(zoom[1]), -math.log(zoom[0])))
    cos, sin = torch.cos(angle) * scale, torch.sin(angle) * scale
    theta = torch.stack([torch.stack([cos, -sin, torch.zeros_like(cos)], -1),
                         torch.stack([sin, cos, torch.zeros_like(cos)], -1)], 1)  # (B, 2, 3): output -> input
    grid = torch.nn.functional.affine_grid(theta, list(render.shape), align_corners=False)
    moved = _on_images(batch, lambda image: torch.nn.functional.grid_sample(image, grid, padding_mode="border",
                                                                            align_corners=False))
    sigma = torch.rand(count, device=device) * max_blur
    offsets = torch.arange(-2, 3, device=device, dtype=render.dtype)
    kernel = torch.exp(-0.5 * (offsets[None] / sigma.clamp_min(1e-3)[:, None]) ** 2)
    kernel = kernel / kernel.sum(dim=1, keepdim=True)  # (B, 5); sigma -> 0 gives the identity
    image = torch.nn.functional.pad(moved["render"], (2, 2, 2, 2), mode="replicate")
    image = sum(kernel[:, i, None, None, None] * image[..., i:i + image.shape[-2] - 4, :] for i in range(5))
    image = sum(kernel[:, i, None, None, None] * image[..., i:i + image.shape[-1] - 4] for i in range(5))
    noise = torch.randn_like(image) * (torch.rand(count, 1, 1, 1, device=device) * max_noise)
    return {**moved, "render": (image + noise).clamp(0.0, 1.0)}


def open_mouths(batch: dict, chance: float = 0.3) -> dict:
    """Open mouths with teeth, which the default lips scene never shows: with probability `chance` per sample, a row
    of teeth is painted over the mouth line (the darkest row near the centre of the render) of 'source' and 'render'
    (B, 3, H, W): a lens of off-white, shaded towards the corners and split by darker gaps, inside a rim of dark
    mouth. The lips' colour is not touched outside the lens; the parameters are kept."""
    render = batch["render"]
    count, _, height, width = render.shape
    device, dtype = render.device, render.dtype

    def uniform(low, high, *shape):
        return torch.empty(count, *shape, device=device, dtype=dtype).uniform_(low, high)

    band = slice(int(0.36 * height), max(int(0.6 * height), int(0.36 * height) + 1))
    middle = render[:, :, band, int(0.4 * width):max(int(0.6 * width), int(0.4 * width) + 1)].mean(dim=(1, 3))
    mouth_row = (middle.argmin(dim=1) + band.start).to(dtype) + 0.5  # (B,)
    rows = (torch.arange(height, device=device, dtype=dtype) + 0.5).view(1, -1, 1)
    cols = (torch.arange(width, device=device, dtype=dtype) + 0.5).view(1, 1, -1)
    x = (cols - width * (0.5 + uniform(-0.03, 0.03, 1, 1))) / width  # (B, 1, W)
    y = (rows - mouth_row.view(-1, 1, 1)) / height  # (B, H, 1), down is positive
    half_width, upper, lower = uniform(0.16, 0.32, 1, 1), uniform(0.02, 0.07, 1, 1), uniform(0.015, 0.06, 1, 1)

    def lens(grow):
        taper = (1 - (x / (half_width + grow)) ** 2).clamp_min(0)
        return (taper > 0) & (y >= -(upper + grow) * taper) & (y <= (lower + grow) * taper)

    teeth, rim = lens(0.0), lens(0.015)
    across = (x / half_width).clamp(-1, 1)
    shade = uniform(0.55, 1.0, 1, 1) * (1 - 0.6 * across**2)  # (B, 1, W): teeth darken into the mouth's corners
    tooth = half_width / uniform(3.0, 4.5, 1, 1)
    gap = torch.remainder(x / tooth + 0.5, 1.0) < 0.12

    def rgb(*values):
        return torch.tensor(values, device=device, dtype=dtype).view(1, 3, 1, 1)

    lit = (shade * torch.where(gap, 0.7, 1.0)).unsqueeze(1)  # (B, 1, 1, W)
    teeth_colour = (rgb(0.92, 0.88, 0.80) + uniform(-0.04, 0.04, 3, 1, 1)) * lit
    mouth_colour = rgb(0.25, 0.08, 0.08) * uniform(0.2, 1.0, 1, 1, 1)
    painted = (torch.rand(count, device=device) < chance).view(-1, 1, 1, 1)
    teeth, rim = (teeth.unsqueeze(1) & painted), (rim.unsqueeze(1) & painted)

    return _on_images(batch, lambda image: torch.where(teeth, teeth_colour, torch.where(rim, mouth_colour, image))
                      .clamp(0.0, 1.0))


def skin_texture(batch: dict, max_amplitude: float = 0.05) -> dict:
    """Pores and blotches, which the default scene's smooth skin and lips lack: 'source' and 'render' (B, 3, H, W)
    multiplied by 1 + a n, n a smooth zero-mean noise field of unit spread (fine, H/4 cells, and coarse, H/16),
    a up to `max_amplitude` per sample. Colour is kept on average; the parameters are kept."""
    render = batch["render"]
    count, _, height, width = render.shape
    noise = torch.zeros(count, 1, height, width, device=render.device, dtype=render.dtype)
    for cells in (max(height // 4, 1), max(height // 16, 1)):
        field = torch.randn(count, 1, cells, cells, device=render.device, dtype=render.dtype)
        noise = noise + torch.nn.functional.interpolate(field, size=(height, width), mode="bicubic",
                                                        align_corners=False)
    noise = noise / noise.flatten(1).std(dim=1).clamp_min(1e-6).view(-1, 1, 1, 1)
    gain = 1 + torch.rand(count, 1, 1, 1, device=render.device, dtype=render.dtype) * max_amplitude * noise
    return _on_images(batch, lambda image: (image * gain).clamp(0.0, 1.0))


def augment(batch: dict, max_shift: int = 3) -> dict:
    """Views the parameters do not change: each sample mirrored left-right with probability 1/2, then the whole batch
    shifted by up to `max_shift` px each way (wrapping); 'source' and 'render' (B, 3, H, W) move together."""
    first = batch["source"] if "source" in batch else batch["render"]
    mirrored = (torch.rand(len(first), device=first.device) < 0.5).view(-1, 1, 1, 1)
    dy, dx = (int(v) for v in torch.randint(-max_shift, max_shift + 1, (2,)))
    return _on_images(batch, lambda image: torch.roll(torch.where(mirrored, image.flip(-1), image), (dy, dx),
                                                      dims=(-2, -1)))


def encoder_views(batch: dict, config) -> dict:
    """The views an encoder trains on, as its config asks: open mouths and skin texture (mouth_views), photo_views,
    then augment's mirrored and shifted ones."""
    batch = skin_texture(open_mouths(batch)) if config.mouth_views else batch
    batch = photo_views(batch) if config.photo_views else batch
    return augment(batch) if config.augment else batch
