"""The hair colour's Blender side: the VTO Hair Swatch / Color compositor stage, the default hair scene, hair photos."""

from __future__ import annotations

import functools
import os
from pathlib import Path

import numpy as np

from vto_core.dataset import DEFAULT_SAMPLES
from vto_core.errors import VtoError
from vto_core.products import HAIR

from ..shipped import DATA
from .products import FIT_RES, BoundSource, ProductRenderer, is_seed

# Default-scene seeds the photo fits render on, in order: apart from the benchmarks' sources 0-7 and eval's 5000 and up.
FIT_SOURCES = (900001, 900002, 900003, 900004)
# FIT_SOURCES' hair regions at FIT_RES and DEFAULT_SAMPLES, rendered by scripts/render_fit_regions.py: a render in the
# panel's click took 2 s and could meet a material preview's render thread (Blender 4.3 then deadlocks).
FIT_REGIONS = "hair_fit_regions.npz"
DARK_HAIR = 0.05  # mean luma of the recoloured swatch below this: the presets Dark Brown (0.047) and darker


@functools.lru_cache(maxsize=16)
def hair_region(source: int, res: int, samples: int):
    """blender_addon.renderers.hair.HairSource of default-scene `source`'s hair region: FIT_SOURCES' at FIT_RES and
    DEFAULT_SAMPLES as shipped (FIT_REGIONS: hair's fits render nothing in Cycles), any other rendered now."""
    from .hair import HairSource, render_hair_source

    if source in FIT_SOURCES and res == FIT_RES and samples == DEFAULT_SAMPLES:
        with np.load(DATA / FIT_REGIONS) as regions:
            return HairSource(regions[f"rgb_{source}"].astype(np.float32),
                              regions[f"mask_{source}"].astype(np.float32))
    return render_hair_source(source, res, samples, 0)


HAIR_TYPES = ("MESH", "CURVES", "CURVE")  # objects that can be hair: meshes (cards, a sculpted cap), curves, emitters
HAIR_ID_MASK = "VTO Hair ID Mask"


def hair_ids(objects) -> tuple[list, list]:
    """Of `objects` (the selection: cameras, lights and the like are left out), (the objects that are hair whole:
    curves and meshes, the materials of the hair particles the others emit); VtoError (one line) for particle hair
    without a material."""
    whole, materials = [], []
    for obj in (obj for obj in objects if obj.type in HAIR_TYPES):
        strands = [system.settings for system in getattr(obj, "particle_systems", ())
                   if system.settings.type == "HAIR"]
        if not strands:
            whole.append(obj)
        for settings in strands:  # the emitter's own surface is not hair: its strands are told by their material
            slot = settings.material - 1
            material = obj.material_slots[slot].material if 0 <= slot < len(obj.material_slots) else None
            if material is None:
                raise VtoError(f"the particle hair of '{obj.name}' has no material: give it one, so that the hair's "
                               "pixels can be told from the emitter's")
            materials.append(material)
    return whole, materials


def free_pass_index(chosen, others) -> int:
    """A pass index for the ids `chosen`: theirs where they share one that no other id uses, else one above all."""
    kept = {item.pass_index for item in chosen}
    used = {item.pass_index for item in others if item not in chosen}
    if len(kept) == 1 and 0 not in kept and not kept & used:
        return kept.pop()
    return max(used | kept | {0}) + 1


