"""Fast for a photo whose scene is unknown: the encoder's estimate fitted through the colour imitator to what the
photo shows of the material, its mean colour then polished on passes of the real stage (hair), where the product's
FitPolicy.fast_fits says the fit pays; else the encoder's estimate as it is (lips)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from vto_core.appearance import MEAN_WEIGHT
from vto_core.dataset import DEFAULT_SAMPLES
from vto_core.products import get_product
from vto_core.specs import RendererSpec

from ..renderers.products import FIT_RES, blender_side
from ..shipped import MODELS
from .photo_fit import fit_start, parameter_difference, photo_values

HUE_TURNS = (0.0, 0.25, 0.5, 0.75)  # where on the hue circle Fast's colour fit starts, from the encoder's hue
# Fast's colour fits whose squared miss of the photo's statistics is within this share of the least are a tie (the
# one nearest the encoder's estimate is kept). Against the least miss alone, on renders with the source hidden
# (seed 9001) 33.80 dB against 33.74; on the 18 portraits against the hand-drawn hair a median 3.07 against 3.14
# CIEDE2000 (tight crops 2.43 against 2.57); tilted -45..45 degrees, 8 portraits moved a median 0.60 against 0.79.
NEAR_TIE = 0.15
# Fast's colour fit then polishes its mean colour on the real stage (iter_polish_colour; FitPolicy.fast_polish passes):
# the imitator is a few CIELAB units off where some fits settle (a grey hair at saturation 0 read as green), and which
# of its near-equal valleys a fit settles in turns on the fourth decimal of the photo's statistics. Renders of the
# default region (~10 ms each, the region rendered once a session) judge and correct it.
POLISH_DAMPING = 0.01  # Marquardt damping of the polish's steps (a share of the Gauss-Newton matrix's diagonal)
POLISH_SHORTER = 10.0  # the damping grows this much after a step whose render went no nearer

def colour_imitator_path(renderer: str) -> Path:
    """The shipped colour imitator of `renderer`: blender_addon/models/<renderer>_colour.onnx."""
    return MODELS / f"{renderer}_colour.onnx"


def fast_polish_passes(renderer: str) -> int:
    """The stage passes Fast's polish takes for product `renderer` (none where Fast does not fit)."""
    return get_product(renderer).fit.polish_passes


def iter_fit_photo_fast(spec: RendererSpec, region: tuple[np.ndarray, np.ndarray], start: dict[str, float],
                        imitator_path: Path | None = None, quality: str = "FAST"):
    """Fast: the encoder's estimate `start` (modelled raw values) as it is where the product's FitPolicy.fast_fits says
    the colour fit does not pay, else fit_colour's, its mean colour then polished on the real stage (iter_polish_colour,
    fast_polish renders; nothing of them left in the .blend) where `quality`, the Match's, is FAST (Better and Best
    start from the fit unpolished: their figures were measured from it). A generator: yields the polish's renders made
    so far (the panel runs them between redraws), returns the values and a note for the user ("" when none)."""
    if not get_product(spec.renderer).fit.fast_fits:
        return dict(start), ""
    fitted, note = fit_colour(spec, region, start, imitator_path)
    if note or quality != "FAST" or not fast_polish_passes(spec.renderer):
        return fitted, note
    from ..scratch import scratch_data

    with scratch_data():
        return (yield from iter_polish_colour(spec, region, fitted, imitator_path)), ""


def fit_photo_fast(spec: RendererSpec, region: tuple[np.ndarray, np.ndarray], start: dict[str, float],
                   imitator_path: Path | None = None, quality: str = "FAST") -> tuple[dict[str, float], str]:
    """iter_fit_photo_fast run to its end: (values, note)."""
    from .refine import drain

    return drain(iter_fit_photo_fast(spec, region, start, imitator_path, quality))


