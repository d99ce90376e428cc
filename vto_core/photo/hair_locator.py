"""Find the hair in a portrait: the person (MediaPipe's selfie segmentation on onnxruntime) less the face, grown from
seeds wherever hair can start (above the forehead, beside the temples and cheeks, a fringe over the forehead) through
the pixels whose colour is the seeds' rather than the skin's, the clothes' or the background's (a Gaussian each in
CIELAB, fitted on this photo). A tight crop (eyebrows to chin) has no forehead in frame: its hair starts beside the
face.

The model is blender_addon/models/person_segmenter.onnx (model card: person_segmenter.md, made by
scripts/convert_selfie_model.py). The face comes from vto_core.photo.face_reader. numpy only at import (onnxruntime when
a HairLocator is made), and no scipy, so this runs inside Blender's extension. Coordinates as in face_reader.

All the work is done on the head's region at WORK_FACE_HEIGHT px per face height, then the hair's probability is
sampled back onto the photo's pixels of that region, so the cost does not grow with the photo.
"""

from __future__ import annotations

import functools
import itertools
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..colour import srgb_to_lab
from ..errors import VtoError
from ..inference import cpu_session, file_key
from .face_reader import (LEFT_EYE_CORNER, LEFT_MOUTH_CORNER, RIGHT_EYE_CORNER, RIGHT_MOUTH_CORNER, FaceRead, as_rgb,
                          polygon_mask, reduce, sample_bilinear, square_matrix, tight_box, warp)
from .photo_light import PhotoLight, neutral_photo

SEGMENTER_SIZE = 256  # selfie segmentation: (1, 3, 256, 256) display RGB in [0, 1] -> (1, 1, 256, 256) person
# MediaPipe's FACEMESH_FACE_OVAL, in order around the face; 10 is the top of the forehead, 152 the chin.
FACE_OVAL = [10, 338, 297, 332, 284, 251, 389, 356, 454, 323, 361, 288, 397, 365, 379, 378, 400, 377, 152, 148, 176,
             149, 150, 136, 172, 58, 132, 93, 234, 127, 162, 21, 54, 103, 67, 109]
FOREHEAD, CHIN, RIGHT_CHEEK, LEFT_CHEEK = 10, 152, 234, 454
BROWS = [70, 63, 105, 66, 107, 336, 296, 334, 293, 300]  # the eyebrows' upper edges
# The head's region, in face heights (forehead landmark to chin) up and down and face widths to each side of the
# face's centre: long hair falls past the chin to the shoulders.
REGION_UP, REGION_DOWN, REGION_SIDE = 1.0, 1.4, 1.6
WORK_FACE_HEIGHT = 56  # px per face height where the hair is found
# The seed: above the forehead landmark (which sits 0.1-0.25 face heights below the hairline) by this many face
# heights, within this many face widths of the face's centre line.
SEED_UP = (0.2, 0.38)
SEED_HALF_WIDTH = 0.3
# The seeds beside the face: a strip this many face widths outside the face oval on each side, from the eyes' height
# down to the mouth's (the temples and the cheeks; a strip that is mostly ear is the skin's colour, and refused).
SIDE_STRIP = (0.03, 0.2)
# A pixel of the fringe's seed (the face oval above the eyebrows) looks like the skin within this squared Mahalanobis
# distance of the skin's model (99 % of a Gaussian in 3 dimensions), and is left out of the seed.
SKIN_LIKE = 11.3
# The clothes' samples, face heights below the chin, within SEED_HALF_WIDTH of the centre line: the collar, the chest.
CLOTHES_BELOW = ((0.3, 0.6), (0.8, 2.0))
NECK_HALF_WIDTH = 0.4  # face widths: below the chin, hair is looked for only this far or further from the centre line
PERSON, BACKGROUND = 0.5, 0.1  # segmenter probabilities: the person at and above; the background below
HAIR_CANDIDATE = 0.25  # hair may reach where the person probability is this low (fine strands against the backdrop)
# A tight crop (less than CROP_SHARE of the head's region in the photo) fills the person model's input with a face,
# and the model takes the hair at the crop's edges for the backdrop. The crop is shown to it again, zoomed out
# CROP_ZOOM times with its edges repeated beyond the photo, where it sees a head with hair. Hair grows where either
# view sees the person, but starts only where the crop alone does: the zoomed-out view also takes a backdrop at the
# crop's edge for a body (a flag, a wall), and seeded there, would read it as hair.
CROP_SHARE, CROP_ZOOM = 0.3, 1.3  # the 18 portraits: 0.38-1.1 of the region in frame; their tight crops 0.12-0.18
MIN_SEED_SHARE = 0.25  # of a seed's area that must be the person, in frame (and unlike the skin, over the forehead)
MIN_HAIR_SKIN_DISTANCE = 10.0  # CIELAB distance of the seed's median from the skin's: nearer is a bald head
# Hair colours: the hair patches of the 12 tuning portraits have chroma 2-29, the 22 hair presets (fashion colours
# included: teal, lilac, violet) 0-25; a desert seen from orbit has 38-44, an orange suit 70, a red hat 60+. A seed or
# a patch more vivid than this is not hair.
MAX_HAIR_CHROMA = 35.0
# The band above the forehead, over hair, spans an L* interquartile range of 1-20 on the 18 portraits, tilted -45..45
# and upside down too (hair in light and shade); over Grace Hopper's cap, its black band and white crown, 66-73. A band
# spread wider than this is a hat of two colours (a seed beside the face may still show hair under it).
MAX_TOP_LIGHTNESS_SPREAD = 40.0
# A picture with no face is a patch of hair when it is not blank (std of its grey over BLANK_STD), not noise (the grey
# of neighbouring pixels correlates at least MIN_NEIGHBOUR_CORRELATION: hair patches 0.64-0.99, white noise 0.01) and
# its median is a hair colour.
BLANK_STD = 0.005
MIN_NEIGHBOUR_CORRELATION = 0.4
PATCH_SIZE = 256  # px: the longer side a picture is reduced to for the patch test
MIN_HAIR_SHARE = 0.08  # of the face oval's area: less found hair is no hair
LAB_FLOOR = np.diag([4.0, 1.0, 1.0])  # variance floor of each colour model (L*, a*, b*), so none is degenerate
# The hair's floor is wider and grows with the hair's lightness and chroma (shading scales them): a seed of lit hair
# must still take in the same hair in shade, whose colour differs more than any seed shows.
HAIR_SPREAD = 0.35
GROW_ROUNDS = 3  # hair models refitted on the hair found, then the hair found again
UPRIGHT_ROLL = math.radians(5)  # a head rolled more than this is worked on along its own axes, turned upright
PADDING_LEVEL = 0.5 / 255  # every channel under this is a canvas's pure black (8-bit 0), where it meets the edge
TO_IMAGE_ROWS = 256  # photo rows a tilted head's hair mask is drawn in at a time
TO_IMAGE_UPSAMPLE = 4  # a tilted head's score is resized up to this many times, then a photo pixel takes its nearest