def wire_hair_mask(scene, tree, render, color, whole: list, materials: list) -> None:
    """The hair mask of `scene`'s own render from its passes: the hair objects get a pass index (the object-index
    pass; particle hair, its material's in the material-index pass), an ID Mask node reads each, and the mask (their
    maximum) goes into `color`'s Mask input. It follows the animation and any camera. `whole` and `materials` are
    hair_ids' two lists."""
    import bpy

    from ..compat import compositor_idname, render_layer_output, set_id_mask

    shown = render.scene or scene
    layer = shown.view_layers.get(render.layer) or shown.view_layers[0]
    masks = []
    for ids, others, pass_name, use in ((whole, scene.objects, "IndexOB", "use_pass_object_index"),
                                        (materials, bpy.data.materials, "IndexMA", "use_pass_material_index")):
        if not ids:
            continue
        index = free_pass_index(ids, others)
        for item in ids:
            item.pass_index = index
        setattr(layer, use, True)
        id_mask = tree.nodes.new("CompositorNodeIDMask")
        id_mask.name = id_mask.label = f"{HAIR_ID_MASK} {pass_name}"
        set_id_mask(id_mask, index)
        tree.links.new(render_layer_output(render, pass_name), id_mask.inputs["ID value"])
        id_mask.location = (-400, -300 - 150 * len(masks))
        masks.append(id_mask.outputs["Alpha"])
    if len(masks) == 2:
        both = tree.nodes.new(compositor_idname("Math"))
        both.operation = "MAXIMUM"
        tree.links.new(masks[0], both.inputs[0])
        tree.links.new(masks[1], both.inputs[1])
        masks = [both.outputs[0]]
    if masks:
        tree.links.new(masks[0], color.inputs["Mask"])


OWN_RENDER_SIDE, OWN_RENDER_SAMPLES = 256, 16  # the artist's render the stage's curve is fitted on: a histogram
MIN_HAIR_PIXELS = 64  # fewer hair pixels in that render: no curve is fitted


def own_render_hair(scene, color):
    """`scene`'s own render, small (cycles.render_user_passes), and its hair where `color` (its VTO Hair Color
    node) takes its Mask: the ID Mask nodes on the render's passes (wire_hair_mask), a mask image, or the whole
    frame when nothing is linked. Returns (HairSource, the full render's width in px, ''), or (None, 0, why) with
    too little hair in view."""
    from vto_core.imageio import resize

    from ..compat import compositor_tree, id_mask_index
    from .cycles import render_user_passes
    from .hair import HairSource

    if scene.camera is None:
        return None, 0, f"scene '{scene.name}' has no camera: the stage's curve is left as it was"
    passes = render_user_passes(scene, OWN_RENDER_SIDE, OWN_RENDER_SAMPLES)
    rgb = np.clip(passes["Combined"][..., :3], 0.0, 1.0)
    height, width = rgb.shape[:2]
    mask = np.ones((height, width), bool)
    link = color.inputs["Mask"].links[0] if color.inputs["Mask"].is_linked else None
    ids = [node for node in compositor_tree(scene).nodes if node.name.startswith(HAIR_ID_MASK)]
    if link is not None and ids:
        mask = np.zeros((height, width), bool)
        for node in ids:  # "VTO Hair ID Mask IndexOB": the pass it reads ends its name
            read = node.name.rsplit(" ", 1)[1]
            if read not in passes:
                return None, 0, (f"scene '{scene.name}' renders no {read} pass ({scene.render.engine}): the "
                                 "stage's curve is left as it was")
            mask |= np.abs(passes[read][..., 0] - id_mask_index(node)) < 0.5
    elif link is not None and getattr(link.from_node, "image", None) is not None:
        image = link.from_node.image
        pixels = np.empty(image.size[0] * image.size[1] * image.channels, np.float32)
        image.pixels.foreach_get(pixels)
        drawn = np.flipud(pixels.reshape(image.size[1], image.size[0], image.channels))[..., :3].mean(axis=-1)
        mask = resize(drawn, height, width) > 0.5
    if mask.sum() < MIN_HAIR_PIXELS:
        return None, 0, (f"scene '{scene.name}' shows hardly any hair ({int(mask.sum())} pixels at {width} x "
                         f"{height}): the stage's curve is left as it was")
    full_width = scene.render.resolution_x * scene.render.resolution_percentage // 100
    return HairSource(rgb.astype(np.float32), mask.astype(np.float32)), full_width, ""


