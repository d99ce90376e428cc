"""Render API of the hair renderer R(X, g): a hair source (Cycles scene or photo + mask), then two compositor passes."""

from __future__ import annotations

import functools
import math
import os
from dataclasses import dataclass
from pathlib import Path

import bpy
import numpy as np

from vto_core.colour import srgb_to_linear
from vto_core.dataset import DEFAULT_SAMPLES
from vto_core.errors import VtoError
from vto_core.hair import PHOTO_HAIR, blur_radius, fit_hair_match, hair_gradient, hair_square
from vto_core.imageio import read_image, resize
from vto_core.specs import RendererSpec
from vto_core.products import get_spec

from ..compat import composite_output, compositor_tree, set_exr_output
from ..shipped import DATA
from .nodes_hair import (COLOR_GROUP, FIT_COLOR_GROUP, SWATCH_GROUP, color_group, set_blur_radius, set_lut,
                         swatch_group)
from .cycles import configure_cycles, render_passes, to_display
from .scene_hair import HAIR_PASS_INDEX, apply_source, build_hair_scene

SWATCH_PATH = DATA / "hair_swatch.png"
PASS_SCENES = {SWATCH_GROUP: "VTO Hair Swatch Pass", COLOR_GROUP: "VTO Hair Color Pass"}
# A hair region is cut from a render REGION_OVERSCAN times its size: the largest square at least REGION_SHARE hair.
REGION_OVERSCAN, REGION_SHARE = 1.5, 0.98
STAGE_IMAGES = ("VTO Hair Source", "VTO Hair Mask", "VTO Hair Gradient", "VTO Hair Swatch Image")


@dataclass
class HairSource:
    """One hair source X: display-sRGB pixels (H, W, 3) and a hair mask (H, W) in [0,1]."""

    rgb: np.ndarray
    mask: np.ndarray


def render_hair_source(source_seed: int, res: int = 64, samples: int = DEFAULT_SAMPLES, seed: int = 0,
                       view: str = "region") -> HairSource:
    """Render the default hair scene for `source_seed`; the mask is the hair object's index pass.

    view "region" (the default source: hair, as an artist gives it) renders REGION_OVERSCAN x res and cuts the
    largest square that is hair (vto_core.hair.hair_square), resized to res; "portrait" is the whole head.
    """
    scene = build_hair_scene()
    if scene.get("vto_source_seed") != int(source_seed) or scene.get("vto_view") != view:
        apply_source(scene, int(source_seed), view)
    size = res if view == "portrait" else int(math.ceil(REGION_OVERSCAN * res))
    configure_cycles(scene, size, samples, seed)
    passes = render_passes(scene)
    mask = (np.abs(passes["IndexOB"][..., 0] - HAIR_PASS_INDEX) < 0.5).astype(np.float32)
    rgb = to_display(passes["Combined"][..., :3])
    if view == "portrait":
        return HairSource(rgb, mask)
    square = hair_square(mask, REGION_SHARE, 1.0 / REGION_OVERSCAN)
    x, y, side = square if square is not None else (0, 0, size)  # hair too thin for a square: the frame, masked
    rgb, mask = rgb[y:y + side, x:x + side], mask[y:y + side, x:x + side]
    return HairSource(resize(rgb, res, res), (resize(mask, res, res) > 0.5).astype(np.float32))


def own_source_held(spec: RendererSpec, start: dict[str, float]) -> dict[int, float]:
    """{position in spec.modelled: unit value} of intensity and blend at full effect (vto_core.hair.PHOTO_HAIR),
    where the spec models them, for iter_refine_by_render's `held`.

    A photo fixes them (photo_fit); and a photo refined as its own source would be undone by them: the stage recolours
    the photo's hair towards the swatch, so with intensity 0 or the fade moved below the hair (blend 1) it returns the
    photo untouched, a perfect and useless match."""
    unit = spec.normalise(spec.vector({**start, **PHOTO_HAIR}))
    return {i: float(unit[i]) for i, name in enumerate(spec.modelled) if name in PHOTO_HAIR}


