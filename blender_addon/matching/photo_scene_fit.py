"""Better and Best in the photo's own scene (lips; an eye's lid): each candidate rendered onto this photo's region (its
face mesh, its light, the bare region under the layer: the try-on, blender_addon.renderers.tryon) and compared with the
photo pixel by pixel. Written for the lips; a lid is read alike, its bare colour guessed from the cheek below it
(PhotoLayer.skin, .bare).

A made-up photo does not show its bare lips, and with the photo's own lips under the layer no product at all
(opacity 0) would reproduce the photo. So what lies under the layer is made from the photo: Fast's product divided
out of the photo's lips (their shading and lines stay), scaled to the colour of the bare lips that the skin beside
them predicts (vto_core.photo.bare_lips); the scene's bare lips take that colour, so under an opaque product the
guess divides out and only a thin one shows it. Where the lips found reach past the paint (a pixel or two of skin, or
lips the layer missed), dividing the product out leaves a colour no lips have: those pixels are trusted less
(under_layer). Each candidate's try-on (vto_core.photo.tryon.composite, clipped as a photo is) is compared with the
photo over the trusted core of the lips, in sRGB levels, by Levenberg-Marquardt (blender_addon.matching.refine) on
a Cauchy loss of each pixel's distance (ROBUST_SCALE: the few pixels no candidate renders, past the paint's edge, cost
little, so they cannot pull the whole layer thinner and lighter), from Fast's estimate, which is kept unless a
candidate renders closer; each unit of distance from Fast costs SCENE_PRIOR levels, so where the photo cannot tell
(a thin layer over lips of an unknown colour) the estimate stays near what the encoder read. Where the guess of the
bare region is poor (a lid: PhotoLayer.bare_spread), its level is fitted beside the product, at a cost that grows
with its distance from the guess in spreads (bare_share, LEVEL_RANGE).
"""

from __future__ import annotations

import numpy as np

from vto_core.colour import linear_to_srgb, srgb_to_linear
from vto_core.dataset import DEFAULT_SAMPLES
from vto_core.errors import VtoError
from vto_core.products import get_product
from vto_core.photo.tryon import RATIO_FLOOR, composite, feathered, worn_over_bare
from vto_core.specs import RendererSpec

from .refine import SIGMA

SCENE_FIT = {"BETTER": (64, 25), "BEST": (96, 100)}  # quality -> (the lips frame's px a side, renders in all)
# sRGB levels of RMS over the lips that one unit of parameter distance from Fast costs. On 5 looks tried on a training
# face, 24 against 8 kept Better within 1.0 CIEDE2000 of Fast where Fast was right (Berry Stain: 1.0 against 4.3).
SCENE_PRIOR = 24.0
LIFT_FLOOR = 0.02  # a product's ratio is divided out as at least this (a black product would lift the noise)
# The lips found on a made-up photo are not exactly the painted ones (on one training face the two masks overlap by
# 75 %: the landmarks move a pixel or two once the lips are coloured), so the comparison leaves out a band of this
# many px inside the lips' edge. The lips are a few px thick in the frame: 2 px would leave a tenth of them.
CORE_INSET = 1
TRUST_SCALE = 0.5  # log colour: a pixel of the lips left 1.65 times off the bare lips' colour has half the trust
# A bare level fitted beside the product (PhotoLayer.bare_spread > 0) ranges over this many spreads either way of the
# guess; one spread off costs what the encoder's typical error (refine.SIGMA) costs a product parameter.
LEVEL_RANGE = 3.0
# sRGB: the least scale of the Cauchy loss each pixel's distance from the photo costs (robust; 0: squares). On 80
# development looks (8 London training people x 10 presets no benchmark uses) a fixed scale read Better 2.86 (mean
# 3.42) with squares, 2.64 at 0.03, 2.51 at 0.02, 2.57 (mean 2.92) at 0.01: the pixels past the paint (lighter than a
# dark product) had pulled a thinner, lighter coat ahead of the opaque one. A fixed scale this small left a product
# tried on 40 levels off where it started, hence the median's scale above it.
ROBUST_SCALE = 0.01


def scene_target(photo: np.ndarray, found, n: int):
    """The photo's region `found` ((FaceRegion, RegionFound) or None: the lips, the first lid read) ready to fit in its
    own scene (blender_addon.renderers.tryon.PhotoRegion at n x n px), or None where it cannot be: no face's region (a
    close-up, a mask), one too small to render onto, or no skin beside it to tell the bare region's colour."""
    from vto_core.photo.face_reader import clean_photo
    from vto_core.products import product_of_region

    from ..renderers.tryon import photo_layer, photo_region, to_render

    if found is None:
        return None
    region, where = found
    try:
        layer = photo_layer(product_of_region(region))
        target = photo_region(clean_photo(photo), to_render(where, region, layer), region, layer, n)
    except VtoError:
        return None
    if not (target.mask > 0.5).any() or target.layer.skin(target.frame, target.mask) is None:
        return None
    return target


