"""The lipstick's Blender side: the VTO Lipstick group in a material, the default lips scene, its try-on on a photo."""

from __future__ import annotations

import functools

import numpy as np

from vto_core.products import LIPSTICK

from .face_layer import DefaultScene, FaceLayerRenderer
from .nodes_lipstick import LIPSTICK_GROUP
from .products import shifted_colour
from .scene_lips import apply_source, build_lips_scene, lips_mask

# Default-scene seeds the photo fits render on: apart from the benchmarks' sources 0-7 and eval's 5000 and up; the fit
# takes those whose skin is most like the photo's.
LIPS_POOL = tuple(range(900001, 900025))
MAX_TONE_RATIO = 4.0  # a source's skin tone is scaled (linear, per channel) by at most this either way
# The median of the lips' core over their whole mask's mean, per channel, in linear colour: medians over the 87
# training faces of data/faces that wear no lipstick (spread 0.09-0.13). A median is what a product's lowered
# highlights (vto_core.photo.tryon.lowered_highlights, above the 0.7 quantile) and a photo's clipped ones leave as it
# was; the bare lips (vto_core.photo.bare_lips) are a whole mask's mean.
CORE_MEDIAN = (1.15, 1.09, 1.13)
# px across the lips (along the face): narrower lips are too small to render onto (a product a few pixels across). The
# astronaut's, in a 512 px portrait, are 48.
MIN_LIPS_WIDTH = 40

_LIPS_POOLS: dict[tuple[int, int], tuple] = {}


def iter_lips_pool(res: int, samples: int):
    """The lipstick fit's candidate sources, rendered bare once per session and size: (seed, its skin's mean CIELAB
    (3,), its skin's mean linear RGB (3,)) each (vto_core.appearance.skin_light, skin_colour). A generator: yields 0
    after each source (the UI stays live; these renders are not the fit's), returns the pool."""
    from vto_core.appearance import skin_colour, skin_light

    if (res, samples) not in _LIPS_POOLS:
        pool = []
        for seed in LIPS_POOL:
            mask = lips_mask(seed, res)
            bare = RENDERER.render_scene(LIPSTICK.bare({}), seed, res, samples, 0)
            pool.append((seed, skin_light(bare, mask)[1], skin_colour(bare, mask)))
            yield 0
        _LIPS_POOLS[(res, samples)] = tuple(pool)
    return _LIPS_POOLS[(res, samples)]


def fitted_tones(seed: int, rendered_skin: np.ndarray, photo_skin: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Skin and bare-lips sRGB tones (3,) for default source `seed` such that its rendered skin, whose mean linear
    RGB with its own tone is `rendered_skin` (3,), shows `photo_skin` (3,, linear): the seed's skin tone scaled per
    channel (within MAX_TONE_RATIO), the lips the scene's typical lips for that skin (scene_lips.lip_tone)."""
    from vto_core.colour import linear_to_srgb, srgb_to_linear

    from .scene_lips import lip_tone, source_tones

    ratio = np.clip(np.asarray(photo_skin, np.float64) / np.maximum(rendered_skin, 1e-6), 1 / MAX_TONE_RATIO,
                    MAX_TONE_RATIO)
    skin = linear_to_srgb(np.clip(srgb_to_linear(source_tones(seed)[0]) * ratio, 0.0, 1.0))
    return skin, lip_tone(skin)


class LipstickRenderer(FaceLayerRenderer):
    """VTO Lipstick: a shader node group in a material, rendered with Cycles on the default lips scene."""

    product = LIPSTICK
    fit_sources = LIPS_POOL
    layer_group = LIPSTICK_GROUP
    scene = DefaultScene(build_lips_scene, apply_source)

    def iter_fit_sources(self, region, count, res, samples):
        """The `count` default lips sources whose skin looks most like the photo's (CIEDE2000 of the skin around the
        lips), each toned (fitted_tones) so its skin shows the photo's skin colour."""
        from vto_core.appearance import skin_colour, skin_light
        from vto_core.colour import ciede2000

        light, photo_skin = skin_light(*region), skin_colour(*region)
        pool = yield from iter_lips_pool(res, samples)
        if light is None:  # a close crop shows no skin: the first sources as they are
            return [self.region_renderer(seed, res, samples) for seed, _, _ in pool[:count]]
        order = np.argsort([ciede2000(light[1], lab) for _, lab, _ in pool])
        return [self.region_renderer(pool[i][0], res, samples, fitted_tones(pool[i][0], pool[i][2], photo_skin))
                for i in order[:count]]

    @functools.cached_property
    def photo_layer(self):
        """The lips as the photo scene renders them (blender_addon.renderers.tryon): the lips mesh of the face mesh."""
        from vto_core.photo.bare_lips import bare_lips
        from vto_core.photo.tryon import lips_mesh

        from .scene_photo import PhotoLayer

        return PhotoLayer("Lips", "lipstick", LIPSTICK_GROUP.name, LIPSTICK_GROUP.material, LIPSTICK_GROUP.bare_node,
                          lambda points, depth, region: lips_mesh(points, depth), MIN_LIPS_WIDTH, bare=bare_lips,
                          core_median=CORE_MEDIAN)

    # The bare lips' tone: the skin's shifted by scene_lips.LIP_TONE_SHIFT times a factor drawn in LIP_SHIFT_RANGE.
    bare_tone_step = 0.1
    bare_tone_prior = 0.7**2 / 12

    def bare_tone(self, offset):
        import bpy

        from .scene_lips import LIP_TONE_SHIFT, LIPS_MATERIAL

        socket = bpy.data.materials[LIPS_MATERIAL].node_tree.nodes["Bare Lips"].inputs["Base Color"]
        return shifted_colour(socket, lambda tone: np.clip(tone + offset * np.array(LIP_TONE_SHIFT), 0.02, 1.0))


RENDERER = LipstickRenderer()
render_lipstick = RENDERER.render_scene  # R(X, g) on the default lips scene (FaceLayerRenderer.render_scene)