@dataclass
class HairFound:
    """What HairLocator.locate found in a portrait."""

    mask: np.ndarray  # (H, W) float32 0/1: the hair
    box: tuple[int, int, int, int]  # x, y, w, h of the mask's tight box
    faces: int  # faces found; the largest face's hair is the one found
    note: str  # "" or one sentence for the user


@dataclass
class Gaussian:
    """A colour model: mean (3,), inverse covariance (3, 3) and log-determinant, in CIELAB (float64; a grid of
    pixels is scored in its own precision, float32 from srgb_to_lab)."""

    mean: np.ndarray
    precision: np.ndarray
    log_det: float

    @classmethod
    def fit(cls, lab: np.ndarray, floor: np.ndarray = LAB_FLOOR) -> Gaussian | None:
        """(N, 3) -> the model, its covariance widened by `floor`; None for fewer than 8 samples."""
        if len(lab) < 8:
            return None
        mean = lab.mean(axis=0, dtype=np.float64)
        centred = lab - mean
        covariance = centred.T @ centred / (len(lab) - 1) + floor
        # The 3 x 3 inverse by its adjugate (rows: cross products of the columns), not LAPACK, whose threads stall a
        # busy machine; the floor keeps the determinant positive.
        adjugate = np.cross(covariance[[1, 2, 0]], covariance[[2, 0, 1]])
        determinant = float(adjugate[0] @ covariance[0])
        return cls(mean, adjugate / determinant, math.log(determinant))

    def distance(self, lab: np.ndarray) -> np.ndarray:
        """(..., 3) -> (...) squared Mahalanobis distance from the mean."""
        # The quadratic form written out (no BLAS call per pixel), with Python floats, which keep lab's precision.
        d = [lab[..., i] - float(self.mean[i]) for i in range(3)]
        p = self.precision.tolist()
        return (p[0][0] * d[0] * d[0] + p[1][1] * d[1] * d[1] + p[2][2] * d[2] * d[2]
                + 2 * (p[0][1] * d[0] * d[1] + p[0][2] * d[0] * d[2] + p[1][2] * d[1] * d[2]))

    def log_likelihood(self, lab: np.ndarray) -> np.ndarray:
        """(..., 3) -> (...) log density up to a shared constant."""
        return -0.5 * (self.distance(lab) + self.log_det)


