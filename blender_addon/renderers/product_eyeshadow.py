"""The eye shadow's Blender side: the VTO Eye Shadow group in a material, the default eye scene."""

from __future__ import annotations

import numpy as np

from vto_core.errors import VtoError
from vto_core.products import EYESHADOW

from .products import BoundSource, ProductRenderer

# Default-scene seeds the photo fits render on: apart from the benchmarks' sources 0-7 and eval's 5000 and up.
EYE_POOL = tuple(range(900001, 900025))
DARK_SHADOW = 60.0  # max(R, G, B) below this (of 255) is a very dark shade (the smoky blacks)


class EyeShadowRenderer(ProductRenderer):
    """VTO Eye Shadow: a shader node group in a material, rendered with Cycles on the default eye scene."""

    product = EYESHADOW
    fit_sources = EYE_POOL

    def bind(self, source, res, samples, seed, lighting=None):
        from .eyeshadow import render_eyeshadow
        from .scene_eyes import eyelid_mask

        self.check_source(source)
        source = int(source)

        def render(values):
            return render_eyeshadow(values, source, res, samples, seed, lighting=lighting)

        return BoundSource(render, lambda: render({"opacity": 0.0}), lambda: eyelid_mask(source, res, lighting))

    def region_renderer(self, source, res, samples, tones=None):
        from .eyeshadow import render_eyeshadow
        from .scene_eyes import eyelid_mask

        mask = eyelid_mask(source, res)
        return lambda values: (render_eyeshadow(values, source, res, samples, 0), mask)

    def iter_fit_sources(self, region, count, res, samples):
        """The first `count` default eye sources of EYE_POOL, as they are (the photo's skin and light are not read
        yet: the eyes' try-on on portraits is the next issue)."""
        return [self.region_renderer(seed, res, samples) for seed in EYE_POOL[:count]]
        yield  # a generator, as the other products' (nothing to wait for)

    def nodes(self, material):
        from .eyeshadow import material_nodes

        return material_nodes(material)

    def material(self, name, values=None):
        from .nodes_eyeshadow import eyeshadow_material

        return eyeshadow_material(name, values)

    def add_group(self, obj):
        """A new "VTO Eye Shadow" material on `obj` (a mesh): a Principled BSDF (the bare lid) -> the eye-shadow group
        -> Material Output, appended to its slots and made active. Returns the material."""
        if obj is None or obj.type != "MESH":
            raise VtoError("select a mesh object to add the eye-shadow material to")
        material = self.material("VTO Eye Shadow")
        obj.data.materials.append(material)
        obj.active_material_index = len(obj.material_slots) - 1
        return material

    def where(self, material):
        return f"material '{material.name}'"

    def missing_group(self, material):
        return (f"material '{material.name}' does not use the 'VTO Eye Shadow' node group (add one with Add VTO Eye "
                "Shadow Material, or put one between the lid's shader and the Material Output)")

    def is_dark(self, values):
        return max(values["red"], values["green"], values["blue"]) < DARK_SHADOW

    def dataset_images(self, values, source, res, samples, cycles_seed, options):
        from .eyeshadow import render_eyeshadow
        from .scene_eyes import eyelid_mask

        def draw(v):
            return render_eyeshadow(v, source, res, samples, cycles_seed, scene=options.get("scene"),
                                    lighting=options.get("lighting"))

        bare = draw({**values[0], "opacity": 0.0}) if options.get("source_images", True) else None
        extra = {}
        if options.get("masks"):
            extra["mask"] = eyelid_mask(source, res, options.get("lighting")).astype(np.float32)
        return bare, [draw(v) for v in values], extra


RENDERER = EyeShadowRenderer()
