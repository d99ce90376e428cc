"""Dataset format (bpy-free): manifest, per-sample folders written atomically, shards, and a reader.

Layout of a dataset folder DIR:

    DIR/manifest.json               renderer, spec, res, samples, seed, n, sensitivity, versions (no shard, no time)
    DIR/samples/0000042/            one folder per finished sample, renamed into place when complete
        source.png                  X: the source, 16-bit PNG, display sRGB (not with --no-source:
                                    manifest "source_images": false)
        render.png                  R(X, g)
        sens_00.png ... sens_MM.png R(X, g'_j) for each modelled j (with --sensitivity)
        mask.png                    hair: the hair mask X came with; lipstick with --masks: the lips mask
        params.json                 g raw and normalised, all parameters (unmodelled at defaults), g'_j,
                                    source id, Cycles seed

Sample i is a pure function of (seed, i), so shards are index ranges and a rerun skips finished folders.
"""

from __future__ import annotations

import json
import os
import shutil
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .errors import VtoError
from .specs import RendererSpec

FORMAT_VERSION = 1
SAMPLES_DIR = "samples"
TMP_PREFIX = ".tmp-"
DEFAULT_RES = 64
# Cycles samples per pixel; renders are denoised (OpenImageDenoise), which at 64 px and 8 spp is cleaner
# (seed-to-seed PSNR ~35 dB) and cheaper than 16 spp without it (~23 dB): benchmarks/results/render.md.
DEFAULT_SAMPLES = 16


def sample_name(index: int) -> str:
    """Folder name of sample `index`."""
    return f"{index:07d}"


def parse_shard(text: str) -> tuple[int, int]:
    """'i/K' -> (i, K) with 0 <= i < K."""
    try:
        index, count = (int(part) for part in text.split("/"))
    except ValueError:
        raise VtoError(f"--shard must look like i/K (e.g. 0/4), got '{text}'") from None
    if count < 1 or not 0 <= index < count:
        raise VtoError(f"--shard {text}: need 0 <= i < K")
    return index, count


def shard_from_env(environ=os.environ) -> tuple[int, int]:
    """The shard a scheduler assigned: SLURM array or Kubernetes indexed job; (0, 1) when neither is set."""
    if "SLURM_ARRAY_TASK_ID" in environ:
        index, count = environ["SLURM_ARRAY_TASK_ID"], environ.get("SLURM_ARRAY_TASK_COUNT")
        offset = int(environ.get("SLURM_ARRAY_TASK_MIN", "0"))
        name = "SLURM_ARRAY_TASK_COUNT"
    elif "JOB_COMPLETION_INDEX" in environ:
        index, count, offset = environ["JOB_COMPLETION_INDEX"], environ.get("VTO_SHARD_COUNT"), 0
        name = "VTO_SHARD_COUNT"
    else:
        return 0, 1
    if count is None:
        raise VtoError(f"a scheduler index is set but {name} is not: cannot tell the number of shards")
    return parse_shard(f"{int(index) - offset}/{count}")


