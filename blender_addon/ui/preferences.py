"""Add-on preferences: the encoder each renderer uses unless a material names its own."""

from __future__ import annotations

import bpy
from bpy.props import StringProperty

from vto_core.products import PRODUCTS

PACKAGE = __package__.rpartition(".")[0]  # "blender_addon", or the extension's package name once installed


def model_setting(product) -> StringProperty:
    """The preferences' model path of one product: '<name>_model'."""
    where = f"{product.name} materials" if product.is_material else f"the {product.name} compositor"
    return StringProperty(name=f"{product.label} Model", subtype="FILE_PATH",
                          description=f"Encoder (.onnx) for {where}; empty: the shipped one")


class VTO_AP_preferences(bpy.types.AddonPreferences):
    """Models of Match from photo: empty means the model shipped with the add-on."""

    bl_idname = PACKAGE
    __annotations__ = {f"{product.name}_model": model_setting(product) for product in PRODUCTS.values()}

    def draw(self, context):
        for product in PRODUCTS.values():
            self.layout.prop(self, f"{product.name}_model")


def preference_model(context, renderer: str) -> str:
    """The preferences' model path of `renderer`, or "" (also when the add-on is registered without addon_utils)."""
    addon = context.preferences.addons.get(PACKAGE)
    if addon is None or addon.preferences is None:
        return ""
    return getattr(addon.preferences, f"{renderer}_model", "")


def register() -> None:
    bpy.utils.register_class(VTO_AP_preferences)


def unregister() -> None:
    bpy.utils.unregister_class(VTO_AP_preferences)
