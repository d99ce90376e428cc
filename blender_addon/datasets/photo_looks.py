"""Looks tried on real portraits (`vto dataset lipstick|eyeshadow --photos DIR`): the try-on renderer's products on
training faces, read as Match reads a photo, through the views a camera adds (the paper's real faces with the makeup
drawn on).

Each look: a face of DIR (consecutive looks share one, BLOCK at a time) and one of the product's regions on it (the lips;
the right or left eye's lid, by turns), the product tried on it (renderers.tryon, its bare render kept per face and
region), then a camera's view of the made-up photo: its exposure and white balance, a JPEG, the framing jittered as
landmarks jitter, and a mirror; then Match's reading (the photo's light read beside the lips and taken out, the region's
frame shrunk to the encoder's size, a left eye flipped). The same look's photo without the product is its source X.

Shapes: photos (H, W, 3) display sRGB in [0, 1]; crops res x res.
"""

from __future__ import annotations

import json
import math
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from vto_core.errors import VtoError
from vto_core.imageio import jpeg_round_trip, read_image, resize
from vto_core.inference import shrink
from vto_core.photo.framing import region_view, view_cut
from vto_core.photo.photo_light import light_of, relit
from vto_core.products import Product

from ..renderers.tryon import on_photo, photo_regions, product_ratio
from ..shipped import photo_reader

PHOTO_SUFFIXES = (".jpg", ".jpeg", ".png", ".tif", ".tiff")
TRAINING_SPLIT = "train"  # faces.json's split that may be trained on; held_out and evaluation faces never are
BLOCK = 32  # consecutive looks on one face: its regions are found and their bare renders made once per block
FRAME_RENDER = 96  # px: each region's frame is rendered at this size, then read at the dataset's (smaller) size
BARE_SEED = 0  # Cycles seed of every face's bare render
_VIEW_STREAM = 9

# The camera's views (uniform draws unless said)
EXPOSURE_STOPS = 0.3  # the whole photo brighter or darker, up to this many stops
WHITE_BALANCE = 0.1  # each channel's log gain, normal with this deviation (the light reader takes most of it out)
ZOOM = (0.9, 1.12)  # the frame this much larger or smaller than Match's, about its centre
SHIFT = 0.05  # and moved up to this share of its side each way
JPEG_CHANCE, JPEG_QUALITY = 0.7, (55, 95)
MIRROR_CHANCE = 0.5


def training_faces(folder: str | Path) -> list[Path]:
    """The portraits of `folder` that may be trained on: with a faces.json in it, those of its 'train' split only
    (data/faces: never a held-out or evaluation face); otherwise every photo in it. VtoError for none."""
    folder = Path(folder)
    listing = folder / "faces.json"
    if listing.is_file():
        entries = json.loads(listing.read_text())
        faces = [folder / Path(entry["file"]).name for entry in entries if entry.get("split") == TRAINING_SPLIT]
        faces = [path for path in faces if path.is_file()]
    else:
        faces = sorted(p for p in folder.iterdir() if p.suffix.lower() in PHOTO_SUFFIXES and not p.name.startswith("."))
    if not faces:
        raise VtoError(f"--photos {folder} holds no portrait to train on (JPEG, PNG or TIFF; with a faces.json, "
                       f"those of its '{TRAINING_SPLIT}' split)")
    return faces


@dataclass
class CameraView:
    """How one look's photo was taken and framed."""

    gains: tuple[float, float, float]  # linear, per channel: exposure x white balance
    jpeg_quality: int | None
    zoom: float
    shift: tuple[float, float]  # share of the frame's side, x and y
    mirror: bool


def camera_view(seed: int, index: int) -> CameraView:
    """Look `index`'s view: a pure function of (seed, index)."""
    rng = np.random.default_rng([seed, index, _VIEW_STREAM])
    exposure = 2.0 ** rng.uniform(-EXPOSURE_STOPS, EXPOSURE_STOPS)
    balance = np.exp(rng.normal(0.0, WHITE_BALANCE, 3))
    quality = int(rng.integers(JPEG_QUALITY[0], JPEG_QUALITY[1] + 1))
    jpeg = rng.uniform() < JPEG_CHANCE
    return CameraView(tuple(float(g) for g in exposure * balance), quality if jpeg else None,
                      float(rng.uniform(*ZOOM)), tuple(float(s) for s in rng.uniform(-SHIFT, SHIFT, 2)),
                      bool(rng.uniform() < MIRROR_CHANCE))


