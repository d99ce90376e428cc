"""Add-on preferences: the encoder each renderer uses unless a material names its own."""

from __future__ import annotations

import bpy
from bpy.props import StringProperty

PACKAGE = __package__.rpartition(".")[0]  # "blender_addon", or the extension's package name once installed


class VTO_AP_preferences(bpy.types.AddonPreferences):
    """Models of Match from photo: empty means the model shipped with the add-on."""

    bl_idname = PACKAGE

    lipstick_model: StringProperty(name="Lipstick Model", subtype="FILE_PATH",
                                   description="Encoder (.onnx) for lipstick materials; empty: the shipped one")
    hair_model: StringProperty(name="Hair Model", subtype="FILE_PATH",
                               description="Encoder (.onnx) for the hair compositor; empty: the shipped one")

    def draw(self, context):
        self.layout.prop(self, "lipstick_model")
        self.layout.prop(self, "hair_model")


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
