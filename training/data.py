"""Torch views of a `vto dataset` folder: train/validation split and batches of tensors."""

from __future__ import annotations

import numpy as np
import torch
from torch.utils.data import DataLoader, Dataset

from vto_core.dataset import DatasetReader
from vto_core.errors import VtoError

CACHE_BYTES = 2e9


def _chw(image: np.ndarray) -> torch.Tensor:
    """(H, W, 3) float -> (3, H, W) float32 tensor."""
    return torch.from_numpy(np.ascontiguousarray(image.transpose(2, 0, 1), dtype=np.float32))


class RenderDataset(Dataset):
    """Samples of a dataset folder as dicts of tensors: source, render, g (unit) and, if present, sensitivity."""

    def __init__(self, reader: DatasetReader, positions: list[int], need_sensitivity: bool = False,
                 cache_bytes: float = CACHE_BYTES):
        if need_sensitivity and not reader.manifest["sensitivity"]:
            raise VtoError(f"{reader.root} has no sensitivity renders; make it with `vto dataset ... --sensitivity`")
        self.reader, self.positions, self.need_sensitivity = reader, positions, need_sensitivity
        res = reader.manifest["res"]
        images_per_sample = 2 + (reader.spec.size if need_sensitivity else 0)
        # Decoded samples stay in memory when they fit: PNG decoding otherwise dominates small-model steps.
        self.cache = {} if len(positions) * images_per_sample * res * res * 3 * 4 <= cache_bytes else None

    def __len__(self) -> int:
        return len(self.positions)

    def __getitem__(self, item: int) -> dict[str, torch.Tensor]:
        if self.cache is not None and item in self.cache:
            return self.cache[item]
        sample = self.reader[self.positions[item]]
        batch = {"source": _chw(sample.source), "render": _chw(sample.render), "g": torch.from_numpy(sample.unit)}
        if self.need_sensitivity:
            batch["moved_render"] = torch.stack([_chw(image) for image in sample.sensitivity])  # (m, 3, H, W)
            batch["moved_g"] = torch.from_numpy(sample.sensitivity_unit)  # (m, m)
        if self.cache is not None:
            self.cache[item] = batch
        return batch


def split(reader: DatasetReader, val_fraction: float) -> tuple[list[int], list[int]]:
    """Positions of training and held-out samples (the held-out ones are the last by index)."""
    count = len(reader)
    if count < 2:
        raise VtoError(f"{reader.root} holds {count} finished samples; training needs at least 2")
    held_out = min(max(int(round(count * val_fraction)), 1 if val_fraction > 0 else 0), count - 1)
    return list(range(count - held_out)), list(range(count - held_out, count))


class EpochSampler(torch.utils.data.Sampler):
    """Sample positions forever, epoch after epoch, each epoch a permutation seeded by (seed, epoch).

    Starting at position `start` (= step x batch size) continues the order a run that reached that step had seen,
    without loading the samples before it, so a resumed run trains on exactly the batches an unbroken one would.
    """

    def __init__(self, size: int, seed: int, start: int = 0):
        self.size, self.seed, self.start = size, seed, start

    def __iter__(self):
        epoch, offset = divmod(self.start, self.size)
        while True:
            generator = torch.Generator().manual_seed(self.seed * 1_000_003 + epoch)
            yield from torch.randperm(self.size, generator=generator)[offset:].tolist()
            epoch, offset = epoch + 1, 0


def training_batches(dataset: RenderDataset, batch_size: int, seed: int, step: int = 0, num_workers: int = 0):
    """Endless training batches from optimiser step `step` on (see EpochSampler)."""
    batch_size = min(batch_size, len(dataset))
    sampler = EpochSampler(len(dataset), seed, step * batch_size)
    return iter(DataLoader(dataset, batch_size=batch_size, sampler=sampler, num_workers=num_workers))


def make_loader(dataset: RenderDataset, batch_size: int, seed: int, num_workers: int = 0, shuffle: bool = True):
    """A DataLoader whose shuffling depends only on `seed`; keeps the last partial batch."""
    generator = torch.Generator().manual_seed(seed)
    return DataLoader(dataset, batch_size=min(batch_size, len(dataset)), shuffle=shuffle, drop_last=False,
                      generator=generator, num_workers=num_workers)