def face_index(seed: int, index: int, count: int) -> int:
    """Which of `count` faces look `index` is tried on: BLOCK consecutive looks each, blocks in a shuffled order."""
    block = index // BLOCK
    order = np.random.default_rng([seed, block // count]).permutation(count)
    return int(order[block % count])


def match_read(photo: np.ndarray, target, view: CameraView, res: int, scratch: Path) -> np.ndarray:
    """What Match reads of a made-up `photo` (H, W, 3) at `target`'s region (a renderers.tryon.PhotoRegion), seen
    through `view`: (res, res, 3) display. Only the part around the region (and the lips, beside which the light is
    read) is worked on."""
    found, region = target.found, target.region
    frame, size, _ = region_view(found, region)
    centre = frame @ np.array([size / 2, size / 2, 1.0])
    side = size * view.zoom
    jittered = frame.copy()
    jittered[:, :2] *= view.zoom
    jittered[:, 2] = centre + np.array(view.shift) * size - jittered[:, :2] @ np.array([size / 2, size / 2])
    reach = int(math.ceil(0.75 * side + size)) + 8
    height, width = photo.shape[:2]
    x0, y0 = (max(0, (int(c) - reach) // 8 * 8) for c in centre)  # on the JPEG's 8 px blocks
    x1, y1 = min(width, int(centre[0]) + reach), min(height, int(centre[1]) + reach)
    beside = photo_reader().light_mask((region, found), found.mask)
    if beside is not found.mask:  # the light is read beside the lips: the part reaches them and the skin around them
        rows, cols = np.nonzero(beside)
        grow = int(cols.max() - cols.min()) // 2 + 8
        x0, y0 = max(0, min(x0, (int(cols.min()) - grow) // 8 * 8)), max(0, min(y0, (int(rows.min()) - grow) // 8 * 8))
        x1, y1 = min(width, max(x1, int(cols.max()) + grow)), min(height, max(y1, int(rows.max()) + grow))
    part = relit(photo[y0:y1, x0:x1], np.asarray(view.gains))
    if view.jpeg_quality is not None:
        part = jpeg_round_trip(part, view.jpeg_quality, scratch)
    light = light_of(part, beside[y0:y1, x0:x1])
    jittered[:, 2] -= (x0, y0)
    image = view_cut(part, jittered, size, light)
    image = resize(shrink(image, res, res), res, res)
    return np.ascontiguousarray(image[:, ::-1] if view.mirror != region.mirrored else image)


class PhotoLooks:
    """Renders looks onto the faces of a --photos folder; keeps the last face's regions and bare renders."""

    def __init__(self, folder: str | Path, res: int, samples: int, seed: int, product: Product):
        self.faces = training_faces(folder)
        self.res, self.samples, self.seed, self.product = res, samples, seed, product
        self.scratch = Path(tempfile.mkdtemp(prefix="vto-photo-looks-"))
        self._face: tuple[int, list, list] | None = None
        self.unusable: set[int] = set()

    def face(self, number: int):
        """(the number of the face used, its regions (PhotoRegion) framed at FRAME_RENDER px, their bare renders or
        None): face `number`, or where the product cannot be tried on it (vto_core's 'no face found ...', eyes hidden),
        the next one where it can."""
        for step in range(len(self.faces)):
            candidate = (number + step) % len(self.faces)
            if self._face is not None and self._face[0] == candidate:
                return self._face
            if candidate in self.unusable:
                continue
            try:
                targets = photo_regions(read_image(self.faces[candidate])[0], self.product, FRAME_RENDER)
                self._face = (candidate, targets, [None] * len(targets))
                return self._face
            except VtoError:
                self.unusable.add(candidate)
        raise VtoError(f"--photos: no {self.product.region} can be tried on any of the {len(self.faces)} portraits")

    def look(self, index: int, values: dict[str, float], source_image: bool
             ) -> tuple[np.ndarray | None, np.ndarray, dict]:
        """Look `index` wearing `values`: (its source X, the made-up photo as Match reads it, what the record notes)."""
        number, targets, bares = self.face(face_index(self.seed, index, len(self.faces)))
        which = index % len(targets)  # the regions by turns (the lips: the one)
        target = targets[which]
        ratio, bares[which] = product_ratio(target, values, self.samples, index, bare=bares[which], bare_seed=BARE_SEED)
        view = camera_view(self.seed, index)
        worn = on_photo(target.photo, target.found, target.to_frame, ratio, values[self.product.coverage])
        render = match_read(worn, target, view, self.res, self.scratch)
        source = match_read(target.photo, target, view, self.res, self.scratch) if source_image else None
        notes = {"source": number, "face": self.faces[number].name, "view": view.__dict__}
        if len(targets) > 1:
            notes["region"] = which
        return source, render, notes
