"""Fast, Better and Best for a photo whose scene is unknown (its light already taken out,
blender_addon.matching.reference): the encoder's estimate (lips' Fast), or that estimate fitted to what the photo shows
of the material, through the colour imitator with its mean colour polished on three stage passes (hair's Fast) or
through the real renderer on default-scene sources (Better, Best).

A photo of real lips (or of an artist's reference hair) has no source X to render the estimate on, so the render
cannot be compared with it pixel by pixel. What can be compared is the region's colour statistics
(vto_core.appearance: its mean colour, the spread of its lightness up to the highlights, its chroma): the fits
(Levenberg-Marquardt from the encoder's estimate or Fast's, with a pull back towards it) move the parameters until
the default scene's lips (or hair) show the photo's statistics. Fast asks the colour imitator
(vto_core.colour_imitator) what the default scene would show; Better and Best render it (blender_addon.matching.refine's
fit), the lips on the sources whose skin looks most like the photo's, their skin and bare lips toned so the render's
skin shows the photo's skin colour (the scene's light and skin fitted as far as the skin shows them). Those sources are
seeds of their own (LIPS_POOL, FIT_SOURCES), never the ones the benchmarks measure the estimate on.

Lips of a face in a portrait do have a scene: Better and Best then fit there instead, pixel by pixel, each candidate
tried on the photo's own lips (blender_addon.matching.photo_scene_fit). The default-scene fit is left for lips without
a face (a close-up, a mask) or without skin beside them.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from pathlib import Path

import numpy as np

from vto_core.appearance import MEAN_WEIGHT
from vto_core.dataset import DEFAULT_SAMPLES
from vto_core.errors import VtoError
from vto_core.hair import PHOTO_HAIR
from vto_core.specs import RendererSpec

from ..shipped import DATA, MODELS

# Default-scene seeds the fits render on: apart from the benchmarks' sources 0-7 and eval's 5000 and up. Lips: a pool
# the fit picks the sources whose skin is most like the photo's from; hair: its sources in order.
LIPS_POOL = tuple(range(900001, 900025))
FIT_SOURCES = (900001, 900002, 900003, 900004)
MAX_TONE_RATIO = 4.0  # a source's skin tone is scaled (linear, per channel) by at most this either way
QUALITIES = ("FAST", "BETTER", "BEST")  # the panel's choice: no render (hair: FAST_POLISH passes), or FIT_QUALITY's
NO_REGION = ("fits the colour of the lips and needs to know where they are: let the add-on find them (Find Lips), or "
             "give a mask")
# Quality -> (sources, renders in all). Lipstick renders cost ~0.15 s at 64 px; the hair stage ~10 ms a source.
FIT_QUALITY = {"lipstick": {"BETTER": (1, 25), "BEST": (2, 100)}, "hair": {"BETTER": (2, 100), "BEST": (4, 400)}}
# (seconds, seconds the first time in a session) each takes on a 2-core CPU, what the panel tells the artist:
# benchmarks/results/photo_sources.md and real_window.md, rounded up. Lips: fitted in the photo's own scene
# (photo_scene_fit: 25 renders at 64 px, 100 at 96 px); hair's regions are shipped (FIT_REGIONS), no render.
# Hair Fast: its polish's 3 stage passes, a pass per timer tick in the panel (0.38-0.42 s a click in the real window,
# 1.3 s once after an undo; `vto match` on the astronaut: 1.1 s, its process's first, with the imitator).
FIT_SECONDS = {"lipstick": {"BETTER": (3, 11), "BEST": (12, 18)},
               "hair": {"FAST": (0.3, 1), "BETTER": (2, 6), "BEST": (6, 10)}}
FIT_RES = 64
# FIT_SOURCES' hair regions at FIT_RES and DEFAULT_SAMPLES, rendered by scripts/render_fit_regions.py: a render in the
# panel's click took 2 s and could meet a material preview's render thread (Blender 4.3 then deadlocks).
FIT_REGIONS = "hair_fit_regions.npz"
# The statistics leave looks ambiguous (a thin white layer with a strong coat can show the lips' colour too): each
# unit of distance from the fit's start (the encoder's estimate or Fast's) costs this many CIELAB units, so the fit
# keeps that reading where the photo does not ask for another. Hair statistics depend on the swatch alone (the stage
# matches the hair's histogram to it), not on a scene: a weaker pull lets the fit go further.
PRIOR_WEIGHT = {"lipstick": 8.0, "hair": 2.0}
# Whether Fast fits the colour imitator after the encoder (benchmarks/results/light.md). Lips: the fit moves the
# estimate until the default scene shows the photo's colour, light and skin included, and loses to the encoder alone
# on renders with the source hidden (-5.3 dB): Fast is the encoder's estimate of the photo with its light taken out
# (+0.06 and -0.13 dB against the encoder alone at seeds 9001 and 4242).
# Hair: the stage matches the hair to the swatch whatever the scene, and the fit gains (+9.7 dB, hair_encoder.md).
FAST_FITS = {"lipstick": False, "hair": True}
HUE_TURNS = (0.0, 0.25, 0.5, 0.75)  # where on the hue circle Fast's colour fit starts, from the encoder's hue
# Fast's colour fits whose squared miss of the photo's statistics is within this share of the least are a tie (the
# one nearest the encoder's estimate is kept). Against the least miss alone, on renders with the source hidden
# (seed 9001) 33.80 dB against 33.74; on the 18 portraits against the hand-drawn hair a median 3.07 against 3.14
# CIEDE2000 (tight crops 2.43 against 2.57); tilted -45..45 degrees, 8 portraits moved a median 0.60 against 0.79.
NEAR_TIE = 0.15
# Hair Fast's colour fit then polishes its mean colour on the real stage (iter_polish_colour): the imitator is a few
# CIELAB units off where some fits settle (a grey hair at saturation 0 read as green), and which of its near-equal
# valleys a fit settles in turns on the fourth decimal of the photo's statistics. Renders of the default region (~10 ms
# each, the region rendered once a session) judge and correct it. Lips Fast does not fit (FAST_FITS).
FAST_POLISH = {"lipstick": 0, "hair": 3}
POLISH_DAMPING = 0.01  # Marquardt damping of the polish's steps (a share of the Gauss-Newton matrix's diagonal)
POLISH_SHORTER = 10.0  # the damping grows this much after a step whose render went no nearer
# The qualities the panel offers: those that beat the one below them. Hair: on renders with the source hidden
# (light.md). Lips: on products tried on the held-out faces and read back (photo_sources.md, the round trip), where
# Better, fitted in the photo's own scene, gains 1.1 dB over Fast; Best (4x the renders) gains 0.9, no more than
# Better, so it stays on `vto match --quality best`.
OFFERED = {"lipstick": ("FAST", "BETTER"), "hair": QUALITIES}
NOT_OFFERED = {"lipstick": "Best: no closer than Better for lips"}  # what the panel says of a quality it leaves out


def parameter_difference(unit: np.ndarray, start: np.ndarray, wraps: np.ndarray) -> np.ndarray:
    """unit - start (m,), wrapping dimensions (hue) the short way round the circle."""
    difference = np.asarray(unit, np.float64) - np.asarray(start, np.float64)
    return np.where(wraps, (difference + 0.5) % 1.0 - 0.5, difference)


@functools.lru_cache(maxsize=16)
def _hair_region(source: int, res: int, samples: int):
    """blender_addon.renderers.hair.HairSource of default-scene `source`'s hair region: FIT_SOURCES' at FIT_RES and
    DEFAULT_SAMPLES as shipped (FIT_REGIONS: hair's fits render nothing in Cycles), any other rendered now."""
    from ..renderers.hair import HairSource, render_hair_source

    if source in FIT_SOURCES and res == FIT_RES and samples == DEFAULT_SAMPLES:
        with np.load(DATA / FIT_REGIONS) as regions:
            return HairSource(regions[f"rgb_{source}"].astype(np.float32),
                              regions[f"mask_{source}"].astype(np.float32))
    return render_hair_source(source, res, samples, 0)


def region_renderer(renderer: str, source: int, res: int = FIT_RES, samples: int = DEFAULT_SAMPLES,
                    tones: tuple[np.ndarray, np.ndarray] | None = None
                    ) -> Callable[[dict[str, float]], tuple[np.ndarray, np.ndarray]]:
    """values -> (render (res, res, 3), its region mask (res, res)) on default-scene `source`: the lips (their skin
    and bare lips in `tones`, sRGB (3,) each, where given), or the hair of a hair region (rendered once per
    process)."""
    if renderer == "lipstick":
        from ..renderers.lipstick import render_lipstick
        from ..renderers.scene_lips import lips_mask

        mask = lips_mask(source, res)
        return lambda values: (render_lipstick(values, source, res, samples, 0, tones=tones), mask)
    from ..renderers.hair import run_hair_stage

    hair = _hair_region(source, res, samples)
    return lambda values: (run_hair_stage(hair, values), hair.mask)


def photo_values(spec: RendererSpec, values: dict[str, float]) -> dict[str, float]:
    """The values with what a photo fixes: for hair, full effect (PHOTO_HAIR)."""
    return {**values, **PHOTO_HAIR} if spec.renderer == "hair" else dict(values)


def fit_start(spec: RendererSpec, start: dict[str, float]) -> tuple[np.ndarray, np.ndarray, dict[int, float] | None]:
    """Where a photo fit starts: the unit vector (m,) of `start` with what a photo fixes, the wrapping dimensions (m,)
    and the held ones (hair: intensity and blend at full effect where modelled,
    blender_addon.renderers.hair.own_source_held)."""
    unit = spec.normalise(spec.vector(photo_values(spec, start)))
    wraps = np.array([p.wraps for p in spec.modelled_params])
    if spec.renderer != "hair":
        return unit, wraps, None
    from ..renderers.hair import own_source_held

    return unit, wraps, own_source_held(spec, start)


_LIPS_POOLS: dict[tuple[int, int], tuple] = {}


def iter_lips_pool(res: int, samples: int):
    """The lipstick fit's candidate sources, rendered bare once per session and size: (seed, its skin's mean CIELAB
    (3,), its skin's mean linear RGB (3,)) each (vto_core.appearance.skin_light, skin_colour). A generator: yields 0
    after each source (the UI stays live; these renders are not the fit's), returns the pool."""
    from vto_core.appearance import skin_colour, skin_light

    from ..renderers.lipstick import render_lipstick
    from ..renderers.scene_lips import lips_mask

    if (res, samples) not in _LIPS_POOLS:
        pool = []
        for seed in LIPS_POOL:
            mask = lips_mask(seed, res)
            bare = render_lipstick({"opacity": 0.0}, seed, res, samples, 0)
            pool.append((seed, skin_light(bare, mask)[1], skin_colour(bare, mask)))
            yield 0
        _LIPS_POOLS[(res, samples)] = tuple(pool)
    return _LIPS_POOLS[(res, samples)]


def fitted_tones(seed: int, rendered_skin: np.ndarray, photo_skin: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Skin and bare-lips sRGB tones (3,) for default source `seed` such that its rendered skin, whose mean linear
    RGB with its own tone is `rendered_skin` (3,), shows `photo_skin` (3,, linear): the seed's skin tone scaled per
    channel (within MAX_TONE_RATIO), the lips the scene's typical lips for that skin (scene_lips.lip_tone)."""
    from vto_core.colour import linear_to_srgb, srgb_to_linear

    from ..renderers.scene_lips import lip_tone, source_tones

    ratio = np.clip(np.asarray(photo_skin, np.float64) / np.maximum(rendered_skin, 1e-6), 1 / MAX_TONE_RATIO,
                    MAX_TONE_RATIO)
    skin = linear_to_srgb(np.clip(srgb_to_linear(source_tones(seed)[0]) * ratio, 0.0, 1.0))
    return skin, lip_tone(skin)


def iter_lips_fit_sources(region: tuple[np.ndarray, np.ndarray], count: int, res: int, samples: int):
    """The `count` default lips sources whose skin looks most like the photo's (CIEDE2000 of the skin around the
    lips), each toned (fitted_tones) so its skin shows the photo's skin colour. A generator (iter_lips_pool's
    yields); returns [render fn (region_renderer)]."""
    from vto_core.appearance import skin_colour, skin_light
    from vto_core.colour import ciede2000

    light, photo_skin = skin_light(*region), skin_colour(*region)
    pool = yield from iter_lips_pool(res, samples)
    if light is None:  # a close crop shows no skin: the first sources as they are
        return [region_renderer("lipstick", seed, res, samples) for seed, _, _ in pool[:count]]
    order = np.argsort([ciede2000(light[1], lab) for _, lab, _ in pool])
    return [region_renderer("lipstick", pool[i][0], res, samples, fitted_tones(pool[i][0], pool[i][2], photo_skin))
            for i in order[:count]]


def iter_fit_photo(spec: RendererSpec, region: tuple[np.ndarray, np.ndarray], start: dict[str, float], quality: str,
                   res: int = FIT_RES, samples: int = DEFAULT_SAMPLES, others: tuple[dict[str, float], ...] = (),
                   photo: tuple[np.ndarray, object] | None = None):
    """Fit the modelled parameters so the default scene's lips (or hair) show the colour statistics
    (vto_core.appearance.region_statistics) of `region` (the photo (H, W, 3) and its lips or hair mask (H, W)), with
    the sources and renders of FIT_QUALITY[renderer][quality].

    The fit starts from `start` (modelled raw values) or, where `others` gives more candidates, from the candidate
    whose render already shows the photo's statistics best (each costs one render a source, inside the budget); the
    fit keeps near that start where the photo does not ask otherwise (PRIOR_WEIGHT). Match passes the encoder's
    estimate and Fast's: on renders the encoder's is the better start (Fast has read the reference's light into the
    look), on real photos mostly Fast's (the lipstick model card).
    Lips: the sources are those of LIPS_POOL whose skin looks most like the photo's, toned so their skin shows the
    photo's skin colour (a scene whose light and skin tone are fitted, as far as the skin shows them; the bare lips
    follow the skin). Hair: FIT_SOURCES' hair regions, as rendered.
    photo: (the whole photo (H, W, 3), the lips found in it): lips of a face are fitted in the photo's own scene
    instead (blender_addon.matching.photo_scene_fit), from Fast's estimate (the last of `others`, else `start`).
    A generator: yields renders made so far (0 while the first fit of a session renders its lips sources); returns
    the fitted modelled values (raw, inside their ranges).
    """
    from vto_core.appearance import region_statistics

    from .refine import iter_refine_by_render

    table = FIT_QUALITY[spec.renderer]
    if quality not in table:
        raise VtoError(f"a photo fit's quality is {' or '.join(table)}, got '{quality}'")
    if spec.renderer == "lipstick" and photo is not None:
        from .photo_scene_fit import SCENE_FIT, iter_fit_photo_scene, scene_target

        target = scene_target(*photo, SCENE_FIT[quality][0])
        if target is not None:
            return (yield from iter_fit_photo_scene(spec, target, (others or (start,))[-1], quality, samples))
    count, renders = table[quality]
    if spec.renderer == "lipstick":
        sources = yield from iter_lips_fit_sources(region, count, res, samples)
    else:
        sources = [region_renderer(spec.renderer, seed, res, samples) for seed in FIT_SOURCES[:count]]
    photo = region_statistics(*region)

    def shown(values: dict[str, float]) -> np.ndarray:
        return np.mean([region_statistics(*render(spec.full_values(photo_values(spec, values)))) for render in sources],
                       axis=0)

    candidates = [start, *(other for other in others if other != start)]
    evaluations = renders // count
    if len(candidates) > 1:
        distances = []
        for candidate in candidates:
            distances.append(float(np.linalg.norm(shown(candidate) - photo)))
            yield count * len(distances)
        start, evaluations = candidates[int(np.argmin(distances))], evaluations - len(candidates)
    unit, wraps, held = fit_start(spec, start)

    def statistics_at(trial: np.ndarray) -> np.ndarray:
        seen = shown(spec.values(spec.denormalise(trial)))
        return np.concatenate([seen, PRIOR_WEIGHT[spec.renderer] * parameter_difference(trial, unit, wraps)])

    spent = renders // count - evaluations
    steps = iter_refine_by_render(statistics_at, np.concatenate([photo, np.zeros(spec.size)]), unit, evaluations,
                                  wraps=wraps, held=held, search="fit")
    while True:
        try:
            yield count * (spent + next(steps))
        except StopIteration as done:
            fitted = spec.values(spec.denormalise(done.value.unit))
            return {name: float(fitted[name]) for name in spec.modelled}


def colour_imitator_path(renderer: str) -> Path:
    """The shipped colour imitator of `renderer`: blender_addon/models/<renderer>_colour.onnx."""
    return MODELS / f"{renderer}_colour.onnx"


def fast_polish_passes(renderer: str) -> int:
    """The stage passes Fast's polish takes for `renderer` (FAST_POLISH; none where Fast does not fit, FAST_FITS)."""
    return FAST_POLISH[renderer] if FAST_FITS[renderer] else 0


def iter_fit_photo_fast(spec: RendererSpec, region: tuple[np.ndarray, np.ndarray], start: dict[str, float],
                        imitator_path: Path | None = None, quality: str = "FAST"):
    """Fast: the encoder's estimate `start` (modelled raw values) as it is where FAST_FITS says the colour fit does
    not pay, else fit_colour's, its mean colour then polished on the real stage (iter_polish_colour, FAST_POLISH
    renders; nothing of them left in the .blend) where `quality`, the Match's, is FAST (Better and Best start from the
    fit unpolished: their figures were measured from it). A generator: yields the polish's renders made so far (the
    panel runs them between redraws), returns the values and a note for the user ("" when none)."""
    if not FAST_FITS[spec.renderer]:
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
    fits = imitator.fit(target, starts, PRIOR_WEIGHT[spec.renderer], wraps, held, skin)
    misses = ((imitator.statistics(fits, skin) - target) ** 2).sum(axis=1)
    distances = (parameter_difference(fits, unit, wraps) ** 2).sum(axis=1)
    found = fits[np.argmin(np.where(misses <= misses.min() * (1 + NEAR_TIE), distances, np.inf))]
    fitted = spec.values(spec.denormalise(found))
    return {name: float(fitted[name]) for name in spec.modelled}, ""


def iter_polish_colour(spec: RendererSpec, region: tuple[np.ndarray, np.ndarray], start: dict[str, float],
                       imitator_path: Path | None = None, renders: int | None = None, res: int = FIT_RES,
                       samples: int = DEFAULT_SAMPLES):
    """The modelled values (raw) near `start` whose render on the default scene (FIT_SOURCES[0]'s region) shows the
    photo region's mean colour: Gauss-Newton on that colour's CIELAB, its residual from real renders, its Jacobian
    from the colour imitator's mean; `renders` (FAST_POLISH) renders in all, each judging the step before it, and the
    values whose render came nearest (CIEDE2000) are kept (`start` where no step came nearer); a step that came no
    nearer is retried shorter from the best. A generator: yields renders made so far, returns the modelled values."""
    from vto_core.appearance import mean_colour
    from vto_core.colour import ciede2000, srgb_to_lab
    from vto_core.colour_imitator import STEP, cached_imitator

    imitator = cached_imitator(colour_imitator_path(spec.renderer) if imitator_path is None else imitator_path)
    render = region_renderer(spec.renderer, FIT_SOURCES[0], res, samples)
    photo = srgb_to_lab(mean_colour(*region)).astype(np.float64)
    unit, wraps, held = fit_start(spec, start)
    free = np.array([i not in (held or {}) for i in range(spec.size)])
    probes = STEP * np.eye(spec.size)[free]  # (f, m)
    best, best_miss, best_shown, damping = unit, np.inf, None, POLISH_DAMPING
    count = FAST_POLISH[spec.renderer] if renders is None else renders
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


def apparent_colour(renderer: str, values: dict[str, float], sources=range(8), res: int = FIT_RES,
                    samples: int = DEFAULT_SAMPLES) -> dict[str, np.ndarray]:
    """The colour an estimate gives the default scene, as the real-photo benchmark reads it: over default `sources`,
    the median of its region's mean colour ('mean') and of its per-channel median colour ('body', without highlights
    and shadows) in the render of `values` (all parameters); each (3,) display values in [0, 1]."""
    from vto_core.appearance import body_colour, mean_colour

    regions = [region_renderer(renderer, source, res, samples)(values) for source in sources]
    return {"mean": np.median([mean_colour(*region) for region in regions], axis=0),
            "body": np.median([body_colour(*region) for region in regions], axis=0)}
