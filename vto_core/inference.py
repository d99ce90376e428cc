"""ONNX encoder inference with onnxruntime: session made once, CPU provider, few threads, no spinning."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from .errors import VtoError
from .specs import RendererSpec

METADATA_PREFIX = "vto."
INPUT_NAME = "image"
OUTPUT_NAME = "params_unit"


def import_onnxruntime():
    """The onnxruntime module; a VtoError of one line that says what to do when it is missing or cannot load."""
    try:
        import onnxruntime
    except ModuleNotFoundError as exc:
        if exc.name != "onnxruntime":  # onnxruntime is there but one of its own imports is not: a broken install
            raise VtoError(f"onnxruntime cannot load (no module {exc.name!r}): reinstall the Match from Photo "
                           "extension from the zip for this platform, or pip install onnxruntime") from None
        raise VtoError("onnxruntime is not installed for this Python: install the Match from Photo extension from "
                       "the zip for this platform (it carries onnxruntime), or pip install onnxruntime") from None
    except ImportError as exc:  # e.g. Windows: "DLL load failed" with an old Visual C++ runtime
        first = (str(exc).splitlines() or [""])[0]
        raise VtoError(f"onnxruntime cannot load ({first}): on Windows install the latest Microsoft Visual C++ "
                       "Redistributable, then restart Blender") from None
    return onnxruntime


def cpu_session(path: str | Path, threads: int, what: str = "model"):
    """An onnxruntime session of `path` on the CPU: `threads` intra-op threads, one inter-op, no spinning; one-line
    VtoErrors ('no {what} at ...', 'cannot load ...') for a missing or bad file."""
    ort = import_onnxruntime()
    path = Path(path)
    if not path.is_file():
        raise VtoError(f"no {what} at {path}")
    options = ort.SessionOptions()
    options.intra_op_num_threads = threads
    options.inter_op_num_threads = 1
    # Inside Blender a spinning thread pool would steal the UI's cores between calls.
    options.add_session_config_entry("session.intra_op.allow_spinning", "0")
    options.add_session_config_entry("session.inter_op.allow_spinning", "0")
    try:
        return ort.InferenceSession(str(path), options, providers=["CPUExecutionProvider"])
    except Exception as exc:  # onnxruntime raises its own exception types for bad files
        raise VtoError(f"cannot load {path} with onnxruntime: {str(exc).splitlines()[0]}") from None


class EncoderSession:
    """An exported encoder: image(s) -> parameters in raw units; refuses a model made for another spec."""

    def __init__(self, path: str | Path, expected_spec: RendererSpec | None = None, threads: int = 2):
        path = Path(path)
        self.session = cpu_session(path, threads, "encoder model")
        metadata = self.session.get_modelmeta().custom_metadata_map
        if f"{METADATA_PREFIX}spec" not in metadata:
            raise VtoError(f"{path} is not a VTO encoder (no {METADATA_PREFIX}spec metadata)")
        self.metadata = metadata
        self.spec = RendererSpec.from_dict(json.loads(metadata[f"{METADATA_PREFIX}spec"]))
        if expected_spec is not None and not self.spec.same_as(expected_spec):
            raise VtoError(
                f"{path.name} estimates {self.spec.renderer} [{', '.join(self.spec.modelled)}], not "
                f"{expected_spec.renderer} [{', '.join(expected_spec.modelled)}]")
        height, width = (int(v) for v in metadata[f"{METADATA_PREFIX}input_size"].split("x"))
        self.input_size = (height, width)

    def predict_unit_nchw(self, images: np.ndarray) -> np.ndarray:
        """images (N, 3, H, W) float32 in [0,1] at the model's size -> (N, m) normalised parameters (unclipped)."""
        images = np.ascontiguousarray(images, dtype=np.float32)
        if images.ndim != 4 or images.shape[1] != 3 or tuple(images.shape[2:]) != self.input_size:
            raise VtoError(f"encoder input must be (N, 3, {self.input_size[0]}, {self.input_size[1]}), got {images.shape}")
        if not np.isfinite(images).all():
            raise VtoError("encoder input holds NaN or inf pixels")
        return self.session.run([OUTPUT_NAME], {INPUT_NAME: images})[0]

    def prepare(self, image: np.ndarray) -> np.ndarray:
        """A display-sRGB image (H, W, 3), any size, HDR allowed -> (3, h, w) at the model's size, clipped to [0,1]."""
        from .imageio import resize

        image = np.asarray(image, dtype=np.float32)
        if image.ndim != 3 or image.shape[2] != 3:
            raise VtoError(f"expected an (H, W, 3) image, got shape {image.shape}")
        if tuple(image.shape[:2]) != self.input_size:
            image = resize(shrink(image, *self.input_size), *self.input_size)
        return np.clip(np.nan_to_num(image, nan=0.0, posinf=1.0, neginf=0.0), 0.0, 1.0).transpose(2, 0, 1)

    def predict(self, images: list[np.ndarray] | np.ndarray) -> list[dict[str, float]]:
        """Image(s) (H, W, 3) -> one dict of raw parameter values each (all parameters; unmodelled at defaults)."""
        if isinstance(images, np.ndarray) and images.ndim == 3:
            images = [images]
        unit = self.predict_unit_nchw(np.stack([self.prepare(image) for image in images]))
        return [self.spec.values(self.spec.denormalise(np.clip(row, 0.0, 1.0))) for row in unit]

    def predict_views(self, groups: list[list[np.ndarray]]) -> list[dict[str, float]]:
        """Groups of views (H, W, 3) of one product each (both eyes' lids) -> one dict of raw values a group: the mean
        of its views' estimates (mean_unit), all read in one run."""
        images = [image for views in groups for image in views]
        unit = np.clip(self.predict_unit_nchw(np.stack([self.prepare(image) for image in images])), 0.0, 1.0)
        ends = np.cumsum([len(views) for views in groups])
        return [self.spec.values(self.spec.denormalise(mean_unit(self.spec, rows)))
                for rows in np.split(unit, ends[:-1])]