def shard_range(n: int, shard: tuple[int, int]) -> range:
    """Contiguous indices of shard (i, K) out of n samples; the K ranges tile range(n)."""
    index, count = shard
    return range(n * index // count, n * (index + 1) // count)


def file_digest(path: str | os.PathLike) -> str:
    """The first 16 hex digits of a file's SHA-256: what a manifest names an input file by."""
    import hashlib

    return hashlib.sha256(Path(path).read_bytes()).hexdigest()[:16]


def write_manifest(root: Path, manifest: dict) -> None:
    """Write DIR/manifest.json atomically, or check that an existing one holds the same settings.

    A larger n grows the dataset: sample i is a function of (seed, i) alone, so the finished samples stay valid.
    """
    root = Path(root)
    path = root / "manifest.json"
    if path.exists():
        existing = read_manifest(root)
        changed = sorted(k for k in set(existing) | set(manifest) if existing.get(k) != manifest.get(k))
        if changed == ["n"] and manifest["n"] > existing["n"]:
            write_text_atomic(path, json.dumps(manifest, indent=1, sort_keys=True) + "\n")
            return
        if changed == ["n"]:
            raise VtoError(f"{root} already holds a dataset of {existing['n']} samples; --n can grow it, not shrink it")
        if changed:
            raise VtoError(f"{root} holds a dataset made with other settings ({', '.join(changed)}); use a new --out")
        return
    write_text_atomic(path, json.dumps(manifest, indent=1, sort_keys=True) + "\n")


def read_manifest(root: Path) -> dict:
    """DIR/manifest.json as a dict."""
    path = Path(root) / "manifest.json"
    try:
        return json.loads(path.read_text())
    except FileNotFoundError:
        raise VtoError(f"{root} is not a dataset: no manifest.json") from None
    except json.JSONDecodeError as exc:
        raise VtoError(f"{path} is corrupt: {exc}") from None


def write_text_atomic(path: Path, text: str) -> None:
    """Write `text` to a temporary file beside `path`, then move it into place: readers never see half a file."""
    tmp = path.with_name(f"{TMP_PREFIX}{os.getpid()}-{path.name}")
    tmp.write_text(text)
    os.replace(tmp, path)


def finished_indices(root: Path) -> set[int]:
    """Indices whose sample folder is in place."""
    folder = Path(root) / SAMPLES_DIR
    if not folder.is_dir():
        return set()
    return {int(entry.name) for entry in os.scandir(folder) if entry.name.isdigit()}


def temporary_prefix(index: int) -> str:
    """How the name of sample `index`'s folder being written begins (the writer's process id follows)."""
    return f"{TMP_PREFIX}{sample_name(index)}-"


def remove_stale_temporaries(root: Path, indices=None) -> int:
    """Delete the half-written folders a killed run left of samples `indices` (None: of every sample); returns how
    many. A shard passes its own: another shard may be writing its samples beside it, in folders of their own."""
    folder = Path(root) / SAMPLES_DIR
    stale = [p for p in folder.glob(TMP_PREFIX + "*")] if folder.is_dir() else []
    if indices is not None:
        owned = {temporary_prefix(i) for i in indices}
        stale = [p for p in stale if p.name[:len(temporary_prefix(0))] in owned]
    for path in stale:
        shutil.rmtree(path, ignore_errors=True)
    return len(stale)


class SampleWriter:
    """Collects one sample's files in a temporary folder and renames it into place on commit."""

    def __init__(self, root: Path, index: int):
        self.final = Path(root) / SAMPLES_DIR / sample_name(index)
        self.tmp = self.final.with_name(f"{temporary_prefix(index)}{os.getpid()}")
        shutil.rmtree(self.tmp, ignore_errors=True)
        self.tmp.mkdir(parents=True)

    def image(self, name: str, pixels: np.ndarray) -> None:
        """Write a display-sRGB image (H, W, 3) or mask (H, W) as a 16-bit PNG."""
        from .imageio import write_image

        write_image(self.tmp / f"{name}.png", pixels, bits=16)

    def params(self, record: dict) -> None:
        """Write params.json (sorted keys, so reruns give identical bytes)."""
        (self.tmp / "params.json").write_text(json.dumps(record, indent=1, sort_keys=True) + "\n")

    def commit(self) -> None:
        """Rename the folder into place (atomic on one filesystem). Where another process (an overlapping shard)
        committed the same sample first, its folder is kept: a sample is a pure function of (seed, index)."""
        try:
            os.replace(self.tmp, self.final)
        except OSError:
            if not self.final.is_dir():
                raise
            self.abort()

    def abort(self) -> None:
        """Drop what was written."""
        shutil.rmtree(self.tmp, ignore_errors=True)


@dataclass
class Sample:
    """One sample read back: images (H, W, 3) float32, vectors in the spec's order."""

    index: int
    source: np.ndarray | None  # None in a dataset made without source images (manifest "source_images": false)
    render: np.ndarray
    unit: np.ndarray  # (m,) normalised g
    raw: np.ndarray  # (m,) raw g
    sensitivity: np.ndarray | None  # (m, H, W, 3) renders R(X, g'_j)
    sensitivity_unit: np.ndarray | None  # (m, m) normalised g'_j, row j
    mask: np.ndarray | None
    record: dict


class DatasetReader:
    """Read a dataset without bpy: len(), reader[i] -> Sample for the finished samples, in index order."""

    def __init__(self, root: str | os.PathLike):
        self.root = Path(root)
        self.manifest = read_manifest(self.root)
        if self.manifest.get("format_version") != FORMAT_VERSION:
            raise VtoError(f"{root}: dataset format {self.manifest.get('format_version')}, this reader reads {FORMAT_VERSION}")
        self.spec: RendererSpec = RendererSpec.from_dict(self.manifest["spec"])
        self.has_sources: bool = self.manifest.get("source_images", True)
        self.indices = sorted(finished_indices(self.root))

    def __len__(self) -> int:
        return len(self.indices)

    def __getitem__(self, position: int) -> Sample:
        from .imageio import read_image

        index = self.indices[position]
        folder = self.root / SAMPLES_DIR / sample_name(index)
        record = json.loads((folder / "params.json").read_text())
        sensitivity = sensitivity_unit = mask = None
        if self.manifest["sensitivity"]:
            sensitivity = np.stack([read_image(folder / f"sens_{j:02d}.png")[0] for j in range(self.spec.size)])
            sensitivity_unit = np.array(record["sensitivity_unit"], np.float32)
        if (folder / "mask.png").exists():
            mask = read_image(folder / "mask.png")[0][..., 0]
        source = read_image(folder / "source.png")[0] if self.has_sources else None
        return Sample(index, source, read_image(folder / "render.png")[0],
                      np.array(record["unit"], np.float32), np.array(record["raw"]), sensitivity, sensitivity_unit,
                      mask, record)


class DatasetUnion:
    """Several datasets of one spec and size read as one (same interface as DatasetReader): positions run through
    them in the order given, so a training split's held-out tail comes from the last one."""

    def __init__(self, roots: list[str | os.PathLike]):
        self.parts = [DatasetReader(root) for root in roots]
        first = self.parts[0]
        for part in self.parts[1:]:
            for what, mine, theirs in (("spec", first.spec.to_dict(), part.spec.to_dict()),
                                       ("image size", first.manifest["res"], part.manifest["res"]),
                                       ("sensitivity renders", first.manifest["sensitivity"],
                                        part.manifest["sensitivity"])):
                if mine != theirs:
                    raise VtoError(f"{part.root} and {first.root} differ in their {what}: one training set needs one")
        self.root = " + ".join(str(part.root) for part in self.parts)  # for messages
        self.manifest, self.spec = first.manifest, first.spec
        self.has_sources = all(part.has_sources for part in self.parts)
        self.starts = np.cumsum([0] + [len(part) for part in self.parts])

    def __len__(self) -> int:
        return int(self.starts[-1])

    def __getitem__(self, position: int) -> Sample:
        part = int(np.searchsorted(self.starts, position, side="right")) - 1
        return self.parts[part][position - int(self.starts[part])]


def open_datasets(data: str | os.PathLike | list) -> DatasetReader | DatasetUnion:
    """A reader of one dataset folder, or of several as one."""
    if isinstance(data, (str, os.PathLike)):
        return DatasetReader(data)
    return DatasetReader(data[0]) if len(data) == 1 else DatasetUnion(data)