def bare_guess(target) -> np.ndarray:
    """(3,) linear: what the bare region of `target` (scene_target) is guessed to be, from the skin beside it
    (its layer's PhotoLayer.skin and .bare), guessed in the light's own white so that the light's colour does not move
    it."""
    return target.layer.bare(target.layer.skin(target.frame, target.mask) / target.cast) * target.cast


def lips_core(mask: np.ndarray) -> np.ndarray:
    """(n, n) 0/1 -> (n, n) bool: the lips CORE_INSET px in from their edge (the whole mask where that leaves
    nothing)."""
    core = feathered(mask, CORE_INSET) >= 1.0 - 1e-6
    return core if core.any() else np.asarray(mask) > 0.5


def under_layer(frame: np.ndarray, soft: np.ndarray, core: np.ndarray, ratio: np.ndarray, bare: np.ndarray,
                core_median) -> tuple[np.ndarray, np.ndarray]:
    """What lies under the layer, and where the photo shows the layer: (the photo's frame (n, n, 3) linear with the
    product of `ratio` (n, n, 3, what Fast's estimate does to the lips) divided out inside the soft mask (n, n) and
    scaled per channel so that the median of its trusted pixels is what the `bare` lips' colour (3,) linear gives
    (times `core_median` (3,), the layer's: a bare core's median over its mean); the trust (n, n) in [0, 1] of each
    pixel of the lips' core (n, n)).

    Where the product lies, dividing it out leaves lips of about the bare lips' colour; where the lips found reach
    past the painted ones (skin, or lips the layer missed), it leaves a colour no lips have (bare lips divided by a
    pink product's ratio are dark green). A pixel's trust falls with the log-colour distance of what is left from the
    bare lips (a Cauchy weight, TRUST_SCALE). The photo's shading and lip lines stay; the product's colour and sheen
    go."""
    if not core.any():
        return np.asarray(frame, np.float32), np.zeros(core.shape, np.float32)
    lifted = frame / np.maximum(ratio, LIFT_FLOOR)
    expected = np.asarray(bare, np.float64) * np.asarray(core_median)
    distance = np.linalg.norm(np.log(np.maximum(lifted, 1e-4)) - np.log(np.maximum(expected, 1e-4)), axis=-1)
    trust = np.where(core, 1.0 / (1.0 + (distance / TRUST_SCALE) ** 2), 0.0)
    trusted = trust >= 0.5
    gain = expected / np.maximum(np.median(lifted[trusted if trusted.any() else core], axis=0), 1e-4)
    weight = soft[..., None]
    return (frame * (1 - weight) + lifted * gain * weight).astype(np.float32), trust.astype(np.float32)