def mask_path_for(photo: Path) -> Path:
    """The mask beside a photo: same folder, stem + '_mask', any image extension."""
    for candidate in sorted(photo.parent.glob(photo.stem + "_mask.*")):
        return candidate
    raise VtoError(f"no mask for {photo}: expected {photo.stem}_mask.png (or another image type) beside it")


def photo_sources(folder: str | os.PathLike) -> list[Path]:
    """The photos of a user folder (every image with a '<stem>_mask' partner), sorted."""
    folder = Path(folder)
    if not folder.is_dir():
        raise VtoError(f"hair source folder {folder} does not exist")
    photos = sorted(p for p in folder.iterdir() if p.suffix.lower() in (".png", ".jpg", ".jpeg", ".exr", ".tif", ".tiff")
                    and not p.stem.endswith("_mask"))
    photos = [p for p in photos if any(p.parent.glob(p.stem + "_mask.*"))]
    if not photos:
        raise VtoError(f"{folder} holds no photo with a '<name>_mask' image beside it")
    return photos


def load_photo_source(photo: str | os.PathLike, res: int | None = None) -> HairSource:
    """A user photo and its mask (mask > 0.5 is hair); optionally resized to res x res."""
    photo = Path(photo)
    rgb, _ = read_image(photo)
    mask_rgb, _ = read_image(mask_path_for(photo))
    mask = mask_rgb.mean(axis=-1)
    if mask.shape != rgb.shape[:2]:
        raise VtoError(f"mask of {photo} is {mask.shape[1]}x{mask.shape[0]}, the photo {rgb.shape[1]}x{rgb.shape[0]}")
    if res is not None and rgb.shape[:2] != (res, res):
        rgb, mask = resize(rgb, res, res), resize(mask, res, res)
    return HairSource(np.clip(rgb, 0, 1).astype(np.float32), (mask > 0.5).astype(np.float32))


@functools.lru_cache(maxsize=4)
def load_swatch(path: str | os.PathLike = SWATCH_PATH) -> np.ndarray:
    """The reference hair swatch (h, w, 3) display values (read once per path; do not modify)."""
    rgb, _ = read_image(path)
    return np.clip(rgb, 0, 1)


def _stage_image(name: str, pixels: np.ndarray) -> bpy.types.Image:
    """Put (H, W, 3|1) values into a float, Non-Color image `name` (reused, resized as needed)."""
    height, width = pixels.shape[:2]
    image = bpy.data.images.get(name)
    if image is not None and tuple(image.size) != (width, height):
        bpy.data.images.remove(image)  # only when the size changes, so not per sample
        image = None
    if image is None:
        image = bpy.data.images.new(name, width, height, alpha=True, float_buffer=True, is_data=True)
    image.colorspace_settings.name = "Non-Color"
    rgba = np.ones((height, width, 4), np.float32)
    rgba[..., :3] = pixels if pixels.ndim == 3 and pixels.shape[2] == 3 else np.reshape(pixels, (height, width, 1))
    image.pixels.foreach_set(np.flipud(rgba).reshape(-1))  # Blender stores the bottom row first
    image.update()
    return image


def _pass_scene(group_name: str) -> bpy.types.Scene:
    """Get or create the compositor-only scene that runs one group: Image nodes -> group -> Composite."""
    name = PASS_SCENES[group_name]
    scene = bpy.data.scenes.get(name)
    if scene is not None:
        return scene
    scene = bpy.data.scenes.new(name)
    camera = bpy.data.objects.get("VTO Stage Camera") or bpy.data.objects.new("VTO Stage Camera", bpy.data.cameras.new("VTO Stage Camera"))
    scene.collection.objects.link(camera)
    scene.camera = camera  # a compositor-only render still needs one
    tree = compositor_tree(scene, create=True)
    tree.nodes.clear()
    group = swatch_group() if group_name == SWATCH_GROUP else color_group(FIT_COLOR_GROUP)
    node = tree.nodes.new("CompositorNodeGroup")
    node.name = group_name
    node.node_tree = group
    inputs = ("VTO Hair Swatch Image",) if group_name == SWATCH_GROUP else STAGE_IMAGES[:3]
    for index, (image_name, socket) in enumerate(zip(inputs, ("Image", "Mask", "Gradient"))):
        image_node = tree.nodes.new("CompositorNodeImage")
        image_node.name = image_name
        image_node.location = (-300, -200 * index)
        tree.links.new(image_node.outputs["Image"], node.inputs[socket])
    output = composite_output(tree)
    output.node.location = (300, 0)
    tree.links.new(node.outputs[0], output)
    return scene