def mean_unit(spec, unit: np.ndarray) -> np.ndarray:
    """(N, m) normalised estimates of one product -> (m,) their mean; a wrapping parameter's (hue) on the circle."""
    unit = np.asarray(unit)
    if len(unit) == 1:  # one view: its estimate, bit for bit
        return unit[0]
    mean = unit.astype(np.float64).mean(axis=0)
    for column, param in enumerate(spec.modelled_params):
        if param.wraps:
            angle = 2 * np.pi * unit[:, column]
            mean[column] = (np.arctan2(np.sin(angle).mean(), np.cos(angle).mean()) / (2 * np.pi)) % 1.0
    return mean


def shrink(image: np.ndarray, height: int, width: int) -> np.ndarray:
    """A very large (H, W, C) image reduced by block means of an integer factor, keeping at least twice
    (height, width): the fast first step before the area-filtered resize (OpenImageIO's resize takes about 25 s from
    8192x8192 to 64x64 on two cores, the block means about 1 s). Smaller images come back unchanged. The few rows and
    columns that do not fill a block are trimmed evenly from both sides."""
    factor = min(image.shape[0] // height, image.shape[1] // width) // 2
    if factor < 2:
        return image
    rows, cols = image.shape[0] // factor * factor, image.shape[1] // factor * factor
    top, left = (image.shape[0] - rows) // 2, (image.shape[1] - cols) // 2
    blocks = image[top:top + rows, left:left + cols].reshape(rows // factor, factor, cols // factor, factor, -1)
    return blocks.mean(axis=(1, 3), dtype=np.float32)


_SESSIONS: dict[tuple[str, int, int], EncoderSession] = {}


def file_key(path: str | Path, what: str = "model") -> tuple[str, int, int]:
    """(resolved path, mtime in ns, size) of a model file, what a cache of its sessions is keyed by: a retrained model
    written over the old one is loaded again; VtoError 'no {what} at ...' for a missing file."""
    path = Path(path).expanduser().resolve()
    if not path.is_file():
        raise VtoError(f"no {what} at {path}")
    stat = path.stat()
    return str(path), stat.st_mtime_ns, stat.st_size


def cached_session(path: str | Path) -> EncoderSession:
    """One EncoderSession per model file, made on first use and reused while the file is unchanged.

    Keyed by the resolved path, its mtime and its size: a retrained model written over the old one is loaded again.
    A file that fails to load is not cached (the next call tries again and says why again).
    """
    key = file_key(path, "encoder model")
    session = _SESSIONS.get(key)
    if session is None:
        session = EncoderSession(key[0])
        for stale in [k for k in _SESSIONS if k[0] == key[0]]:
            del _SESSIONS[stale]
        _SESSIONS[key] = session
    return session