class HairRenderer(ProductRenderer):
    """VTO Hair Color: a two-pass compositor stage that matches the hair's histogram to a recoloured swatch."""

    product = HAIR
    fit_sources = FIT_SOURCES

    def check_source(self, source):
        if not is_seed(source) and not Path(source).is_file():
            raise VtoError(f"hair source {source} is neither a default-scene seed nor a photo")

    def render(self, values, source, res, samples, seed, lighting=None):
        from .hair import render_hair

        return render_hair(values, source, res, samples, seed)  # a missing photo: "cannot read image ..."

    def bind(self, source, res, samples, seed, lighting=None):
        from .hair import resolve_hair_source, run_hair_stage

        self.check_source(source)
        hair = resolve_hair_source(source, res, samples, seed)
        return BoundSource(lambda values: run_hair_stage(hair, values), lambda: hair.rgb, lambda: hair.mask,
                           not is_seed(source))

    def region_renderer(self, source, res, samples, tones=None):
        from .hair import run_hair_stage

        hair = hair_region(source, res, samples)
        return lambda values: (run_hair_stage(hair, values), hair.mask)

    def iter_fit_sources(self, region, count, res, samples):
        """FIT_SOURCES' hair regions, in order (shipped at FIT_RES: nothing renders)."""
        return [self.region_renderer(seed, res, samples) for seed in FIT_SOURCES[:count]]
        yield  # a generator, as the other products' (nothing to wait for)

    def photo_sources(self, folder):
        from .hair import photo_sources

        return photo_sources(folder)

    def fit_held(self, spec, start):
        from .hair import own_source_held

        return own_source_held(spec, start)

    def nodes(self, scene):
        from ..compat import compositor_tree
        from .nodes_hair import COLOR_GROUP, SWATCH_GROUP

        tree = compositor_tree(scene) if scene is not None else None
        if tree is None:
            return []
        return [n for n in tree.nodes if n.bl_idname == "CompositorNodeGroup" and n.node_tree is not None
                and n.node_tree.name.startswith((SWATCH_GROUP, COLOR_GROUP))]

    def add_group(self, scene, hair_objects=()) -> list:
        """The two hair groups in `scene`'s compositor, wired: the hair swatch image -> "VTO Hair Swatch" -> Viewer (the
        recoloured swatch), the render -> "VTO Hair Color" -> Composite. Where `hair_objects` (the selection) hold hair,
        the render's own passes make its hair mask (wire_hair_mask); else a mask image node waits to be chosen
        (Gradient stays 1, the whole hair). Returns the two group nodes; VtoError (nothing changed) for particle hair
        without a material."""
        import bpy

        from ..compat import composite_output, compositor_tree
        from .hair import SWATCH_PATH
        from .nodes_hair import COLOR_GROUP, SWATCH_GROUP, color_group, swatch_group

        whole, materials = hair_ids(hair_objects)  # refused before anything changes
        before = compositor_tree(scene)
        fresh = before is None or not before.nodes or (hasattr(scene, "use_nodes") and not scene.use_nodes)
        tree = compositor_tree(scene, create=True)
        nodes, links = tree.nodes, tree.links
        def existing(idname: str):
            return next((n for n in nodes if n.bl_idname == idname), None) or nodes.new(idname)

        render = next((n for n in nodes if n.bl_idname == "CompositorNodeRLayers"), None) \
            or nodes.new("CompositorNodeRLayers")
        if fresh:  # a new node reads the context's scene; this scene's render is the one recoloured
            render.scene = scene
        output = composite_output(tree)
        swatch_image = nodes.new("CompositorNodeImage")
        swatch_image.name = swatch_image.label = "VTO Hair Swatch Image"
        swatch_image.image = bpy.data.images.load(str(SWATCH_PATH), check_existing=True)
        mask_image = nodes.new("CompositorNodeImage")
        mask_image.name = mask_image.label = "VTO Hair Mask (choose an image)"
        swatch = nodes.new("CompositorNodeGroup")
        swatch.name = swatch.label = SWATCH_GROUP
        swatch.node_tree = swatch_group()
        color = nodes.new("CompositorNodeGroup")
        color.name = color.label = COLOR_GROUP
        color.node_tree = color_group()
        color.inputs["Mask"].default_value = 1.0
        color.inputs["Gradient"].default_value = 1.0
        viewer = existing("CompositorNodeViewer")
        links.new(swatch_image.outputs["Image"], swatch.inputs["Image"])
        links.new(swatch.outputs[0], viewer.inputs[0])
        links.new(render.outputs["Image"], color.inputs["Image"])
        links.new(color.outputs[0], output)
        mask_image.location, color.location, output.node.location = (-400, -300), (0, 0), (300, 0)
        if whole or materials:
            mask_image.location = (-700, -300)  # the image stays a choice; the passes give the mask
            wire_hair_mask(scene, tree, render, color, whole, materials)
        swatch_image.location, swatch.location, viewer.location = (-400, 300), (0, 300), (300, 300)
        return [swatch, color]

    def where(self, scene):
        return f"the compositor of scene '{scene.name}'"

    def fitted_target(self, scene, values):
        """The curve of `scene`'s VTO Hair Color fitted to the hair of the scene's own render (own_render_hair) for
        `values`, in the compositor's scene-linear values: the stage then matches the artist's own hair, not a
        default one's, to the recoloured swatch."""
        from .hair import set_stage, stage_match
        from .nodes_hair import COLOR_GROUP

        colors = [node for node in self.nodes(scene) if node.node_tree.name.startswith(COLOR_GROUP)]
        if not colors:
            return (lambda: None), []
        source, width, why = own_render_hair(scene, colors[0])
        if source is None:
            return (lambda: None), [why]
        match = stage_match(source, self.product.spec.full_values(values), scene_linear=True)

        def write():
            for group in {node.node_tree for node in colors}:
                set_stage(group, match, width)

        return write, [f"the hair's curve fitted to the hair of scene '{scene.name}' as it renders"]

    def missing_group(self, scene):
        return f"scene '{scene.name}' has no VTO hair compositor groups (add them with Add VTO Hair Compositor)"

    def is_dark(self, values):
        from vto_core.colour import luminance
        from vto_core.hair import swatch_target

        from .hair import load_swatch

        return float(luminance(swatch_target(load_swatch(), values)).mean()) < DARK_HAIR

    def dataset_images(self, values, source, res, samples, cycles_seed, options):
        from .hair import load_photo_source, render_hair_source, run_hair_stage

        photos, cache = options.get("photos"), options.get("cache")
        if photos:
            hair_source = load_photo_source(photos[source % len(photos)], res)
        elif cache is not None:
            hair_source = cached_hair_source(Path(cache), source, res, samples, cycles_seed)
        else:
            hair_source = render_hair_source(source, res, samples, cycles_seed)
        return hair_source.rgb, [run_hair_stage(hair_source, v) for v in values], {"mask": hair_source.mask}


def cached_hair_source(folder: Path, source: int, res: int, samples: int, cycles_seed: int):
    """The hair source of a group of looks: rendered once, kept in `folder` (written atomically)."""
    from .hair import HairSource, render_hair_source

    path = folder / f"{source}.npz"
    if path.is_file():
        with np.load(path) as cached:
            return HairSource(cached["rgb"], cached["mask"])
    hair_source = render_hair_source(source, res, samples, cycles_seed)
    path.parent.mkdir(exist_ok=True)
    temporary = path.with_name(f"{path.stem}.{os.getpid()}.tmp.npz")
    np.savez(temporary, rgb=hair_source.rgb, mask=hair_source.mask)
    os.replace(temporary, path)
    return hair_source


RENDERER = HairRenderer()
