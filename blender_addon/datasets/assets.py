"""A .blend asset library of a material product's presets (lipstick, eye shadow): one marked material per preset,
with catalog, tags and preview.

Each material is the product's material (a Principled bare shader under its VTO group, the product's Blender side
makes it) with the preset's values written on the group's inputs, so dragging it from Blender's Asset Browser onto
lips or a lid gives the look. The file holds only those materials and the node groups they use
(`bpy.data.libraries.write`); it is written to a temporary name and moved into place, and `blender_assets.cats.txt`
beside it names the catalog. Hair has no material form (it is a two-pass compositor stage fitted to each photo's own
hair), so no library is made for it.
"""

from __future__ import annotations

import os
import uuid
from pathlib import Path

import bpy
import numpy as np

from vto_core.dataset import write_text_atomic
from vto_core.products import Product

from ..renderers.products import blender_side

CATALOG_FILE = "blender_assets.cats.txt"


def catalog_path(product: Product) -> str:
    """The catalog of `product`'s presets in the Asset Browser: "Match from photo/Lipstick"."""
    return f"Match from photo/{product.label}"


def catalog_id(path: str) -> str:
    """A stable catalog UUID for `path` (the same on every run, so reruns keep the Asset Browser's catalog)."""
    return str(uuid.uuid5(uuid.NAMESPACE_URL, f"vto-match/{path}"))


def write_catalogs(folder: Path, path: str) -> str:
    """Write blender_assets.cats.txt (version 1, one catalog) into `folder`; returns the catalog's UUID."""
    cid = catalog_id(path)
    write_text_atomic(folder / CATALOG_FILE, "# Asset catalogs of `vto batch` (Blender's format).\n\nVERSION 1\n\n"
                                         f"{cid}:{path}:{path.replace('/', '-')}\n")
    return cid


def set_preview(material: bpy.types.Material, image: np.ndarray) -> None:
    """Store a display-sRGB image (H, W, 3) as the material's asset preview (Blender's rows run bottom-up)."""
    height, width = image.shape[:2]
    rgba = np.ones((height, width, 4), dtype=np.float32)
    rgba[..., :3] = np.clip(image, 0.0, 1.0)
    preview = material.preview_ensure()
    preview.image_size = (width, height)
    preview.image_pixels_float.foreach_set(rgba[::-1].ravel())


def write_library(path: Path, products: dict[str, tuple[dict[str, float], np.ndarray, list[str]]],
                  description: str, product: Product) -> dict[str, str]:
    """Write the asset library of `product` (a material product) at `path`: preset -> (values, preview, extra tags);
    returns preset -> material name.

    The materials live in bpy.data only while the file is written; they are removed afterwards.
    """
    cid = write_catalogs(path.parent, catalog_path(product))
    side, materials = blender_side(product), {}
    try:
        for name, (values, preview, tags) in products.items():
            material = materials[name] = side.material(name, values)
            material.asset_mark()
            material.asset_data.catalog_id = cid
            material.asset_data.description = description
            for tag in (product.name, name, *tags):
                material.asset_data.tags.new(tag[:63], skip_if_exists=True)
            set_preview(material, preview)
        temporary = path.with_name(f".tmp-{os.getpid()}-{path.name}")
        bpy.data.libraries.write(str(temporary), set(materials.values()), fake_user=True, compress=True)
        os.replace(temporary, path)
        return {name: material.name for name, material in materials.items()}
    finally:
        for material in materials.values():
            bpy.data.materials.remove(material)
