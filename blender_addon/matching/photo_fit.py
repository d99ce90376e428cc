"""Better and Best for a photo whose scene is unknown (its light already taken out, vto_core.photo.photo_reader):
the estimate fitted through the real renderer, on default-scene sources, to what the photo shows of the material.

A photo of real lips (or of an artist's reference hair) has no source X to render the estimate on, so the render
cannot be compared with it pixel by pixel. What can be compared is the region's colour statistics
(vto_core.appearance: its mean colour, the spread of its lightness up to the highlights, its chroma): the fit
(Levenberg-Marquardt from the encoder's estimate or Fast's, with a pull back towards it) moves the parameters until
the default scene's lips (or hair) show the photo's statistics, rendered (blender_addon.matching.refine's fit) on the
product's fit sources (ProductRenderer.iter_fit_sources: lips on the sources whose skin looks most like the photo's,
toned so the render's skin shows the photo's skin colour). Those sources are seeds of their own, never the ones the
benchmarks measure the estimate on. Fast is blender_addon.matching.colour_fit; what each quality costs and which are
offered is the product's FitPolicy (vto_core.products).

Lips of a face in a portrait do have a scene: Better and Best then fit there instead, pixel by pixel, each candidate
tried on the photo's own lips (blender_addon.matching.photo_scene_fit). The default-scene fit is left for lips without
a face (a close-up, a mask) or without skin beside them.
"""

from __future__ import annotations


import numpy as np

from vto_core.dataset import DEFAULT_SAMPLES
from vto_core.errors import VtoError
from vto_core.products import get_product
from vto_core.specs import RendererSpec

from ..renderers.products import FIT_RES, blender_side

NO_REGION = ("fits the colour of the lips and needs to know where they are: let the add-on find them (Find Lips), or "
             "give a mask")


def parameter_difference(unit: np.ndarray, start: np.ndarray, wraps: np.ndarray) -> np.ndarray:
    """unit - start (m,), wrapping dimensions (hue) the short way round the circle."""
    difference = np.asarray(unit, np.float64) - np.asarray(start, np.float64)
    return np.where(wraps, (difference + 0.5) % 1.0 - 0.5, difference)


def region_renderer(renderer: str, source: int, res: int = FIT_RES, samples: int = DEFAULT_SAMPLES, tones=None):
    """values -> (render (res, res, 3), its region mask (res, res)) on default-scene `source` of product `renderer`
    (blender_addon.renderers.products.ProductRenderer.region_renderer)."""
    return blender_side(renderer).region_renderer(source, res, samples, tones)


def photo_values(spec: RendererSpec, values: dict[str, float]) -> dict[str, float]:
    """The values with what a photo fixes (the product's photo_fixes: for hair, full effect)."""
    return get_product(spec.renderer).photo_values(values)


def fit_start(spec: RendererSpec, start: dict[str, float]) -> tuple[np.ndarray, np.ndarray, dict[int, float] | None]:
    """Where a photo fit starts: the unit vector (m,) of `start` with what a photo fixes, the wrapping dimensions (m,)
    and the held ones (what a photo fixes, where modelled: ProductRenderer.fit_held)."""
    unit = spec.normalise(spec.vector(photo_values(spec, start)))
    wraps = np.array([p.wraps for p in spec.modelled_params])
    return unit, wraps, blender_side(spec.renderer).fit_held(spec, start)


def iter_fit_photo(spec: RendererSpec, region: tuple[np.ndarray, np.ndarray], start: dict[str, float], quality: str,
                   res: int = FIT_RES, samples: int = DEFAULT_SAMPLES, others: tuple[dict[str, float], ...] = (),
                   photo: tuple[np.ndarray, object] | None = None):
    """Fit the modelled parameters so the default scene's lips (or hair) show the colour statistics
    (vto_core.appearance.region_statistics) of `region` (the photo (H, W, 3) and its lips or hair mask (H, W)), with the
    sources and renders of the product's FitPolicy.renders[quality].

    The fit starts from `start` (modelled raw values) or, where `others` gives more candidates, from the candidate whose
    render already shows the photo's statistics best (each costs one render a source, inside the budget); the fit keeps
    near that start where the photo does not ask otherwise (FitPolicy.prior_weight). Match passes the encoder's estimate
    and Fast's: on renders the encoder's is the better start (Fast has read the reference's light into the look), on
    real photos mostly Fast's (the lipstick model card). Lips: the sources are those of LIPS_POOL whose skin looks most
    like the photo's, toned so their skin shows the photo's skin colour (a scene whose light and skin tone are fitted,
    as far as the skin shows them; the bare lips follow the skin). Hair: its fit sources' hair regions, as rendered
    (ProductRenderer.iter_fit_sources). photo: (the whole photo (H, W, 3), (FaceRegion, RegionFound) of the region
    found in it, or None): a face's lips (lids) are fitted in the photo's own scene instead (blender_addon.matching.photo_scene_fit), from Fast's estimate (the last of
    `others`, else `start`). A generator: yields renders made so far (0 while the first fit of a session renders its
    lips sources); returns the fitted modelled values (raw, inside their ranges)."""
    from vto_core.appearance import region_statistics

    from .refine import iter_refine_by_render

    product = get_product(spec.renderer)
    table = product.fit.renders
    if quality not in table:
        raise VtoError(f"a photo fit's quality is {' or '.join(table)}, got '{quality}'")
    if product.kind.fits_in_photo_scene and photo is not None:
        from .photo_scene_fit import SCENE_FIT, iter_fit_photo_scene, scene_target

        target = scene_target(*photo, SCENE_FIT[quality][0])
        if target is not None:
            return (yield from iter_fit_photo_scene(spec, target, (others or (start,))[-1], quality, samples))
    count, renders = table[quality]
    sources = yield from blender_side(product).iter_fit_sources(region, count, res, samples)
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
        return np.concatenate([seen, product.fit.prior_weight * parameter_difference(trial, unit, wraps)])

    spent = renders // count - evaluations
    steps = iter_refine_by_render(statistics_at, np.concatenate([photo, np.zeros(spec.size)]), unit, evaluations,
                                  wraps=wraps, held=held, search="fit")
    while True:
        try:
            yield count * (spent + next(steps))
        except StopIteration as done:
            fitted = spec.values(spec.denormalise(done.value.unit))
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