class HairLocator:
    """The person segmenter, loaded once; locate() finds the hair of the largest face's person."""

    def __init__(self, segmenter_path: str | Path, threads: int = 1):
        self.segmenter = cpu_session(segmenter_path, threads, "person model")
        self.segmenter_input = self.segmenter.get_inputs()[0].name

    def person(self, image: np.ndarray, matrix: np.ndarray, repeat_edges: bool = False) -> np.ndarray:
        """(SEGMENTER_SIZE, SEGMENTER_SIZE) person probability of the square that `matrix` (2, 3) maps from the model's
        input onto (H, W, 3); beyond the photo the square is black, or with `repeat_edges` the photo's edges."""
        square = warp(image, matrix, SEGMENTER_SIZE, repeat_edges)
        (probability,) = self.segmenter.run(None, {self.segmenter_input: square[None]})
        return np.nan_to_num(probability[0, 0])

    def locate(self, image: np.ndarray, face: FaceRead, light: PhotoLight | None = None) -> HairFound:
        """(H, W, 3) display sRGB and its largest face (FaceReader.read) -> the hair, grown from every seed that shows
        it (HeadFrame.seeds: above the forehead, over it, beside the face); VtoError 'no hair found ...' for a bald
        head, a hat, hair out of frame on every side, or too little hair to read. light: the photo's light
        (vto_core.photo.photo_light), taken out of the head's colours before they are modelled and judged, so a warm or
        cool light does not make hair look like skin or a hat (the limits here are a neutral studio's)."""
        image = as_rgb(image)
        height, width = image.shape[:2]
        frame = HeadFrame(face.landmarks, height, width)
        if frame.box[2] < 4 or frame.box[3] < 4:
            raise VtoError("no hair found: the head is out of frame")
        rgb = frame.sample(image)
        frame.inside &= ~padding(rgb, frame.inside)
        rgb = rgb if light is None else neutral_photo(rgb, light)
        square = frame.segmenter_matrix()
        person = seen = frame.sample_person(self.person(image, square), square)
        if frame.share_in_photo() < CROP_SHARE:
            wider = frame.segmenter_matrix(CROP_ZOOM)
            person = np.maximum(seen, frame.sample_person(self.person(image, wider, repeat_edges=True), wider))
        lab = srgb_to_lab(rgb, fast=True)
        oval = frame.polygon(face.landmarks[FACE_OVAL])
        in_photo = np.where(frame.inside, person, np.nan)  # beyond the photo: neither the person nor the background
        models = colour_models(lab, oval & ~frame.above_brows(), in_photo, frame.clothes())
        seeds = frame.seeds(oval, seen >= PERSON, models["skin"].distance(lab) > SKIN_LIKE if "skin" in models
                            else np.ones_like(oval))
        others = others_likelihood(lab, models)
        hair, seed, fringe = hair_seeds(lab, seeds, models, others, frame.inside)
        candidates = (person >= HAIR_CANDIDATE) & (~oval | fringe) & ~frame.under_chin()
        for _ in range(GROW_ROUNDS):
            parts = split_by_lightness(lab[hair])
            if not parts:
                break
            margin = hair_margin(lab, parts, others, frame.inside)
            hair = grow(seed & (margin > 0), candidates & (margin > 0))
        score = box_blur(hair.astype(np.float32), frame.inside)
        mask = frame.to_image(score)
        if mask.sum() < MIN_HAIR_SHARE * frame.oval_area(face.landmarks[FACE_OVAL]):
            raise VtoError("no hair found: too little hair beside the face to read (bald, or a hat?)")
        return HairFound(mask, tight_box(mask), face.faces, face.note)


@dataclass
class Seed:
    """Where hair may start: the work pixels (rows, cols) bool that can show it, and the seed's area in work pixels
    had the photo no edges."""

    name: str
    where: np.ndarray
    area: float


OUT_OF_FRAME = ("no hair found: the top of the head is out of frame or not part of the person, and no hair shows "
                "beside the face")


def seed_problem(lab: np.ndarray, area: float, models: dict[str, Gaussian], top: bool = False) -> str:
    """'' when a seed's pixels (N, 3) CIELAB show hair, else why not ('no hair found: ...'); `top`: the seed is the
    band above the forehead, where a hat sits."""
    if len(lab) < max(MIN_SEED_SHARE * area, 8):
        return OUT_OF_FRAME
    if top and np.subtract(*np.percentile(lab[:, 0], [75, 25])) > MAX_TOP_LIGHTNESS_SPREAD:
        return "no hair found: what covers the head is of two colours far apart, not hair (a hat?)"
    median = np.median(lab, axis=0)
    if "skin" in models and np.linalg.norm(median - models["skin"].mean) < MIN_HAIR_SKIN_DISTANCE:
        return "no hair found: the head around the face is the colour of the skin (bald?)"
    if not is_hair_colour(median):
        return "no hair found: what covers the head is not a hair colour (a hat?)"
    return ""


