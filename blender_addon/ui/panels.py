"""The "Match from photo" panels: the top of Material Properties and the Shader Editor's sidebar (a material's
product: lipstick, eye shadow), the Compositor's sidebar (hair); and the 3D Viewport's sidebar (the artist's
character)."""

from __future__ import annotations

import json
from pathlib import Path

import bpy

from vto_core.products import Product, get_spec

from ..matching import apply
from ..renderers.makeup_layer import layer_products, layers
from . import preview, thumbnail, warmup
from .operators import (VTO_OT_add_hair_compositor, VTO_OT_find_face, VTO_OT_match_from_photo, VTO_OT_preview_on_photo,
                        add_material_buttons, layer_buttons, layer_choice)
from .preferences import preference_model

THUMBNAIL_SCALE = 6.0  # the reference's thumbnail: 6 icon rows high


def split_column(layout):
    """A column in Blender's property-split style (labels right-aligned on the left, no animation dots)."""
    layout.use_property_split = True
    layout.use_property_decorate = False
    return layout.column()


def draw_reference(column, props, preview_name: str, product: Product) -> None:
    """Reference (a file or an image of the .blend), its thumbnail with the crop and the lips or hair found outlined,
    crop, mask and whether to find the lips or the hair."""
    column.prop(props, "image" if props.use_datablock else "image_path", text="Reference")
    column.prop(props, "use_datablock", text="Image in .blend")
    icon_id, why = thumbnail.icon(props, preview_name, product)
    if icon_id:
        column.template_icon(icon_value=icon_id, scale=THUMBNAIL_SCALE)
    if why and why != "no image chosen":
        icon = "INFO" if icon_id and not why.startswith(f"no {product.region}") else "ERROR"
        for line in why.split("; "):  # one line a note: what was found, then the light read
            column.label(text=line, icon=icon)
            icon = "BLANK1"
    column.prop(props, "use_crop", text="Part of the Image")
    if props.use_crop:
        box = column.column(align=True)
        for index, name in enumerate(("X", "Y", "Width", "Height")):
            box.prop(props, "crop", index=index, text=name)
    column.prop(props, "mask_path", text="Mask")
    row = column.row()
    row.active = not props.mask_path and not (product.face_region is None and props.use_crop)  # these say where it is
    row.prop(props, "find_region", text=f"Find {product.region.title()}")


def draw_quality(column, props, product: Product) -> None:
    """Fast / Better / Best where they pay (FitPolicy.offered; else why not), and what the choice costs."""
    offered = product.fit.offered
    quality = props.quality if props.quality in offered else "FAST"
    if len(offered) > 1:
        split = column.split(factor=0.4)  # the label column of property split, which prop_enum does not follow
        label = split.row()
        label.alignment = "RIGHT"
        label.label(text="Quality")
        row = split.row(align=True)
        row.use_property_split = False
        for value in offered:
            row.prop_enum(props, "quality", value)
    column.label(text=quality_cost(product, quality), icon="TIME")
    if product.fit.not_offered:
        column.label(text=product.fit.not_offered, icon="INFO")


def quality_cost(product: Product, quality: str) -> str:
    """'Fast: no render, milliseconds', 'Fast: 3 stage passes, 0.3-1 s' (FitPolicy.polish_passes) or 'Better: 25
    renders, 4-17 s' (FitPolicy.renders, seconds)."""
    if quality == "FAST":
        passes = product.fit.polish_passes
        if not passes:
            return "Fast: no render, milliseconds"
        seconds, first = product.fit.seconds[quality]
        return f"Fast: {passes} stage passes, {seconds:g}-{first:g} s"
    renders = product.fit.renders[quality][1]
    seconds, first = product.fit.seconds[quality]
    return f"{quality.title()}: {renders} renders, {seconds:g}-{first:g} s"  # the longer: a session's first fit


def draw_estimate(layout, props) -> None:
    """The last values written, as the group's inputs show them."""
    try:
        last = json.loads(props.last_estimate)
        lines = apply.describe(get_spec(last["renderer"]), last["values"])
    except (ValueError, KeyError, TypeError):
        return
    box = layout.box()
    box.use_property_split = False
    box.label(text=f"Written ({Path(last.get('model', '')).stem})", icon="CHECKMARK")
    for line in lines:
        box.label(text=line)


def draw_match(layout, context, props, product: Product, material_name: str = "") -> None:
    """The shared body: reference, crop, mask, model, quality, Match, and the values last written."""
    column = split_column(layout)
    draw_reference(column, props, f"{product.target}:{material_name}", product)
    if product.kind.tryon and material_name:
        draw_preview(column, bpy.data.materials[material_name])
    preference = preference_model(context, product.name)
    model = apply.resolve_model(product.name, props.model_path, preference)
    try:
        column.prop(props, "model_path", text="Model", placeholder="shipped"
                    if not (props.model_path or preference) else model.stem)
    except TypeError:  # no placeholder before Blender 4.1
        column.prop(props, "model_path", text="Model")
    problem = warmup.problem(model) if model.is_file() else f"no model file {model.name}"
    if problem:
        alert = column.column()
        alert.alert = True
        alert.label(text=problem, icon="ERROR")
    else:
        warmup.ensure(model)
    draw_quality(column, props, product)

    row = layout.row()
    row.scale_y = 1.4
    operator = row.operator(VTO_OT_match_from_photo.bl_idname, text="Match", icon="EYEDROPPER")
    operator.target = product.target
    if material_name:
        operator.material = material_name
    if props.last_estimate:
        draw_estimate(layout, props)