def _run_pass(group_name: str, images: dict[str, np.ndarray], values: dict[str, float]) -> np.ndarray:
    """Fill the pass's images and group inputs, render the compositor, return (H, W, 3) values."""
    scene = _pass_scene(group_name)
    tree = compositor_tree(scene)
    for name, pixels in images.items():
        tree.nodes[name].image = _stage_image(name, pixels)
    group_node = tree.nodes[group_name]
    for param in get_spec("hair").params:
        if param.socket in group_node.inputs:
            group_node.inputs[param.socket].default_value = values[param.name]
    height, width = next(iter(images.values())).shape[:2]
    configure_cycles(scene, 8, 1)
    scene.cycles.use_denoising = False  # nothing is rendered: the compositor makes the image
    scene.render.resolution_x, scene.render.resolution_y = width, height
    scene.render.use_compositing = True
    settings = scene.render.image_settings
    set_exr_output(settings, multilayer=False)
    settings.color_depth, settings.color_mode = "32", "RGB"
    return render_passes(scene)["Combined"][..., :3]


def stage_match(source: HairSource, values: dict[str, float], swatch: np.ndarray | None = None,
                scene_linear: bool = False):
    """The curves (HistogramMatch) that move `source`'s hair onto the swatch recoloured by pass 1 with hair `values`
    (full). scene_linear: `source` holds a render's scene-linear values (an artist's compositor), so the recoloured
    swatch's display values are taken to scene-linear as well; else both are display values (a photo, the passes)."""
    swatch = load_swatch() if swatch is None else swatch
    recoloured = np.clip(_run_pass(SWATCH_GROUP, {"VTO Hair Swatch Image": swatch}, values), 0, 1)
    return fit_hair_match(source.rgb, source.mask, srgb_to_linear(recoloured) if scene_linear else recoloured)


def set_stage(group: bpy.types.NodeTree, match, width: int) -> None:
    """Put `match`'s curves, and the local-contrast blur of an image `width` px wide, into colour group `group`."""
    set_lut(group, match.gray_lut, match.channel_luts)
    set_blur_radius(group, blur_radius(width))


def run_hair_stage(source: HairSource, values: dict[str, float], swatch: np.ndarray | None = None) -> np.ndarray:
    """Both compositor passes on `source` with hair `values`: (H, W, 3) display values."""
    values = get_spec("hair").full_values(values)
    set_stage(color_group(FIT_COLOR_GROUP), stage_match(source, values, swatch), source.rgb.shape[1])
    display = np.clip(source.rgb, 0, 1)  # a display-referred stage: HDR sources are clipped, as in the reference
    stage_inputs = dict(zip(STAGE_IMAGES[:3], (display, source.mask, hair_gradient(source.mask))))
    return np.clip(_run_pass(COLOR_GROUP, stage_inputs, values), 0, 1).astype(np.float32)


def resolve_hair_source(source, res: int, samples: int, seed: int) -> HairSource:
    """An int renders the default scene with that source seed; a path is a photo with a mask beside it."""
    if isinstance(source, (int, np.integer)) or (isinstance(source, str) and source.isdigit()):
        return render_hair_source(int(source), res, samples, seed)
    return load_photo_source(source, res)


def render_hair(values: dict[str, float], source=0, res: int = 64, samples: int = DEFAULT_SAMPLES, seed: int = 0) -> np.ndarray:
    """R(X, g) for hair: (res, res, 3) display-sRGB float32."""
    return run_hair_stage(resolve_hair_source(source, res, samples, seed), values)