def hair_seeds(lab: np.ndarray, seeds: list[Seed], models: dict[str, Gaussian], others: np.ndarray | None = None,
               inside: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(where the hair's colour is first fitted, where it grows from, the fringe's seed or none) (rows, cols) bool
    each, from the seeds that show hair (seed_problem). Where the band above the forehead shows it, the colour is
    fitted on it alone, and a seed elsewhere must be that hair's colour rather than another's (a headset, a collar);
    else on all the seeds that show hair. VtoError (the first seed's problem that is not the frame's, else the
    frame's) where none shows hair. others: others_likelihood(lab, models) (None: computed); inside: the work
    pixels in the photo (None: all)."""
    problems = {seed.name: seed_problem(lab[seed.where], seed.area, models, seed.name == "top") for seed in seeds}
    shown = [seed for seed in seeds if not problems[seed.name]]
    if not shown:
        raise VtoError(next((p for p in problems.values() if p != OUT_OF_FRAME), OUT_OF_FRAME))
    if shown[0].name == "top":
        parts = split_by_lightness(lab[shown[0].where])
        margin = hair_margin(lab, parts, others_likelihood(lab, models) if others is None else others, inside)
        shown = shown[:1] + [seed for seed in shown[1:] if np.median(margin[seed.where]) > 0]
    fringe = next((seed.where for seed in shown if seed.name == "fringe"), np.zeros_like(seeds[0].where))
    every = np.logical_or.reduce([seed.where for seed in shown])
    return (shown[0].where if shown[0].name == "top" else every), every, fringe


class HeadFrame:
    """The head's region of a photo and its work grid, sampled at WORK_FACE_HEIGHT px per face height: the region's
    box along the photo's axes where the head is upright (within UPRIGHT_ROLL), else along the face's own axes, so
    that a tilted head is worked on as it would be upright."""

    def __init__(self, landmarks: np.ndarray, height: int, width: int):
        landmarks = landmarks.astype(np.float64)
        self.shape = (height, width)
        top, chin = landmarks[FOREHEAD], landmarks[CHIN]
        self.face_height = max(float(np.linalg.norm(top - chin)), 1.0)
        self.up = (top - chin) / self.face_height
        self.right = np.array([-self.up[1], self.up[0]])  # image right when the face is upright
        self.face_width = max(float(np.linalg.norm(landmarks[LEFT_CHEEK] - landmarks[RIGHT_CHEEK])), 1.0)
        self.centre = (top + chin) / 2
        self.scale = WORK_FACE_HEIGHT / self.face_height  # work px per photo px
        roll = math.atan2(self.right[1], self.right[0])
        self.turn = roll if abs(roll) > UPRIGHT_ROLL else 0.0  # the grid's axes: the photo's, or the face's
        self.across = np.array([math.cos(self.turn), math.sin(self.turn)])  # the grid's x and y in the photo
        self.down = np.array([-self.across[1], self.across[0]])
        corners = [self.centre + self.up * (up * self.face_height) + self.right * (side * self.face_width)
                   for up in (0.5 + REGION_UP, -0.5 - REGION_DOWN) for side in (-REGION_SIDE, REGION_SIDE)]
        axes = np.stack([self.across, self.down], 1)
        along = np.array(corners) @ axes  # (4, 2) the region's corners on the grid's axes, then the photo's
        photo = np.array([[0.0, 0.0], [width, 0.0], [0.0, height], [width, height]]) @ axes
        self.low = np.maximum(along.min(axis=0), photo.min(axis=0))  # the region's box, cut to the photo's
        self.high = np.maximum(np.minimum(along.max(axis=0), photo.max(axis=0)), self.low)
        self.cols, self.rows = (max(1, round(float(v))) for v in (self.high - self.low) * self.scale)
        # (rows, cols) photo coordinates of the work pixels' centres
        self.xs, self.ys = self.from_work(*np.meshgrid(np.arange(self.cols) + 0.5, np.arange(self.rows) + 0.5))
        self.inside = (self.xs >= 0) & (self.xs < width) & (self.ys >= 0) & (self.ys < height)
        offset = np.stack([self.xs, self.ys], -1) - self.centre
        self.along_up = offset @ self.up / self.face_height  # face heights above the face's centre
        self.along_right = offset @ self.right / self.face_width  # face widths right of the centre line
        low, high = np.min(corners, axis=0), np.max(corners, axis=0)
        x0, y0 = max(0, int(math.floor(low[0]))), max(0, int(math.floor(low[1])))
        x1, y1 = min(width, int(math.ceil(high[0]))), min(height, int(math.ceil(high[1])))
        self.box = (x0, y0, max(0, x1 - x0), max(0, y1 - y0))  # the region's axis-aligned box on the photo
        self.marks_up = (landmarks - self.centre) @ self.up / self.face_height  # (468,) the landmarks likewise
        self.marks_right = (landmarks - self.centre) @ self.right / self.face_width

    def from_work(self, col: np.ndarray, row: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Work grid col, row (pixel centres at +0.5; any shape) -> photo x, y."""
        a, d = self.low[0] + col / self.scale, self.low[1] + row / self.scale
        return a * self.across[0] + d * self.down[0], a * self.across[1] + d * self.down[1]

    def to_work(self, points: np.ndarray) -> np.ndarray:
        """(..., 2) photo x, y -> (..., 2) work grid col, row (pixel centres at +0.5)."""
        points = np.asarray(points, np.float64)
        return np.stack([points @ self.across - self.low[0], points @ self.down - self.low[1]], -1) * self.scale

    def sample(self, image: np.ndarray) -> np.ndarray:
        """(H, W, 3) -> (rows, cols, 3) float32 the region on the work grid (block means, then bilinear; black
        outside the photo)."""
        x0, y0, w, h = self.box
        factor = max(1, int(1 / self.scale))
        region = reduce(image[y0:y0 + h, x0:x0 + w], factor)
        return np.clip(sample_bilinear(region, (self.xs - x0) / factor, (self.ys - y0) / factor), 0, 1
                       ).transpose(1, 2, 0)

    def segmenter_matrix(self, zoom: float = 1.0) -> np.ndarray:
        """(2, 3) the model's 256 x 256 input onto the square around the part of the region inside the photo (the head
        and shoulders, as a selfie frames them), along the grid's axes: the model, like a selfie, expects a person
        upright, so a tilted head is shown to it as the same head upright would be. zoom: the square's side times
        this."""
        rows, cols = np.nonzero(self.inside)
        if not rows.size:
            rows, cols = np.array([0, self.rows - 1]), np.array([0, self.cols - 1])
        side = (max(np.ptp(rows), np.ptp(cols)) + 1) / self.scale * zoom
        centre = np.array(self.from_work((cols.min() + cols.max() + 1) / 2, (rows.min() + rows.max() + 1) / 2))
        return square_matrix(centre, side, self.turn, SEGMENTER_SIZE)

    def sample_person(self, probability: np.ndarray, square: np.ndarray) -> np.ndarray:
        """The segmenter's (256, 256) output on the square (2, 3) (segmenter_matrix) -> on the work grid (rows,
        cols)."""
        to_model = np.linalg.inv(np.vstack([square, [0.0, 0.0, 1.0]]))
        u = to_model[0, 0] * self.xs + to_model[0, 1] * self.ys + to_model[0, 2]
        v = to_model[1, 0] * self.xs + to_model[1, 1] * self.ys + to_model[1, 2]
        return sample_bilinear(probability[..., None].astype(np.float32), u, v)[0] * self.inside

    def share_in_photo(self) -> float:
        """The share of the head's region that lies in the photo (1 for a portrait with room around the head)."""
        region = (1 + REGION_UP + REGION_DOWN) * 2 * REGION_SIDE * self.work_area()
        return float(self.inside.sum()) / region

    def polygon(self, points: np.ndarray) -> np.ndarray:
        """(rows, cols) bool: the work pixels inside the photo and inside a polygon (K, 2) given in photo pixels."""
        return polygon_mask(self.to_work(points), 0, 0, self.cols, self.rows) & self.inside

    def seed(self) -> np.ndarray:
        """(rows, cols) bool: the band above the forehead where hair is looked for first."""
        above_top = self.along_up - 0.5
        return ((above_top >= SEED_UP[0]) & (above_top <= SEED_UP[1])
                & (np.abs(self.along_right) <= SEED_HALF_WIDTH))

    def seed_area(self) -> float:
        """The seed band's area in work pixels, had the photo no edges."""
        return (SEED_UP[1] - SEED_UP[0]) * 2 * SEED_HALF_WIDTH * self.work_area()

    def seeds(self, oval: np.ndarray, person: np.ndarray, unlike_skin: np.ndarray) -> list[Seed]:
        """Where hair may start, each among the person's pixels: the band above the forehead and the strips beside the
        face, left and right, each less the face oval (`seed`, `beside`); the oval above the eyebrows where it is
        `unlike_skin` (rows, cols) bool (a fringe)."""
        fringe = self.above_brows() & oval & person & unlike_skin
        top = Seed("top", self.seed() & person & ~oval, self.seed_area())
        sides = [Seed(name, where & person & ~oval, self.beside_area())
                 for name, where in zip(("left", "right"), self.beside())]
        return [top, Seed("fringe", fringe, self.fringe_area())] + sides

    def above_brows(self) -> np.ndarray:
        """(rows, cols) bool: above the eyebrows' top."""
        return self.along_up > self.marks_up[BROWS].max()

    def fringe_area(self) -> float:
        """The face oval's area above the eyebrows, in work pixels."""
        heights = np.linspace(self.marks_up[BROWS].max(), self.marks_up[FOREHEAD], 17)
        left, right = self.oval_edges(heights)
        widths = np.maximum(right - left, 0)
        return max(0.0, float(((widths[1:] + widths[:-1]) / 2 * np.diff(heights)).sum())) * self.work_area()

    def beside(self) -> tuple[np.ndarray, np.ndarray]:
        """(rows, cols) bool each: SIDE_STRIP outside the face oval on its left and its right, from the eyes'
        height down to the mouth's."""
        eyes, mouth = self.eyes_and_mouth()
        rows = (self.along_up <= eyes) & (self.along_up >= mouth)
        left, right = self.oval_edges(self.along_up)
        near, far = SIDE_STRIP
        return (rows & (self.along_right <= left - near) & (self.along_right >= left - far),
                rows & (self.along_right >= right + near) & (self.along_right <= right + far))

    def beside_area(self) -> float:
        """The area of one strip beside the face, in work pixels."""
        eyes, mouth = self.eyes_and_mouth()
        return max(eyes - mouth, 0.0) * (SIDE_STRIP[1] - SIDE_STRIP[0]) * self.work_area()

    def eyes_and_mouth(self) -> tuple[float, float]:
        """The heights (face heights above the centre) of the eyes' outer corners and of the mouth's corners."""
        eyes = float(self.marks_up[[RIGHT_EYE_CORNER, LEFT_EYE_CORNER]].mean())
        return eyes, float(self.marks_up[[RIGHT_MOUTH_CORNER, LEFT_MOUTH_CORNER]].mean())

    def oval_edges(self, heights: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(left, right) where the face oval's two sides lie (face widths right of the centre line) at `heights`
        (face heights above the centre): each side's landmarks from the forehead to the chin, interpolated."""
        chin = FACE_OVAL.index(CHIN)
        edges = []
        for side in (FACE_OVAL[:chin + 1], FACE_OVAL[chin:] + [FOREHEAD]):
            order = np.argsort(self.marks_up[side])
            edges.append(np.interp(heights, self.marks_up[side][order], self.marks_right[side][order]))
        return tuple(sorted(edges, key=lambda edge: float(np.mean(edge))))

    def work_area(self) -> float:
        """Work pixels in an area of one face height by one face width."""
        return self.face_width / self.face_height * WORK_FACE_HEIGHT ** 2

    def clothes(self) -> list[np.ndarray]:
        """(rows, cols) bool each: below the chin, in the middle: the collar and the chest."""
        below = -0.5 - self.along_up
        middle = np.abs(self.along_right) <= SEED_HALF_WIDTH
        return [middle & (below >= low) & (below < high) for low, high in CLOTHES_BELOW]

    def under_chin(self) -> np.ndarray:
        """(rows, cols) bool: below the chin and in front of the neck, where hair hangs only behind the head."""
        return (self.along_up < -0.5) & (np.abs(self.along_right) < NECK_HALF_WIDTH)

    def oval_area(self, oval: np.ndarray) -> float:
        """The face oval's area (K, 2) in photo pixels (shoelace)."""
        x, y = oval[:, 0].astype(np.float64), oval[:, 1].astype(np.float64)
        return 0.5 * abs(float(x @ np.roll(y, -1) - y @ np.roll(x, -1)))

    def to_image(self, score: np.ndarray) -> np.ndarray:
        """(rows, cols) hair score in [0, 1] -> (H, W) float32 0/1 on the photo, over the region: where the grid lies
        along the photo's axes, the score interpolated bilinearly (edges repeated) at each photo pixel on the grid,
        > 0.5 (a row of the photo at a time, then a column); along a tilted head's, the score so resized to up to
        TO_IMAGE_UPSAMPLE times the grid, > 0.5, each photo pixel taking its nearest, in bands of TO_IMAGE_ROWS rows
        (a large photo costs no whole-photo grids). Either way only the photo pixels near the score's non-zero cells
        are worked on: elsewhere the score interpolates to 0."""
        mask = np.zeros(self.shape, np.float32)
        rows_held, cols_held = np.flatnonzero(score.any(axis=1)), np.flatnonzero(score.any(axis=0))
        if not rows_held.size:
            return mask
        # A position reads a non-zero cell only within [first - 0.5, last + 1.5) of the non-zero cells (linear_taps).
        row_span = (rows_held[0] - 0.5, rows_held[-1] + 1.5)
        col_span = (cols_held[0] - 0.5, cols_held[-1] + 1.5)
        x0, y0, w, h = self.box
        if not self.turn:
            cols = (x0 + np.arange(w) + 0.5 - self.low[0]) * self.scale
            rows = (y0 + np.arange(h) + 0.5 - self.low[1]) * self.scale
            (left, right), (top, bottom) = on_grid(cols, self.cols, col_span), on_grid(rows, self.rows, row_span)
            mask[y0 + top:y0 + bottom, x0 + left:x0 + right] = linear_resize(score, rows[top:bottom],
                                                                             cols[left:right]) > 0.5
            return mask
        fine = min(TO_IMAGE_UPSAMPLE, max(1, math.ceil(1 / self.scale)))
        (top, bottom), (left, right) = (on_grid((np.arange(size * fine) + 0.5) / fine, size, span)
                                        for size, span in ((self.rows, row_span), (self.cols, col_span)))
        rows, cols = bottom - top, right - left  # the fine grid's part that can hold hair, from (top, left)
        # bordered by no hair: a photo pixel beyond the part, its indices clipped to the border, reads no hair there
        hair = np.zeros((rows + 2, cols + 2), bool)
        hair[1:-1, 1:-1] = linear_resize(score, (np.arange(top, bottom) + 0.5) / fine,
                                         (np.arange(left, right) + 0.5) / fine) > 0.5
        hair, start = hair.ravel(), (top - 1) * (cols + 2) + (left - 1)  # the border's first cell, on the fine grid
        # The fine grid's col and row are affine in the photo's x and y: each a x + b y + c.
        origin = self.to_work(np.zeros(2)) * fine
        (col_x, row_x), (col_y, row_y) = (self.to_work(np.eye(2)) * fine - origin).astype(np.float32)
        col_0, row_0 = origin.astype(np.float32)
        # Only the photo pixels whose box holds that part's corners can land on it.
        corners = np.array(self.from_work(np.array([left, right, left, right]) / fine,
                                          np.array([top, top, bottom, bottom]) / fine))
        x_low, y_low = np.maximum(np.floor(corners.min(axis=1)).astype(int) - 1, (x0, y0))
        x_high, y_high = np.minimum(np.ceil(corners.max(axis=1)).astype(int) + 1, (x0 + w, y0 + h))
        xs = (np.arange(x_low, max(x_high, x_low)) + 0.5).astype(np.float32)
        for band in range(y_low, y_high, TO_IMAGE_ROWS):
            ys = (np.arange(band, min(band + TO_IMAGE_ROWS, y_high)) + 0.5).astype(np.float32)[:, None]
            col = np.floor(col_x * xs + (col_y * ys + col_0)).astype(np.int32)  # on the fine grid
            row = np.floor(row_x * xs + (row_y * ys + row_0)).astype(np.int32)
            np.clip(col, left - 1, right, out=col)
            np.clip(row, top - 1, bottom, out=row)
            row *= cols + 2  # (in place: the bands are a megapixel's size)
            row += col
            row -= start
            mask[band:band + len(ys), x_low:x_low + len(xs)] = hair[row]
        return mask


def on_grid(positions: np.ndarray, size: int, span: tuple[float, float] = (0.0, math.inf)) -> tuple[int, int]:
    """Increasing positions (n,) on an axis of `size` work pixels -> the slice [start, stop) of those on it and in
    [span[0], span[1])."""
    return int(np.searchsorted(positions, max(0.0, span[0]))), int(np.searchsorted(positions, min(size, span[1])))


def linear_taps(positions: np.ndarray, size: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Linear interpolation at positions (...) along an axis of `size` pixels (pixel i's centre at i + 0.5; edges
    repeated): (the lower neighbour, the upper one, the upper one's weight), each shaped as positions."""
    position = np.clip(positions - np.float32(0.5), 0, size - 1)
    low = np.floor(position).astype(np.intp)
    return low, np.minimum(low + 1, size - 1), (position - low).astype(np.float32)


def linear_resize(values: np.ndarray, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
    """(r, c) sampled at positions rows (R,) and cols (C,) (linear_taps along each axis) -> (R, C)."""
    low, high, weight = linear_taps(rows, values.shape[0])
    down = values[low] * (1 - weight)[:, None] + values[high] * weight[:, None]
    low, high, weight = linear_taps(cols, values.shape[1])
    return down[:, low] * (1 - weight) + down[:, high] * weight


def is_hair_colour(lab: np.ndarray) -> bool:
    """Whether a CIELAB colour (3,) can be a hair colour, natural or dyed: not more vivid than MAX_HAIR_CHROMA."""
    return math.hypot(lab[1], lab[2]) <= MAX_HAIR_CHROMA


def patch_problem(image: np.ndarray) -> str:
    """'' when a picture with no face (H, W, 3) can be a patch of hair, else why not ('no hair found: ...')."""
    image = as_rgb(image)
    small = reduce(image, max(1, math.ceil(max(image.shape[:2]) / PATCH_SIZE)))
    grey = small.mean(axis=2, dtype=np.float64)
    if grey.std() <= BLANK_STD:
        return "no hair found: the image is blank"
    centred = grey - grey.mean()
    correlation = max(float((centred[1:] * centred[:-1]).mean()), float((centred[:, 1:] * centred[:, :-1]).mean()))
    if correlation < MIN_NEIGHBOUR_CORRELATION * centred.var():
        return "no hair found: no face, and the image is noise, not a patch of hair"
    if not is_hair_colour(np.median(srgb_to_lab(small).reshape(-1, 3), axis=0)):
        return "no hair found: no face, and the image's colour is not a hair colour; crop the hair or give a mask"
    return ""


def colour_models(lab: np.ndarray, oval: np.ndarray, person: np.ndarray, clothes: list[np.ndarray]
                  ) -> dict[str, Gaussian]:
    """The photo's own colour models, each from the pixels it surely covers: the skin (`oval`, the face oval below the
    eyebrows so that a fringe is not taken for it, its outliers trimmed), the background (not the person), the
    clothes (the collar and the chest)."""
    models = {}
    skin = lab[oval]
    if len(skin) >= 8:
        first = Gaussian.fit(skin)
        distance = first.distance(skin)
        models["skin"] = Gaussian.fit(skin[distance < np.quantile(distance, 0.8)]) or first
    samples = [("background", person < BACKGROUND)] + [(f"clothes {i}", where & (person >= PERSON))
                                                       for i, where in enumerate(clothes)]
    for name, where in samples:
        model = Gaussian.fit(lab[where])
        if model is not None:
            models[name] = model
    return models


def split_by_lightness(hair: np.ndarray) -> list[Gaussian]:
    """(N, 3) CIELAB of hair -> a model each of its darker and lighter half (hair in light and in shade), or one for
    few samples; [] for fewer than 8."""
    if len(hair) < 8:
        return []
    lightness, a_star, b_star = np.median(hair, axis=0)
    chroma = math.hypot(a_star, b_star)
    floor = LAB_FLOOR + np.diag([lightness, chroma, chroma]) ** 2 * HAIR_SPREAD ** 2
    if len(hair) < 16:
        return [Gaussian.fit(hair, floor)]
    lighter = hair[:, 0] >= lightness
    halves = (Gaussian.fit(hair[~lighter], floor), Gaussian.fit(hair[lighter], floor))
    return [model for model in halves if model is not None]


def others_likelihood(lab: np.ndarray, models: dict[str, Gaussian]) -> np.ndarray:
    """(rows, cols, 3) CIELAB -> (rows, cols) the best log-likelihood of the colour models that are not the hair's
    (the skin, the background, the clothes); -inf where there are none."""
    if not models:
        return np.full(lab.shape[:2], -np.inf, lab.dtype)
    return functools.reduce(np.maximum, (model.log_likelihood(lab) for model in models.values()))


def hair_margin(lab: np.ndarray, hair_models: list[Gaussian], others: np.ndarray,
                inside: np.ndarray | None = None) -> np.ndarray:
    """(rows, cols) the best hair model's log-likelihood less the others' (others_likelihood), smoothed over 3 x 3
    pixels of those `inside` the photo (rows, cols) bool (None: all)."""
    hair = functools.reduce(np.maximum, (model.log_likelihood(lab) for model in hair_models))
    return box_blur(np.clip(hair - others, -50, 50), inside)


def padding(rgb: np.ndarray, inside: np.ndarray) -> np.ndarray:
    """(rows, cols) bool: the work pixels (rgb (rows, cols, 3), `inside` the photo (rows, cols) bool) of a canvas's
    padding: pure black (every channel under PADDING_LEVEL) and connected to the photo's edge or the grid's. A photo
    turned on a larger canvas, or letterboxed, has black there that is no part of the scene, and the person model
    takes it for the person beside it."""
    black = np.maximum(np.maximum(rgb[..., 0], rgb[..., 1]), rgb[..., 2]) < PADDING_LEVEL  # (max(axis=2): 3 at a time)
    edge = np.pad(~inside, 1, constant_values=True)
    edge = edge[:-2, 1:-1] | edge[2:, 1:-1] | edge[1:-1, :-2] | edge[1:-1, 2:]  # beside the photo's edge or the grid's
    return grow(edge & black & inside, black & inside)


def box_blur(values: np.ndarray, weights: np.ndarray | None = None) -> np.ndarray:
    """(rows, cols) the mean over each pixel's 3 x 3 neighbourhood, edges repeated; with `weights` (rows, cols) bool,
    over the neighbours it holds (a pixel with none keeps 0), so that what lies outside the photo counts for nothing."""

    def total(array):  # the 3 x 3 sum as a 3-sum down the rows, then across the columns
        padded = np.pad(array, 1, mode="edge")
        across = padded[:-2] + padded[1:-1] + padded[2:]
        return across[:, :-2] + across[:, 1:-1] + across[:, 2:]

    if weights is None:
        return total(values) / values.dtype.type(9)
    count = total(weights.astype(values.dtype))
    return total(np.where(weights, values, values.dtype.type(0))) / np.maximum(count, values.dtype.type(1))


def grow(seed: np.ndarray, allowed: np.ndarray) -> np.ndarray:
    """(rows, cols) bool: the pixels of `allowed` connected to `seed` (4-neighbours). Each run of `allowed` along a
    row that holds a pixel of the region joins it whole, then each such run along a column, in turn until nothing
    changes: a few passes where dilating a pixel at a time takes one per pixel of the region's longest path."""
    region = seed & allowed
    if not region.any():
        return region
    along = [run_labels(allowed), np.ascontiguousarray(run_labels(allowed.T).T)]
    held = np.zeros(max(int(labels.max()) for labels in along) + 1, bool)  # per run: whether it joins (0: none)
    unchanged = 0
    for labels in itertools.cycle(along):
        held[:] = False
        held[labels[region]] = True
        grown = held[labels]
        unchanged = unchanged + 1 if np.array_equal(grown, region) else 0
        if unchanged == 2:  # a pass along the rows and one along the columns, both adding nothing
            return region
        region = grown


def run_labels(allowed: np.ndarray) -> np.ndarray:
    """(rows, cols) bool -> (rows, cols) intp: each run of True along a row numbered from 1, 0 elsewhere."""
    rows, cols = allowed.shape
    padded = np.zeros((rows, cols + 1), bool)  # a False column between rows, so that no run crosses into the next
    padded[:, :cols] = allowed
    flat = padded.ravel()
    starts = flat.copy()
    starts[1:] &= ~flat[:-1]
    return (np.cumsum(starts) * flat).reshape(rows, cols + 1)[:, :cols]


def cached_hair_locator(segmenter_path: str | Path) -> HairLocator:
    """One HairLocator per model file (by resolved path, mtime and size), made on first use."""
    key = file_key(segmenter_path, "person model")
    if _LOCATORS.get("key") != key:
        _LOCATORS.update(key=key, locator=HairLocator(key[0]))
    return _LOCATORS["locator"]


_LOCATORS: dict = {}
