"""What the "Match from photo" panel remembers: one settings group per material (lipstick, eye shadow) and per scene
(hair)."""

from __future__ import annotations

import json

import bpy
from bpy.props import BoolProperty, EnumProperty, FloatVectorProperty, PointerProperty, StringProperty

from vto_core.products import PRODUCTS, either


def _fast_fit(product) -> str:
    """What Fast adds for a product whose Fast fits the colour imitator (FitPolicy.fast_fits)."""
    polish = product.fit.polish_passes
    seconds = product.fit.seconds.get("FAST")
    return (f"; for {product.name}, fitted to the {product.region}'s colour through the colour imitator"
            + (f", then checked and corrected on {polish} passes of the {product.name} {product.kind.name}"
               if polish else "") + (f" (at most {seconds[1]:g} s)" if seconds else ""))


_FRAMED = [p for p in PRODUCTS.values() if p.face_regions]  # a mask frames the reference as the training renders do
_UNFRAMED = [p for p in PRODUCTS.values() if not p.face_regions]
QUALITY_ITEMS = [
    ("FAST", "Fast", "The encoder's estimate of the photo with its light taken out (milliseconds, no render)"
                     + "".join(_fast_fit(p) for p in PRODUCTS.values() if p.fit.fast_fits)),
    ("BETTER", "Better", "The estimate fitted through the renderer to the colour of the photo's "
                         f"{either(p.region for p in PRODUCTS.values())} (a few seconds)"),
    ("BEST", "Best", "As Better, on more default scenes with more renders (several seconds)"),
]


class VTO_PG_match_settings(bpy.types.PropertyGroup):
    """Reference, crop or mask, model and quality of Match from photo, and the last estimate."""

    use_datablock: BoolProperty(name="Image in this .blend", default=False,
                                description="Use an image datablock already in the .blend instead of a file")
    image_path: StringProperty(name="Reference", subtype="FILE_PATH", description="The reference photo")
    image: PointerProperty(name="Reference Image", type=bpy.types.Image,
                           description="An image already in the .blend as the reference")
    find_region: BoolProperty(name="Find Region", default=True,
                              description="Find what the photo shows of the product: the lips with a face model (a "
                                          "portrait, or a close-up of lips), both eyes' lids on a portrait's face "
                                          "mesh, the hair around the largest face of a portrait (a picture with no "
                                          "face is read whole as a patch of hair); off: the image or crop is taken "
                                          "as it is (for eye shadow, one eye framed as the default eye scene frames "
                                          "it)")
    use_crop: BoolProperty(name="Crop", default=False, description="Estimate from a part of the reference only")
    crop: FloatVectorProperty(name="Crop", size=4, min=0.0, default=(0.0, 0.0, 1.0, 1.0),
                              description="x, y, width, height from the top-left corner: in pixels, or fractions of "
                                          "the image when all four are at most 1")
    mask_path: StringProperty(name="Mask", subtype="FILE_PATH",
                              description="Optional mask image: white = the product's region ("
                                          f"{either(p.region for p in PRODUCTS.values())})"
                                          + (f". {either(p.label for p in _FRAMED)}: the reference is framed around "
                                             "it as the training renders frame it (instead of finding it)"
                                             if _FRAMED else "")
                                          + (f". {either(p.label for p in _UNFRAMED)}: the encoder reads its largest "
                                             "square, Better and Best all of it" if _UNFRAMED else ""))
    model_path: StringProperty(name="Model", subtype="FILE_PATH",
                               description="An encoder (.onnx) for this material only; empty: the add-on "
                                           "preferences' model, else the shipped one")
    quality: EnumProperty(name="Quality", items=QUALITY_ITEMS, default="FAST")
    last_estimate: StringProperty(name="Last Estimate", default="", options={"HIDDEN"},
                                  description="JSON of the last values written, for the panel")


LEGACY_FIND = ("find_lips", "find_hair")  # find_region's names before (one a product): old .blend files hold them


def find_region(props) -> bool:
    """The find_region setting; a .blend saved before it keeps the value it stored under its old name."""
    if "find_region" not in props:  # never set here: the default, or an old name's stored value (a set one was off)
        for old in LEGACY_FIND:
            if old in props:
                return bool(props[old])
    return props.find_region


def settings_dict(props: VTO_PG_match_settings) -> dict:
    """The panel's settings as the plain dict blender_addon.matching.apply takes."""
    settings = {"quality": props.quality, "model_path": props.model_path, "mask_path": props.mask_path,
                "crop": tuple(props.crop) if props.use_crop else None, "find_region": find_region(props)}
    if props.use_datablock:
        settings["image_name"] = props.image.name if props.image else ""
    else:
        settings["image_path"] = props.image_path
    return settings


def remember(props, renderer: str, values: dict[str, float], model: str, seconds: float | None = None) -> None:
    """Store the values written (and how long the match took), for the panel to show."""
    props.last_estimate = json.dumps({"renderer": renderer, "values": values, "model": model, "seconds": seconds})


def register() -> None:
    bpy.utils.register_class(VTO_PG_match_settings)
    bpy.types.Material.vto_match = PointerProperty(type=VTO_PG_match_settings)
    for product in (p for p in PRODUCTS.values() if not p.is_material):  # Scene.vto_hair_match: a stage's settings
        setattr(bpy.types.Scene, f"vto_{product.name}_match", PointerProperty(type=VTO_PG_match_settings))


def unregister() -> None:
    for product in (p for p in PRODUCTS.values() if not p.is_material):
        delattr(bpy.types.Scene, f"vto_{product.name}_match")
    del bpy.types.Material.vto_match
    bpy.utils.unregister_class(VTO_PG_match_settings)
