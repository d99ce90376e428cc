"""Read a face in a photo: MediaPipe's BlazeFace detector and 468-point face mesh on onnxruntime, shared by the lips
(vto_core.photo.lips_locator) and the hair (vto_core.photo.hair_locator).

The models are blender_addon/models/face_detector.onnx and face_landmarks.onnx (model card: face_locator.md, made by
scripts/convert_face_models.py). numpy only at import; onnxruntime is imported when a FaceReader is made. All the
resampling is numpy (strided block means, then bilinear sampling through an affine map), so this module runs inside
Blender's extension, which has neither OpenImageIO's resize nor scipy.

Coordinates: x, y in pixels from the top-left corner of the image; pixel (i, j) covers [i, i+1) x [j, j+1), so its
centre is at (i + 0.5, j + 0.5).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import VtoError
from ..inference import cpu_session, file_key

DETECTOR_SIZE = 128  # BlazeFace short range: (1, 3, 128, 128) in [-1, 1]
MESH_SIZE = 192  # face mesh: (1, 3, 192, 192) in [0, 1]
ANCHOR_STRIDES = (8, 16, 16, 16)  # MediaPipe's SSD anchor options for face_detection_short_range
MIN_DETECTION_SCORE = 0.5
NMS_OVERLAP = 0.3  # boxes overlapping more (IoU) merge into one face (weighted NMS, as MediaPipe)
RAW_SCORE_LIMIT = 80.0
# The mesh's face-presence probability (sigmoid of its logit output) below which a detection is no face. MediaPipe
# keeps 0.5; here real faces score >= 0.99 and a cat's face 0.55 (face_locator.md).
MIN_FACE_SCORE = 0.75
ROI_SCALE = 1.5  # the mesh reads the detection box enlarged this much, made square on its longer side
RIGHT_EYE_CORNER, LEFT_EYE_CORNER = 33, 263  # mesh landmarks: the outer eye corners, image left then right
RIGHT_MOUTH_CORNER, LEFT_MOUTH_CORNER = 61, 291  # the mouth's corners, image left then right (upright)
# np.rot90's quarter turns (anticlockwise) of a photo read again when it shows no face upright, or one upside down: a
# photo on its side or upside down, which BlazeFace, trained on faces near upright, does not see (or sees in part).
QUARTER_TURNS = (1, 2, 3)
REFINE_PASSES = 6  # mesh passes on the region the last landmarks give, while the roll still moves by ...
SETTLED_ROLL = math.radians(5)  # ... more than this (a face turned far from the detector's view settles in 2-3) ...
# ... or, for a rolled face, its size by more than this share: the detector's upright box of a rolled face is too large,
# and each pass on the region the last landmarks give shrinks the mesh about half the way back (a portrait tilted 30
# degrees read 10 % wide after its roll settled, which moved its eye-shadow estimate by 2 CIEDE2000).
SETTLED_SIZE = 0.02
# The mesh's face logit (before its sigmoid) under which a reading may be upside down: on the 18 benchmark portraits a
# face read the right way up scores 39-55; turned 180 degrees and read upright, 5.6 at most (31-44 once turned back).
SURE_FACE_LOGIT = 20.0
MAX_FACES_CHECKED = 8  # detections the mesh looks at, largest first (each ~3 ms)
RIGHT_EYE, LEFT_EYE = 0, 1  # detector keypoints: the subject's right eye (image left), left eye; then nose, mouth...
TILE_GRIDS = (2, 3)  # the second detector pass, when the whole image shows no face: 2 x 2, then 3 x 3 squares
MIN_TILED_SIDE = 256  # px: smaller images hold no face too small for the whole-image pass
SMALL_FACE = 0.15  # a face box under this share of the image's longer side sends the detector over the squares too
TAPS = 4  # strided samples per block side when a large image is reduced (TAPS**2 per output pixel)

@dataclass
class Detection:
    """One face from the detector, in image pixels."""

    score: float
    box: np.ndarray  # (4,) xmin, ymin, xmax, ymax
    keypoints: np.ndarray  # (6, 2) x, y: right eye, left eye, nose tip, mouth, right and left tragion

    @property
    def area(self) -> float:
        """The box's area in pixels."""
        return float((self.box[2] - self.box[0]) * (self.box[3] - self.box[1]))

    @property
    def side(self) -> float:
        """The box's longer side in pixels."""
        return float(max(self.box[2] - self.box[0], self.box[3] - self.box[1]))