def draw_preview(layout, material) -> None:
    """Preview on Photo: the reference's lips beside the material's current values tried on them, made on request
    and after Match."""
    icon_id, note = preview.shown(material)
    if note:
        layout.label(text=note, icon="ERROR")
    elif icon_id:
        layout.template_icon(icon_value=icon_id, scale=THUMBNAIL_SCALE)
    layout.operator(VTO_OT_preview_on_photo.bl_idname, icon="IMAGE_RGB").material = material.name


class MaterialMatch:
    """The Material Properties panel's body; a sub-panel of each engine's material-slots panel, so that it sits under
    the slots, above Preview and the Surface inputs (bl_order cannot place an add-on panel above built-in ones)."""

    bl_label = "Match from photo"
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "material"

    @classmethod
    def poll(cls, context):
        return apply.material_product(getattr(context, "material", None)) is not None

    def draw_header(self, context):
        self.layout.label(icon="EYEDROPPER")

    def draw(self, context):
        material = context.material
        layer_choice(self.layout, material)
        draw_match(self.layout, context, material.vto_match, apply.material_product(material), material.name)
        if layers(material):  # a skin material wearing makeup layers: the next one, or one taken out, set apart
            box = self.layout.box()  # from Match, so that a click meant for Match never removes a layer
            box.label(text="Makeup layers of this material")
            layer_buttons(box.column(), material)


class VTO_PT_match_material(MaterialMatch, bpy.types.Panel):
    """Match from photo for a material using a VTO material group (EEVEE, Workbench)"""

    bl_idname = "VTO_PT_match_material"
    bl_parent_id = "EEVEE_MATERIAL_PT_context_material"


class VTO_PT_match_material_cycles(MaterialMatch, bpy.types.Panel):
    """Match from photo for a material using a VTO material group (Cycles)"""

    bl_idname = "VTO_PT_match_material_cycles"
    bl_parent_id = "CYCLES_PT_context_material"


class SidebarPanel:
    """A node editor sidebar panel in the VTO tab."""

    bl_label = "Match from photo"
    bl_space_type = "NODE_EDITOR"
    bl_region_type = "UI"
    bl_category = "VTO"


class VTO_PT_match_shader(SidebarPanel, bpy.types.Panel):
    """Match from photo in the Shader Editor's sidebar (VTO tab), for the material being edited"""

    bl_idname = "VTO_PT_match_shader"

    @classmethod
    def poll(cls, context):
        space = getattr(context, "space_data", None)
        return (getattr(space, "tree_type", "") == "ShaderNodeTree"
                and apply.material_product(getattr(space, "id", None)) is not None)

    def draw(self, context):
        material = context.space_data.id
        layer_choice(self.layout, material)
        draw_match(self.layout, context, material.vto_match, apply.material_product(material), material.name)


class VTO_PT_match_hair(SidebarPanel, bpy.types.Panel):
    """Match from photo for the scene's VTO compositor stages (the hair colour's groups)"""

    bl_idname = "VTO_PT_match_hair"

    @classmethod
    def poll(cls, context):
        space = getattr(context, "space_data", None)
        return getattr(space, "tree_type", "") == "CompositorNodeTree" and context.scene is not None

    def draw(self, context):
        for product in apply.compositor_products():
            if not apply.group_nodes(product, context.scene):
                self.layout.label(text=f"No {product.group_text} in this compositor")
                self.layout.operator(VTO_OT_add_hair_compositor.bl_idname, icon="NODETREE")
                continue
            draw_match(self.layout, context, apply.stage_settings(context.scene, product), product)


class VTO_PT_add_lipstick(bpy.types.Panel):
    """A starting point: add a VTO material (lipstick, eye shadow) to the active mesh when its material has none, or
    layer makeup into the material it has"""

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
                and apply.material_product(getattr(context, "material", None)) is None)

    def draw(self, context):
        self.layout.label(text="This material uses no VTO group")
        add_material_buttons(self.layout)
        layer_buttons(self.layout, getattr(context, "material", None))  # or layer makeup into this material


class VTO_PT_character(bpy.types.Panel):
    """The artist's own character, in the 3D Viewport's sidebar (VTO tab): Find Face on Mesh, what it found, and the
    makeup layers of the active material"""

    bl_label = "Character"
    bl_idname = "VTO_PT_character"
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "VTO"

    @classmethod
    def poll(cls, context):
        obj = getattr(context, "object", None)
        return obj is not None and obj.type == "MESH"

    def draw(self, context):
        obj = context.object
        self.layout.operator(VTO_OT_find_face.bl_idname, icon="USER")
        found = [product.face_region for product in layer_products()
                 if product.face_region.attribute in obj.data.attributes]
        self.layout.label(text=f"Found: {', '.join(region.name for region in found)}" if found
                          else "No face regions on this mesh yet", icon="CHECKMARK" if found else "INFO")
        icon_id, _ = preview.found_face(obj.name)
        if icon_id:
            self.layout.template_icon(icon_value=icon_id, scale=8.0)
        layer_buttons(self.layout, obj.active_material)


CLASSES = (VTO_PT_match_material, VTO_PT_match_material_cycles, VTO_PT_match_shader, VTO_PT_match_hair,
           VTO_PT_add_lipstick, VTO_PT_character)
_registered: list = []


def register() -> None:
    """Register the panels; a sub-panel only where its parent (the engine's material-slots panel) exists."""
    for cls in CLASSES:
        parent = getattr(cls, "bl_parent_id", "")
        if parent and not hasattr(bpy.types, parent):
            continue
        bpy.utils.register_class(cls)
        _registered.append(cls)


def unregister() -> None:
    for cls in reversed(_registered):
        bpy.utils.unregister_class(cls)
    _registered.clear()
    thumbnail.unregister()
    preview.unregister()
    warmup.unregister()
