"""The eye shadow's Blender side: the VTO Eye Shadow group in a material, the default eye scene."""

from __future__ import annotations

import functools

import numpy as np

from vto_core.appearance import skin_below
from vto_core.products import EYESHADOW

from .face_layer import DefaultScene, FaceLayerRenderer
from .nodes_eyeshadow import EYESHADOW_GROUP
from .products import shifted_colour
from .scene_eyes import apply_source, build_eye_scene

# Default-scene seeds the photo fits render on: apart from the benchmarks' sources 0-7 and eval's 5000 and up.
EYE_POOL = tuple(range(900001, 900025))
# The bare lid over the skin below it (vto_core.appearance.skin_below of the 64 px lid frame: the per-channel median of
# the cheek under the eye, which a fringe of hair or the brows over the lid do not reach), per channel, linear: medians
# over the 190 lids found on the 98 training faces of data/faces; and the median of the lid's core over its mean. What
# Better and Best put under the layer (photo_scene_fit). Reproduce: scripts/measure_bare_lid.py.
BARE_LID_RATIO = (0.588, 0.585, 0.592)
LID_CORE_MEDIAN = (1.013, 0.994, 0.984)
# How far a face's bare lid is from that guess: the robust standard deviation (interquartile range / 1.35) of the log of
# the lid core's median over the guess (times LID_CORE_MEDIAN), on those 190 lids (0.38, 0.45, 0.47 for R, G, B; the 5 %
# and 95 % points are 0.37 and 1.54 times the guess: lids are shadowed, oily, or lit from above). The skin all around
# the lid (its mean, the brow bone and temple too) read 0.40, 0.48, 0.50 here, and 0.31, 0.37, 0.42 on the held-out
# faces against the cheek's 0.28, 0.26, 0.30: a fringe over the brow darkened it. Too wide to trust still, so Better and
# Best fit the bare lid's level beside the shade, which the lid's top shows where the shade's band leaves it.
BARE_LID_SPREAD = 0.45
# px across a lid (along the face): narrower lids are too small to render onto. The astronaut's, in a 512 px portrait,
# are 30; the 18 portraits' 29-141.
MIN_LID_WIDTH = 24


class EyeShadowRenderer(FaceLayerRenderer):
    """VTO Eye Shadow: a shader node group in a material, rendered with Cycles on the default eye scene."""

    product = EYESHADOW
    fit_sources = EYE_POOL
    layer_group = EYESHADOW_GROUP
    scene = DefaultScene(build_eye_scene, apply_source)
    add_hint = ", or put one between the lid's shader and the Material Output"

    def iter_fit_sources(self, region, count, res, samples):
        """The first `count` default eye sources of EYE_POOL, as they are (Better and Best on a portrait fit in the
        photo's own scene instead; these serve a lid given without its face)."""
        return [self.region_renderer(seed, res, samples) for seed in EYE_POOL[:count]]
        yield  # a generator, as the other products' (nothing to wait for)

    @functools.cached_property
    def photo_layer(self):
        """Each eye's lid as the photo scene renders it (blender_addon.renderers.tryon): a patch on its face-mesh loop,
        with the lid coordinates the group reads."""
        from vto_core.photo.tryon import lid_mesh

        from .nodes_eyeshadow import ACROSS_ATTRIBUTE, LID_ATTRIBUTE
        from .scene_photo import PhotoLayer

        def attributes(uvs):  # u: 0 at the outer end, 1 at the inner; across: 1 at the outer end, -1 at the inner
            return {LID_ATTRIBUTE: uvs[:, 1], ACROSS_ATTRIBUTE: 1.0 - 2.0 * uvs[:, 0]}

        return PhotoLayer("Eyelid", "eyeshadow", EYESHADOW_GROUP.name, EYESHADOW_GROUP.material,
                          EYESHADOW_GROUP.bare_node, lid_mesh, MIN_LID_WIDTH, attributes,
                          bare=lambda skin: np.asarray(skin, np.float64) * BARE_LID_RATIO, skin=skin_below,
                          core_median=LID_CORE_MEDIAN, bare_spread=BARE_LID_SPREAD)

    # The bare lid's tone: the skin's times scene_eyes.LID_TONE times a factor drawn in 0.95-1.05.
    bare_tone_step = 0.02
    bare_tone_prior = 0.1**2 / 12

    def bare_tone(self, offset):
        import bpy

        from .scene_eyes import LID_MATERIAL

        socket = bpy.data.materials[LID_MATERIAL].node_tree.nodes["Lid Or Skin"].inputs[6]  # the lid's own tone
        return shifted_colour(socket, lambda tone: np.clip(tone * (1.0 + offset), 0.0, 1.0))


RENDERER = EyeShadowRenderer()
render_eyeshadow = RENDERER.render_scene  # R(X, g) on the default eye scene (FaceLayerRenderer.render_scene)