@dataclass
class FaceRead:
    """The largest face FaceReader.read found in an image."""

    landmarks: np.ndarray  # (468, 2) float32 the face mesh in image pixels
    score: float  # the mesh's face probability
    faces: int  # faces found (detections the face mesh confirms)
    box: tuple[float, float, float, float]  # x, y, w, h of the detector's box of the face
    depth: np.ndarray | None = None  # (468,) float32 each landmark's depth in image pixels, nearer the camera lower

    @property
    def note(self) -> str:
        """'' or a sentence for the user when there were several faces."""
        return f"{self.faces} faces found: the largest is used" if self.faces > 1 else ""


def sigmoid(logits: np.ndarray) -> np.ndarray:
    """Logistic function of logits clipped to +-RAW_SCORE_LIMIT (no overflow)."""
    return 1.0 / (1.0 + np.exp(-np.clip(logits, -RAW_SCORE_LIMIT, RAW_SCORE_LIMIT)))


def ssd_anchors(size: int = DETECTOR_SIZE, strides: tuple[int, ...] = ANCHOR_STRIDES) -> np.ndarray:
    """(896, 2) anchor centres x, y in [0, 1], MediaPipe's SsdAnchorsCalculator order (fixed size 1, aspect 1, two
    anchors per layer, layers of equal stride sharing one grid)."""
    anchors = []
    for stride in sorted(set(strides)):
        per_cell = 2 * strides.count(stride)
        cells = size // stride
        centres = (np.arange(cells, dtype=np.float32) + 0.5) / cells
        grid_y, grid_x = np.meshgrid(centres, centres, indexing="ij")
        anchors.append(np.repeat(np.stack([grid_x.ravel(), grid_y.ravel()], 1), per_cell, axis=0))
    return np.concatenate(anchors)


ANCHORS = ssd_anchors()