def fit_colour(spec: RendererSpec, region: tuple[np.ndarray, np.ndarray], start: dict[str, float],
               imitator_path: Path | None = None) -> tuple[dict[str, float], str]:
    """The colour imitator's fit: the modelled values (raw) near `start` whose default-scene statistics, as the colour
    imitator (vto_core.colour_imitator) predicts them, are the photo region's; milliseconds, no render. Returns them
    and a note: where no imitator for this spec exists the encoder's estimate stands, and the note says so."""
    from vto_core.appearance import region_statistics, skin_light
    from vto_core.colour_imitator import cached_imitator

    path = colour_imitator_path(spec.renderer) if imitator_path is None else Path(imitator_path)
    if not path.is_file():
        return dict(start), f"no colour imitator at {path}: Fast is the encoder's estimate"
    imitator = cached_imitator(path)
    if not imitator.spec.same_as(spec):
        return dict(start), (f"{path.name} imitates other parameters than the model estimates: Fast is the "
                             "encoder's estimate")
    light = skin_light(*region) if imitator.typical_skin is not None else None
    target = region_statistics(*region)
    unit, wraps, held = fit_start(spec, start)
    skin = None if light is None else light[1]
    # A hue is a turn: the encoder reads the hue of a near-grey hair (a cast of a few units of chroma) at random, and a
    # fit settles where it starts on the circle (the imitator does not wrap, so a fit does not cross hue 0). The fit is
    # also run from the hue turned by quarter turns, and the one whose statistics come nearest the photo's is kept.
    # Fits whose statistics come within NEAR_TIE of the nearest are told apart by the imitator's error, not the photo:
    # of those, the one nearest the encoder's estimate is kept, so a hair read a little differently (the same photo
    # turned a few degrees) keeps its valley.
    starts = np.stack([np.where(wraps, (unit + turn) % 1.0, unit) for turn in (HUE_TURNS if wraps.any() else (0.0,))])
    fits = imitator.fit(target, starts, get_product(spec.renderer).fit.prior_weight, wraps, held, skin)
    misses = ((imitator.statistics(fits, skin) - target) ** 2).sum(axis=1)
    distances = (parameter_difference(fits, unit, wraps) ** 2).sum(axis=1)
    found = fits[np.argmin(np.where(misses <= misses.min() * (1 + NEAR_TIE), distances, np.inf))]
    fitted = spec.values(spec.denormalise(found))
    return {name: float(fitted[name]) for name in spec.modelled}, ""


def iter_polish_colour(spec: RendererSpec, region: tuple[np.ndarray, np.ndarray], start: dict[str, float],
                       imitator_path: Path | None = None, renders: int | None = None, res: int = FIT_RES,
                       samples: int = DEFAULT_SAMPLES):
    """The modelled values (raw) near `start` whose render on the default scene (its first fit source's region) shows
    the photo region's mean colour: Gauss-Newton on that colour's CIELAB, its residual from real renders, its Jacobian
    from the colour imitator's mean; `renders` (FitPolicy.fast_polish) renders in all, each judging the step before it,
    and the values whose render came nearest (CIEDE2000) are kept (`start` where no step came nearer); a step that came
    no nearer is retried shorter from the best. A generator: yields renders made so far, returns the modelled values."""
    from vto_core.appearance import mean_colour
    from vto_core.colour import ciede2000, srgb_to_lab
    from vto_core.colour_imitator import STEP, cached_imitator

    imitator = cached_imitator(colour_imitator_path(spec.renderer) if imitator_path is None else imitator_path)
    side = blender_side(spec.renderer)
    render = side.region_renderer(side.fit_sources[0], res, samples)
    photo = srgb_to_lab(mean_colour(*region)).astype(np.float64)
    unit, wraps, held = fit_start(spec, start)
    free = np.array([i not in (held or {}) for i in range(spec.size)])
    probes = STEP * np.eye(spec.size)[free]  # (f, m)
    best, best_miss, best_shown, damping = unit, np.inf, None, POLISH_DAMPING
    count = get_product(spec.renderer).fit.fast_polish if renders is None else renders
    for k in range(count):
        values = spec.values(spec.denormalise(unit))
        shown = srgb_to_lab(mean_colour(*render(spec.full_values(photo_values(spec, values))))).astype(np.float64)
        miss = float(ciede2000(shown, photo))
        yield k + 1
        if miss < best_miss:
            best, best_miss, best_shown = unit, miss, shown
        else:  # the step went no nearer: a shorter one from the best so far
            damping *= POLISH_SHORTER
        if k == count - 1:
            break
        predicted = imitator.statistics(np.vstack([best, best + probes]))[:, :3] / MEAN_WEIGHT  # (1 + f, 3)
        jacobian = ((predicted[1:] - predicted[0]) / STEP).T  # (3, f)
        gram = jacobian.T @ jacobian
        step = np.linalg.solve(gram + damping * np.diag(np.diag(gram) + 1e-9), -jacobian.T @ (best_shown - photo))
        trial = best.copy()
        trial[free] += step
        unit = np.where(wraps, np.mod(trial, 1.0), np.clip(trial, 0.0, 1.0))
    fitted = spec.values(spec.denormalise(best))
    return {name: float(fitted[name]) for name in spec.modelled}