def iter_fit_photo_scene(spec: RendererSpec, target, start: dict[str, float], quality: str,
                         samples: int = DEFAULT_SAMPLES, seed: int = 0):
    """Fit the product's modelled values so that, tried on `target`'s bare region (scene_target, framed at
    SCENE_FIT[quality]'s size), they show what the photo shows, with SCENE_FIT[quality]'s renders from `start` (Fast's
    modelled raw values). A generator: yields renders made so far; returns the fitted modelled values (raw)."""
    from ..renderers.scene_photo import set_bare
    from ..renderers.tryon import render_look, set_photo_region
    from .refine import iter_refine_by_render

    if quality not in SCENE_FIT:
        raise VtoError(f"a fit in the photo's scene is {' or '.join(SCENE_FIT)}, got '{quality}'")
    renders = SCENE_FIT[quality][1]
    layer, coverage = target.layer, get_product(spec.renderer).coverage
    predicted = bare_guess(target)
    scene = set_photo_region(target, samples, seed)
    set_bare(layer, predicted / target.cast)
    bare = render_look(scene, spec.full_values({coverage: 0.0}), layer)
    yield 1
    soft = feathered(target.mask)
    if bare.shape[:2] != soft.shape:
        raise VtoError(f"the photo scene rendered {bare.shape[0]} px for a {soft.shape[0]} px frame")
    core = lips_core(target.mask)
    fast = spec.full_values(start)
    under, trust = under_layer(srgb_to_linear(target.frame), soft, core,
                               worn_over_bare(bare, render_look(scene, fast, layer)), predicted, layer.core_median)
    yield 2
    # The scene's bare region takes the colour its pixels under the layer are scaled to, as the try-on's takes the
    # bare photo's mean over the region: under_layer scaled what lies under the layer so that its trusted core's median
    # is the guess times the layer's core median, which is what a bare core is over its whole mask's mean. Under an
    # opaque product the level of the region under it then divides out. Lips are painted whole, so the pixels left
    # untrusted are the paint's misses, skin divided by the product (bright orange under a dark one): their mean read
    # dark products lighter (+3 L* on 80 development looks). Where the guess is poor (a lid: bare_spread > 0) the
    # region takes what lies under the layer averaged over its whole mask instead (held-out faces: Better 2.25 against
    # 2.65 with the guess): the layer leaves the lid's top bare, and those pixels, untrusted where the guess is off,
    # likely show the real lid it misses.
    albedo, made, share = predicted / target.cast, 2, None
    if layer.bare_spread > 0:
        region = (target.mask > 0.5)[..., None]  # a bare render scales with the albedo on the region (its sheen too)
        albedo = under[region[..., 0]].mean(axis=0, dtype=np.float64) / target.cast
        set_bare(layer, albedo)
        bare = render_look(scene, spec.full_values({coverage: 0.0}), layer)
        yield 3
        share = bare_share(scene, layer, albedo, bare, {**fast, coverage: 1.0})
        made = 5
        yield made
    weights = (255.0 * np.sqrt(trust / max(float(trust.sum()), 1e-6)))[..., None]
    unit = spec.normalise(spec.vector(start))
    wraps = np.array([p.wraps for p in spec.modelled_params])
    m = unit.size
    last = {}  # the last product's render: a step of the bare level alone renders nothing

    def tried(trial: np.ndarray) -> np.ndarray:
        values = spec.full_values(spec.values(spec.denormalise(trial[:m])))
        key = trial[:m].tobytes()
        if key not in last:
            last.clear()
            last[key] = worn_over_bare(bare, render_look(scene, values, layer))
        ratio, prior = last[key], SCENE_PRIOR * (trial[:m] - unit)
        if share is not None:  # the bare region's albedo times exp(level): what it makes of each pixel scales
            level = (trial[m] - 0.5) * 2.0 * LEVEL_RANGE * layer.bare_spread
            covered = values[coverage]
            ratio = ratio + np.expm1(level) * ((1.0 - covered) * region + covered * share)
            prior = np.append(prior, SCENE_PRIOR * SIGMA * level / layer.bare_spread)
        worn = np.clip(linear_to_srgb(composite(under, ratio, soft, values[coverage])), 0.0, 1.0)  # as a photo is
        return np.concatenate([(robust(worn - target.frame, core) * weights).ravel(), prior])

    begin = unit if share is None else np.append(unit, 0.5)  # the level starts at the guess
    wraps = wraps if share is None else np.append(wraps, False)
    reference = np.zeros(target.frame.size + begin.size)
    steps = iter_refine_by_render(tried, reference, begin, renders - made, wraps=wraps, search="fit")
    while True:
        try:
            yield made + next(steps)
        except StopIteration as done:
            fitted = spec.values(spec.denormalise(done.value.unit[:m]))
            return {name: float(fitted[name]) for name in spec.modelled}


def robust(difference: np.ndarray, counted: np.ndarray) -> np.ndarray:
    """(n, n, 3) -> (n, n, 3): each pixel's difference rescaled so that its squared length is the Cauchy loss
    c^2 log(1 + (d / c)^2) of its length d, c the median length over the `counted` pixels (n, n) bool and at least
    ROBUST_SCALE (unchanged where ROBUST_SCALE is 0). With c the median, a candidate far off everywhere is still
    pulled as by squares; only pixels far off beside a close bulk cost little."""
    if ROBUST_SCALE <= 0:
        return difference
    length = np.linalg.norm(difference, axis=-1, keepdims=True)
    scale = max(ROBUST_SCALE, float(np.median(length[counted])) if counted.any() else 0.0)
    robust_length = scale * np.sqrt(np.log1p((length / scale) ** 2))
    return difference * (robust_length / np.maximum(length, 1e-12))


def bare_share(scene, layer, albedo: np.ndarray, bare: np.ndarray, values: dict[str, float]) -> np.ndarray:
    """(n, n, 3) in [0, 1]: the share of each pixel of `values`' render (an opaque look) that the bare region's
    albedo makes, over the bare render `bare` (n, n, 3) linear: 0 where the layer covers the region and outside it, 1
    on the region beyond the layer's band. Two renders, the bare region at `albedo` (3,) and at half of it: the group
    mixes the layer over the bare region's shader, so what the albedo makes is linear in it."""
    from ..renderers.scene_photo import set_bare
    from ..renderers.tryon import render_look

    worn = render_look(scene, values, layer)
    set_bare(layer, albedo * 0.5)
    halved = render_look(scene, values, layer)
    set_bare(layer, albedo)
    return np.clip(2.0 * (worn - halved) / np.maximum(bare, RATIO_FLOOR), 0.0, 1.0).astype(np.float32)
