"""The "Match from photo" panels: Material Properties (lipstick) and the Compositor sidebar (hair)."""

from __future__ import annotations

import json
from pathlib import Path

import bpy

from vto_core.specs import get_spec

from . import apply
from .operators import VTO_OT_add_hair_compositor, VTO_OT_add_lipstick_material, VTO_OT_match_from_photo
from .preferences import preference_model


def draw_match(layout, context, props, renderer: str, target: str, material_name: str = "") -> None:
    """The shared body: reference, crop / mask, model, quality, Match, and the last estimate."""
    column = layout.column()
    column.prop(props, "use_datablock")
    column.prop(props, "image" if props.use_datablock else "image_path")
    column.prop(props, "use_crop")
    if props.use_crop:
        column.prop(props, "crop", text="")
    column.prop(props, "mask_path")
    column.prop(props, "model_path", text="Model Override")
    model = apply.resolve_model(renderer, props.model_path, preference_model(context, renderer))
    column.label(text=f"Model: {model.name}" + ("" if model.is_file() else " (missing)"), icon="FILE")

    column.label(text="Quality:")
    row = column.row(align=True)
    row.prop_enum(props, "quality", "FAST")
    refinable = renderer == "hair"
    for value in ("BETTER", "BEST"):
        cell = row.row(align=True)
        cell.enabled = refinable
        cell.prop_enum(props, "quality", value)
    if not refinable:
        column.label(text="Better / Best: a face photo has no known source to render", icon="INFO")
    elif props.quality != "FAST" and not props.mask_path:
        column.label(text="Better / Best need the hair mask of the photo", icon="ERROR")

    operator = column.operator(VTO_OT_match_from_photo.bl_idname, text="Match", icon="EYEDROPPER")
    operator.target = target
    if material_name:
        operator.material = material_name
    if not refinable:
        operator.quality = "FAST"

    if props.last_estimate:
        try:
            last = json.loads(props.last_estimate)
            lines = apply.describe(get_spec(last["renderer"]), last["values"])
        except (ValueError, KeyError, TypeError):
            return
        box = layout.box()
        box.label(text=f"Estimate ({Path(last.get('model', '')).name}):")
        for line in lines:
            box.label(text=line)


class VTO_PT_match_material(bpy.types.Panel):
    """Match from photo for a material using the "VTO Lipstick" group"""

    bl_label = "Match from photo"
    bl_idname = "VTO_PT_match_material"
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "material"

    @classmethod
    def poll(cls, context):
        return bool(apply.lipstick_nodes(getattr(context, "material", None)))

    def draw(self, context):
        material = context.material
        draw_match(self.layout, context, material.vto_match, "lipstick", "MATERIAL", material.name)


class VTO_PT_match_hair(bpy.types.Panel):
    """Match from photo for the scene's VTO hair compositor groups"""

    bl_label = "Match from photo"
    bl_idname = "VTO_PT_match_hair"
    bl_space_type = "NODE_EDITOR"
    bl_region_type = "UI"
    bl_category = "VTO"

    @classmethod
    def poll(cls, context):
        space = getattr(context, "space_data", None)
        return getattr(space, "tree_type", "") == "CompositorNodeTree" and context.scene is not None

    def draw(self, context):
        if not apply.hair_nodes(context.scene):
            self.layout.label(text="No VTO hair groups in this compositor")
            self.layout.operator(VTO_OT_add_hair_compositor.bl_idname, icon="NODETREE")
            return
        draw_match(self.layout, context, context.scene.vto_hair_match, "hair", "HAIR")


class VTO_PT_add_lipstick(bpy.types.Panel):
    """A starting point: add a lipstick material to the active mesh when its material has no VTO group"""

    bl_label = "Match from photo"
    bl_idname = "VTO_PT_add_lipstick"
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "material"
    bl_options = {"DEFAULT_CLOSED"}

    @classmethod
    def poll(cls, context):
        obj = getattr(context, "object", None)
        return (obj is not None and obj.type == "MESH"
                and not apply.lipstick_nodes(getattr(context, "material", None)))

    def draw(self, context):
        self.layout.label(text="This material does not use the VTO Lipstick group")
        self.layout.operator(VTO_OT_add_lipstick_material.bl_idname, icon="MATERIAL")


CLASSES = (VTO_PT_match_material, VTO_PT_match_hair, VTO_PT_add_lipstick)


def register() -> None:
    for cls in CLASSES:
        bpy.utils.register_class(cls)


def unregister() -> None:
    for cls in reversed(CLASSES):
        bpy.utils.unregister_class(cls)
