"""Each product's Blender side (a blender_addon.renderers.products.ProductRenderer), found from its declaration."""

from __future__ import annotations

import importlib

from vto_core.products import Product, get_product


def blender_side(product: Product | str):
    """The Blender side of `product` (a declaration or a name): its module's RENDERER (product_<name>.py)."""
    product = get_product(product) if isinstance(product, str) else product
    return importlib.import_module(product.blender_module, __package__).RENDERER