def decode_detections(regressors: np.ndarray, logits: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The detector's raw outputs (896, 16), (896,) -> scores (896,), boxes (896, 4) xmin ymin xmax ymax and
    keypoints (896, 6, 2), all in [0, 1] of the detector's input square."""
    raw = regressors.reshape(-1, 8, 2).astype(np.float64) / DETECTOR_SIZE
    centre, half = raw[:, 0] + ANCHORS, raw[:, 1] / 2
    boxes = np.concatenate([centre - half, centre + half], axis=1)
    return sigmoid(logits.astype(np.float64)), boxes, raw[:, 2:] + ANCHORS[:, None]


def box_area(boxes: np.ndarray) -> np.ndarray:
    """Areas of boxes (..., 4) xmin ymin xmax ymax -> (...); 0 for empty or inverted boxes."""
    return np.clip(boxes[..., 2] - boxes[..., 0], 0, None) * np.clip(boxes[..., 3] - boxes[..., 1], 0, None)


def box_overlap(box: np.ndarray, boxes: np.ndarray) -> np.ndarray:
    """IoU of one box (4,) with boxes (N, 4), all xmin ymin xmax ymax -> (N,); 0 where the union is empty."""
    width = np.clip(np.minimum(box[2], boxes[:, 2]) - np.maximum(box[0], boxes[:, 0]), 0, None)
    height = np.clip(np.minimum(box[3], boxes[:, 3]) - np.maximum(box[1], boxes[:, 1]), 0, None)
    inter = width * height
    union = box_area(box) + box_area(boxes) - inter
    return np.where(union > 0, inter / np.where(union > 0, union, 1.0), 0.0)


def weighted_nms(scores: np.ndarray, boxes: np.ndarray, keypoints: np.ndarray,
                 min_score: float = MIN_DETECTION_SCORE, overlap: float = NMS_OVERLAP) -> list[Detection]:
    """MediaPipe's weighted non-maximum suppression: the best box and all it overlaps merge, weighted by score.

    scores (N,), boxes (N, 4), keypoints (N, 6, 2) -> detections, best first (coordinates as given)."""
    keep = (scores > min_score) & (boxes[:, 2] > boxes[:, 0]) & (boxes[:, 3] > boxes[:, 1])
    order = np.flatnonzero(keep)[np.argsort(-scores[keep], kind="stable")]
    detections = []
    while order.size:
        best = order[0]
        close = box_overlap(boxes[best], boxes[order]) > overlap
        members, order = order[close | (order == best)], order[~close & (order != best)]
        weights = scores[members] / scores[members].sum()
        detections.append(Detection(float(scores[best]), weights @ boxes[members],
                                    np.tensordot(weights, keypoints[members], axes=1)))
    return detections


ONE_BITS = int(np.array(1.0, np.float32).view(np.uint32))  # 0x3F800000


def clean(image: np.ndarray) -> np.ndarray:
    """(..., C) -> float32 in [0, 1]: NaN and -inf as 0, +inf as 1, HDR values clipped. (fmax and fmin pass over a
    NaN to the bound: two passes, where nan_to_num and clip take six and three copies.)"""
    return np.fmin(np.fmax(image, 0.0), 1.0).astype(np.float32, copy=False)


def is_clean(image: np.ndarray) -> bool:
    """Whether `image` is float32 with every value in [0, 1] (what clean gives), in one pass: read as unsigned
    integers, the floats in [+0, 1] are exactly those up to 1.0's bits (a negative one, -0 included, has the top bit
    set; NaN and infinity lie above)."""
    return image.dtype == np.float32 and image.size > 0 and int(image.view(np.uint32).max()) <= ONE_BITS


def clean_photo(image: np.ndarray) -> np.ndarray:
    """clean(image) for a whole photo, without a copy where there is nothing to clean: the image itself where it is
    float32 with every value in [0, 1] (a 64-megapixel photo is 768 MB a copy); else a cleaned float32 copy."""
    image = np.asarray(image)
    return image if is_clean(image) else clean(np.asarray(image, np.float32))


def reduce(image: np.ndarray, factor: int) -> np.ndarray:
    """(H, W, C) -> (H // factor, W // factor, C) float32 cleaned: each block of factor x factor pixels as the mean of
    up to TAPS x TAPS evenly spread pixels of it (the exact block mean when factor <= TAPS). The remainder rows and
    columns at the bottom and right are dropped, so reduced pixel i covers source pixels [i * factor, (i+1) * factor).
    Only the taps' rows are read: a 12-megapixel photo reduced 30 times reads a tenth of its rows."""
    if factor <= 1:
        return clean(image)
    rows, cols = image.shape[0] // factor, image.shape[1] // factor
    taps = min(factor, TAPS)
    offsets = np.unique(((np.arange(taps) + 0.5) * factor / taps).astype(int))
    # The taps' rows summed first (contiguous runs), then the taps' columns of that sum: the same taps as summing each
    # strided tap, in half the time.
    lines = [image[dy::factor][:rows, :cols * factor] for dy in offsets]
    if not all(is_clean(line) for line in lines):  # one check over the rows read saves cleaning each
        lines = [clean(line) for line in lines]
    summed = lines[0].copy()
    for line in lines[1:]:
        summed += line
    # The taps' columns summed by einsum (the same sums; on one channel, to a float32 ulp): numpy's strided adds step
    # a pixel's three floats at a time, at twice the cost (a product with a 0/1 matrix was faster still, but BLAS's
    # threads stalled a busy machine: 1.7 times the strided adds' time under a second job).
    blocks = summed.reshape(rows * cols, factor, image.shape[2])
    total = np.einsum("rfc->rc", blocks if offsets.size == factor else blocks[:, offsets])
    return total.reshape(rows, cols, image.shape[2]) / np.float32(offsets.size ** 2)


def sample_bilinear(image: np.ndarray, xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
    """(h, w, C) sampled at continuous points xs, ys (...) (pixel i's centre at i + 0.5) -> (C, ...) float32,
    channels first; black (0) outside the image, blending into it over the border pixel. A grid (rows, cols) whose xs
    vary along its columns only and ys along its rows only (an axis-aligned map) is sampled a row, then a column, at a
    time: the same values for a third of the work."""
    height, width, channels = image.shape
    # A border of zeros: every neighbour outside the image reads 0 once its index is clipped into the border.
    padded = np.zeros((channels, height + 2, width + 2), np.float32)
    padded[:, 1:-1, 1:-1] = image.transpose(2, 0, 1)
    if xs.ndim == 2 and (xs == xs[:1]).all() and (ys == ys[:, :1]).all():
        top, bottom, wy = bilinear_taps(ys[:, 0], height)
        rows = padded[:, top] * (1 - wy)[:, None] + padded[:, bottom] * wy[:, None]
        left, right, wx = bilinear_taps(xs[0], width)
        return np.ascontiguousarray(rows[:, :, left] * (1 - wx) + rows[:, :, right] * wx)
    flat = padded.reshape(channels, -1)
    left, right, wx = bilinear_taps(xs.ravel(), width)
    top, bottom, wy = bilinear_taps(ys.ravel(), height)
    top, bottom = top * (width + 2), bottom * (width + 2)
    upper = np.take(flat, top + left, axis=1) * (1 - wx) + np.take(flat, top + right, axis=1) * wx
    lower = np.take(flat, bottom + left, axis=1) * (1 - wx) + np.take(flat, bottom + right, axis=1) * wx
    return (upper * (1 - wy) + lower * wy).reshape((channels,) + xs.shape)


def bilinear_taps(points: np.ndarray, size: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Continuous coordinates (N,) along an axis of `size` pixels (pixel i's centre at i + 0.5) -> (the lower and the
    upper neighbour's index in the axis padded by a pixel each side (N,) intp, the upper one's weight (N,) float32)."""
    padded = points.astype(np.float32) + np.float32(0.5)  # coordinates in the padded axis's pixel-index space
    low = np.floor(padded)
    return (np.clip(low, 0, size + 1).astype(np.intp), np.clip(low + 1, 0, size + 1).astype(np.intp),
            padded - low)


def warp(image: np.ndarray, matrix: np.ndarray, size: int, repeat_edges: bool = False) -> np.ndarray:
    """(H, W, 3) seen through an affine map -> (3, size, size) float32 in [0, 1], channels first; black beyond the
    image, or with `repeat_edges` its edge pixels repeated there.

    matrix (2, 3) maps output coordinates (u, v) (pixel centres at +0.5) to image coordinates. The part of the image
    that the output covers is first reduced (`reduce`) so that the bilinear step shrinks by less than 2: cheap and
    free of aliasing at any image size."""
    scale = math.sqrt(abs(np.linalg.det(matrix[:, :2])))
    factor = max(1, int(scale))
    corners = matrix @ np.array([[0, size, 0, size], [0, 0, size, size], [1, 1, 1, 1]], np.float64)
    x0, y0 = (max(0, int(math.floor(v)) - factor) for v in corners.min(axis=1))
    x1, y1 = (min(n, int(math.ceil(v)) + factor) for v, n in zip(corners.max(axis=1), image.shape[1::-1]))
    if x1 - x0 < factor or y1 - y0 < factor:  # the output lies wholly outside the image
        return np.zeros((3, size, size), np.float32)
    region = reduce(image[y0:y1, x0:x1], factor)
    centres = np.arange(size, dtype=np.float64) + 0.5
    u, v = np.meshgrid(centres, centres)
    xs = (matrix[0, 0] * u + matrix[0, 1] * v + matrix[0, 2] - x0) / factor
    ys = (matrix[1, 0] * u + matrix[1, 1] * v + matrix[1, 2] - y0) / factor
    if repeat_edges:  # a point beyond the region reads the nearest edge pixel's centre
        xs, ys = np.clip(xs, 0.5, region.shape[1] - 0.5), np.clip(ys, 0.5, region.shape[0] - 0.5)
    return np.clip(sample_bilinear(region, xs, ys), 0.0, 1.0)


def letterbox_matrix(height: int, width: int, size: int = DETECTOR_SIZE) -> np.ndarray:
    """(2, 3) map from a size x size square to the image, letterboxed: the image's longer side spans the square,
    centred, the rest black (as MediaPipe pads the detector's input)."""
    side = max(height, width)
    return np.array([[side / size, 0.0, (width - side) / 2], [0.0, side / size, (height - side) / 2]])


def square_matrix(centre: np.ndarray, side: float, angle: float, size: int) -> np.ndarray:
    """(2, 3) map from a size x size square to a square of `side` px centred on `centre`, turned by `angle` radians
    (clockwise on screen, y pointing down), as MediaPipe's rotated region of interest."""
    cos, sin = math.cos(angle) * side / size, math.sin(angle) * side / size
    rotation = np.array([[cos, -sin], [sin, cos]])
    return np.concatenate([rotation, (centre - rotation @ np.array([size / 2, size / 2]))[:, None]], axis=1)


def apply_matrix(matrix: np.ndarray, points: np.ndarray) -> np.ndarray:
    """(2, 3) affine map applied to points (..., 2) -> (..., 2)."""
    return points @ matrix[:, :2].T + matrix[:, 2]


def face_region(detection: Detection) -> tuple[np.ndarray, float, float]:
    """A detection -> the mesh's region: centre (2,), side in px, angle in radians (MediaPipe's
    DetectionsToRects with the eyes as rotation keypoints, then RectTransformation with scale 1.5, square long)."""
    box = detection.box
    centre = np.array([(box[0] + box[2]) / 2, (box[1] + box[3]) / 2])
    side = ROI_SCALE * max(box[2] - box[0], box[3] - box[1])
    (x0, y0), (x1, y1) = detection.keypoints[RIGHT_EYE], detection.keypoints[LEFT_EYE]
    angle = -math.atan2(y0 - y1, x1 - x0)
    return centre, float(side), angle - 2 * math.pi * math.floor((angle + math.pi) / (2 * math.pi))


def roll_of(landmarks: np.ndarray) -> float:
    """The face's roll in radians, clockwise on screen (0 upright, +-pi upside down), from its (468, 2) landmarks:
    the mean direction of the line through the outer eye corners and of the line through the mouth's corners."""
    lines = [landmarks[end].astype(np.float64) - landmarks[start]
             for start, end in ((RIGHT_EYE_CORNER, LEFT_EYE_CORNER), (RIGHT_MOUTH_CORNER, LEFT_MOUTH_CORNER))]
    direction = sum(line / max(float(np.hypot(*line)), 1e-9) for line in lines)
    return math.atan2(float(direction[1]), float(direction[0]))


def face_size(landmarks: np.ndarray) -> float:
    """A face's size in pixels from its (468, 2) landmarks, the same at any roll: det(cov(landmarks)) ** (1/4), the
    geometric mean of the landmarks' spreads along their two principal axes."""
    return float(np.linalg.det(np.cov(landmarks.astype(np.float64), rowvar=False))) ** 0.25


def turned_back(face: FaceRead, quarter_turns: int, shape: tuple[int, int]) -> FaceRead:
    """A face read in np.rot90(image, quarter_turns) -> the same face in the image of (height, width) `shape`."""
    height, width = shape
    back = {1: lambda p: np.stack([width - p[:, 1], p[:, 0]], 1),
            2: lambda p: np.stack([width - p[:, 0], height - p[:, 1]], 1),
            3: lambda p: np.stack([p[:, 1], height - p[:, 0]], 1)}[quarter_turns % 4]
    x, y, w, h = face.box
    corners = back(np.array([[x, y], [x + w, y + h]], np.float64))
    low, high = corners.min(axis=0), corners.max(axis=0)
    return FaceRead(back(face.landmarks.astype(np.float64)).astype(np.float32), face.score, face.faces,
                    (float(low[0]), float(low[1]), float(high[0] - low[0]), float(high[1] - low[1])), face.depth)


def turn_between(a: float, b: float) -> float:
    """a - b in radians, wrapped into [-pi, pi)."""
    return (a - b + math.pi) % (2 * math.pi) - math.pi


def landmarks_region(landmarks: np.ndarray) -> tuple[np.ndarray, float, float]:
    """The mesh's (468, 2) landmarks -> the region for a second mesh pass: centre (2,), side px, angle rad (as
    MediaPipe's landmarks-to-ROI: turned by the line through the outer eye corners 33 and 263, the landmarks' box in
    that frame, enlarged 1.5x, square on its longer side)."""
    (x0, y0), (x1, y1) = landmarks[RIGHT_EYE_CORNER], landmarks[LEFT_EYE_CORNER]
    angle = -math.atan2(float(y0 - y1), float(x1 - x0))
    cos, sin = math.cos(angle), math.sin(angle)
    upright = landmarks.astype(np.float64) @ np.array([[cos, -sin], [sin, cos]])  # rotated by -angle
    low, high = upright.min(axis=0), upright.max(axis=0)
    centre = np.array([[cos, -sin], [sin, cos]]) @ ((low + high) / 2)  # back by +angle
    return centre, float(ROI_SCALE * (high - low).max()), angle


def polygon_mask(polygon: np.ndarray, x0: int, y0: int, width: int, height: int) -> np.ndarray:
    """(height, width) bool: the pixel centres of the box (x0, y0, width, height) inside the polygon (K, 2) by the
    even-odd rule."""
    start, end = polygon.astype(np.float64), np.roll(polygon, -1, axis=0).astype(np.float64)
    ys = y0 + np.arange(height) + 0.5
    xs = x0 + np.arange(width) + 0.5
    # Per edge and row: does the edge cross the row's line, and where (x). Edges along a row never cross it.
    straddles = (start[:, 1:2] > ys) != (end[:, 1:2] > ys)
    rise = np.where(end[:, 1:2] != start[:, 1:2], end[:, 1:2] - start[:, 1:2], 1.0)
    cross_x = start[:, 0:1] + (ys - start[:, 1:2]) * (end[:, 0:1] - start[:, 0:1]) / rise
    # A crossing counts for the pixels left of it (xs < cross_x): +1 from the row's first pixel, -1 from the first
    # pixel at or right of it, summed along the row (a few crossings a row, not every edge at every pixel).
    edge, row = np.nonzero(straddles)
    counts = np.zeros((height, width + 1), np.int32)
    np.add.at(counts, (row, 0), 1)
    crossing = cross_x[edge, row]
    np.add.at(counts, (row, np.where(np.isnan(crossing), 0, np.searchsorted(xs, crossing, side="left"))), -1)
    return np.cumsum(counts[:, :width], axis=1) % 2 == 1


def tight_box(mask: np.ndarray) -> tuple[int, int, int, int]:
    """x, y, w, h of the non-zero pixels of mask (H, W); (0, 0, 0, 0) when there are none."""
    rows, cols = np.flatnonzero(mask.any(axis=1)), np.flatnonzero(mask.any(axis=0))
    if not rows.size:
        return (0, 0, 0, 0)
    return (int(cols[0]), int(rows[0]), int(cols[-1] - cols[0] + 1), int(rows[-1] - rows[0] + 1))


def as_rgb(image: np.ndarray) -> np.ndarray:
    """(H, W), (H, W, 1), (H, W, 3) or (H, W, 4) -> (H, W, 3), integers scaled to [0, 1], a view where it can be;
    VtoError for other shapes."""
    image = np.asarray(image)
    if image.dtype.kind in "ui":  # 8- or 16-bit pixels
        image = image.astype(np.float32) / np.float32(np.iinfo(image.dtype).max)
    if image.ndim == 2:
        image = image[..., None]
    if image.ndim != 3 or image.shape[2] not in (1, 3, 4) or image.shape[0] < 1 or image.shape[1] < 1:
        raise VtoError(f"expected an (H, W, 3) image, got shape {image.shape}")
    if image.shape[2] == 1:
        return np.repeat(image, 3, axis=2)
    return image[..., :3]


class FaceReader:
    """The face detector and mesh, loaded once; read() finds the largest face of one image and its 468 landmarks."""

    def __init__(self, detector_path: str | Path, landmarks_path: str | Path, threads: int = 1, refine: bool = True):
        """refine: a second mesh pass on the region the first pass's landmarks give (MediaPipe's tracking step);
        it keeps faces turned 45-90 degrees within ~2 px where the detector's eye keypoints alone leave ~6 px."""
        self.refine = refine
        self.detector = cpu_session(detector_path, threads, "face model")
        self.mesh = cpu_session(landmarks_path, threads, "face model")
        self.detector_input = self.detector.get_inputs()[0].name
        self.mesh_input = self.mesh.get_inputs()[0].name

    def detect(self, image: np.ndarray, matrix: np.ndarray | None = None) -> list[Detection]:
        """Faces in (H, W, 3) seen through `matrix` (2, 3) (a square of the image mapped to the detector's input;
        default the whole image letterboxed), largest first, in image pixels."""
        matrix = letterbox_matrix(*image.shape[:2]) if matrix is None else matrix
        tensor = warp(image, matrix, DETECTOR_SIZE)[None] * np.float32(2) - np.float32(1)
        regressors, logits = self.detector.run(None, {self.detector_input: tensor})
        scores, boxes, keypoints = decode_detections(regressors[0], logits[0, :, 0])
        to_pixels = matrix.copy()
        to_pixels[:, :2] *= DETECTOR_SIZE  # the detections are in [0, 1] of the square
        found = []
        for detection in weighted_nms(scores, boxes, keypoints):
            corners = apply_matrix(to_pixels, detection.box.reshape(2, 2))  # swapped where the view is turned
            box = np.concatenate([corners.min(axis=0), corners.max(axis=0)])
            found.append(Detection(detection.score, box, apply_matrix(to_pixels, detection.keypoints)))
        return sorted(found, key=lambda d: -d.area)

    def detect_tiles(self, image: np.ndarray, found: list[Detection] = ()) -> list[Detection]:
        """Faces too small for the whole-image pass: the detector on overlapping squares of the letterboxed image
        (2 x 2 of 2/3 its side, then 3 x 3 of 1/2), merged across squares and with `found` (the whole-image pass's);
        largest first, in image pixels."""
        whole = letterbox_matrix(*image.shape[:2])
        found = list(found)
        for grid in TILE_GRIDS:
            side = 2.0 / (grid + 1)  # share of the letterboxed square; neighbours overlap by half a tile
            for row in range(grid):
                for col in range(grid):
                    tile = whole.copy()
                    tile[:, :2] *= side
                    tile[:, 2] = apply_matrix(whole, np.array([col, row]) * side / 2 * DETECTOR_SIZE)
                    found += self.detect(image, tile)
        if not found:
            return []
        merged = weighted_nms(np.array([d.score for d in found]), np.array([d.box for d in found]),
                              np.array([d.keypoints for d in found]), min_score=0.0)
        return sorted(merged, key=lambda d: -d.area)

    def accepted_faces(self, image: np.ndarray, faces: list[Detection]) -> list[tuple[Detection, np.ndarray, float]]:
        """The detections (largest first; at most MAX_FACES_CHECKED) that the mesh takes for faces, each with its
        (468, 3) landmarks (x, y, depth in image pixels) and its face logit (mesh_read)."""
        accepted = []
        for detection in faces[:MAX_FACES_CHECKED]:
            landmarks, logit = self.mesh_read(image, *face_region(detection))
            if sigmoid(np.float64(logit)) >= MIN_FACE_SCORE:
                accepted.append((detection, landmarks, logit))
        return accepted

    def mesh_read(self, image: np.ndarray, centre: np.ndarray, side: float, angle: float) -> tuple[np.ndarray, float]:
        """The mesh on the square region (centre (2,), side px, angle rad) of (H, W, 3) -> (468, 3) landmarks (x, y,
        depth; depth at the scale of x and y, nearer the camera lower) in image pixels and the face logit (before its
        sigmoid, clipped to +-RAW_SCORE_LIMIT)."""
        matrix = square_matrix(centre, side, angle, MESH_SIZE)
        points, logit = self.mesh.run(None, {self.mesh_input: warp(image, matrix, MESH_SIZE)[None]})
        points = points.reshape(-1, 3).astype(np.float64)
        clipped = float(np.clip(logit.ravel()[0], -RAW_SCORE_LIMIT, RAW_SCORE_LIMIT))
        depth = points[:, 2:] * (side / MESH_SIZE)
        return np.concatenate([apply_matrix(matrix, points[:, :2]), depth], axis=1).astype(np.float32), clipped

    def read(self, image: np.ndarray) -> FaceRead | None:
        """(H, W, 3) display sRGB (any size; NaN, inf and HDR values are cleaned; (H, W), (H, W, 4) and integer
        pixels taken too) -> the largest face the mesh accepts, or None.

        The image is read as it stands (read_view), and again turned a quarter and a half turn when that finds no face
        the mesh keeps, or only a face it had to turn over (an upside-down photo, whose faces the detector, trained on
        faces near upright, finds only in part); the surest reading is kept, and among equals the one whose view saw
        the face nearest upright."""
        image = as_rgb(image)
        first = self.read_view(image)
        readings = [] if first is None else [first]
        if first is None or not first[1] or first[2]:  # no face upright, one not kept, or one turned over
            for quarter_turns in QUARTER_TURNS:
                reading = self.read_view(np.rot90(image, quarter_turns), tiles=bool(readings))
                if reading is not None:
                    readings.append((turned_back(reading[0], quarter_turns, image.shape[:2]),) + reading[1:])
        kept = [reading for reading in readings if reading[1]] or readings
        if not kept:
            return None
        return max(kept, key=lambda r: (round(r[0].score, 2), -r[3]))[0]

    def read_view(self, image: np.ndarray, tiles: bool = True) -> tuple[FaceRead, bool, bool, float] | None:
        """The largest face of (H, W, 3) as it stands, or None: (the face, whether the mesh kept it on a second look,
        whether it was turned over, its roll's distance from upright in radians).

        The detector runs on the whole image, and again on overlapping squares when that finds no face or only a small
        one (where `tiles`: a turned view looks over squares only for an upside-down face's neighbours, since a photo
        with no face would cost 13 detector runs a view). The mesh checks each detection and reads the largest face it
        accepts (by its landmarks, which a tilt leaves as they are, unlike the detector's upright box), then again on
        the region its landmarks give until the face's roll settles (FaceReader.settled), so a face reads alike at any
        roll."""
        height, width = image.shape[:2]
        detections = self.detect(image)
        faces = self.accepted_faces(image, detections)
        largest = max((detection.side for detection, _, _ in faces), default=0.0)
        if tiles and max(height, width) >= MIN_TILED_SIDE and largest < SMALL_FACE * max(height, width):
            # No face, or a small one: a group or full-length photo, whose other faces the whole-image pass misses.
            tiled = self.accepted_faces(image, self.detect_tiles(image, detections))
            faces = tiled if len(tiled) >= len(faces) else faces
        if not faces:
            return None
        faces.sort(key=lambda face: -face_size(face[1][:, :2]))
        return self.settled(image, faces)

    def settled(self, image: np.ndarray, faces: list[tuple[Detection, np.ndarray, float]]
                ) -> tuple[FaceRead, bool, bool, float]:
        """The first of `faces` (accepted_faces) read again on the region its landmarks give until its roll settles,
        and turned over where the mesh is unsure (an upside-down face seen upright): (the face, whether the mesh kept
        it on the second look, whether it was turned over, its roll's distance from upright)."""
        detection, landmarks, logit = faces[0]
        kept, over = True, False
        if self.refine:
            landmarks, logit, kept = self.settle(image, landmarks, logit)
            if logit < SURE_FACE_LOGIT:
                centre, side, angle = landmarks_region(landmarks[:, :2])
                turned, turned_logit = self.mesh_read(image, centre, side, angle + math.pi)
                if turned_logit > logit:
                    (landmarks, logit, kept), over = self.settle(image, turned, turned_logit), True
        xmin, ymin, xmax, ymax = (float(v) for v in detection.box)
        box = (xmin, ymin, xmax - xmin, ymax - ymin)
        score = float(sigmoid(np.float64(logit)))
        face = FaceRead(landmarks[:, :2], score, len(faces), box, landmarks[:, 2])
        return face, kept, over, abs(roll_of(landmarks[:, :2]))

    def settle(self, image: np.ndarray, landmarks: np.ndarray, logit: float) -> tuple[np.ndarray, float, bool]:
        """(468, 3) landmarks (face logit `logit`) read again on the region they give, until the face lies within
        SETTLED_ROLL of upright, or, on a second pass or later, its roll moves less than that and its size less than
        SETTLED_SIZE (at most REFINE_PASSES; a face read upright costs one pass, as before): (the landmarks, the last
        kept pass's face logit, whether the mesh kept the face on the first pass)."""
        for attempt in range(REFINE_PASSES):
            refined, refined_logit = self.mesh_read(image, *landmarks_region(landmarks[:, :2]))
            if sigmoid(np.float64(refined_logit)) < MIN_FACE_SCORE:
                return landmarks, logit, attempt > 0
            roll = roll_of(refined[:, :2])
            moved = abs(turn_between(roll, roll_of(landmarks[:, :2])))
            grown = abs(face_size(refined[:, :2]) / face_size(landmarks[:, :2]) - 1.0)
            landmarks, logit = refined, refined_logit
            if abs(roll) < SETTLED_ROLL or (attempt and moved < SETTLED_ROLL and grown < SETTLED_SIZE):
                break  # upright; or rolled, and settled over two passes (a first pass may move it little by chance)
        return landmarks, logit, True

_READERS: dict[tuple, FaceReader] = {}


def cached_reader(detector_path: str | Path, landmarks_path: str | Path) -> FaceReader:
    """One FaceReader per pair of model files, made on first use and reused while neither file changes (keyed by
    resolved path, mtime and size, as vto_core.inference.cached_session)."""
    key = (file_key(detector_path, "face model"), file_key(landmarks_path, "face model"))
    reader = _READERS.get(key)
    if reader is None:
        reader = FaceReader(detector_path, landmarks_path)
        for stale in [k for k in _READERS if (k[0][0], k[1][0]) == (key[0][0], key[1][0])]:
            del _READERS[stale]
        _READERS[key] = reader
    return reader
