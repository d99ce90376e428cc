"""Operators of Match from photo: thin wrappers over blender_addon.matching.apply (one class per operator, the docstring
is the tooltip). Each is undoable in one step; on bad input it reports one line and changes nothing."""

from __future__ import annotations

import time

import bpy
from bpy.props import BoolProperty, EnumProperty, FloatVectorProperty, StringProperty

from vto_core.errors import VtoError, failure_line
from vto_core.products import LIPSTICK, PRODUCTS, either, get_product, product_of_target

from ..matching import apply
from ..renderers import makeup_layer
from ..renderers.products import blender_side
from . import preview
from .preferences import preference_model
from .properties import QUALITY_ITEMS, remember, settings_dict

TICK_SECONDS = 0.05  # refinement work per timer tick, at least one render: the UI answers between ticks


_MATERIAL_ITEMS: list = []  # Blender keeps no copy of a callback's enum strings: they live here


def material_product_items(self, context) -> list:
    """The products whose renderer is a material's node group (vto_core.products), one item each, the first the
    default."""
    items = [(p.name, p.label, f"A new material with the {p.group_text} over a bare shader")
             for p in PRODUCTS.values() if p.is_material]
    if items != _MATERIAL_ITEMS:
        _MATERIAL_ITEMS[:] = items
    return _MATERIAL_ITEMS


def add_material(operator, context, product) -> set:
    """Add `product`'s material to the operator's object (or the active one) and report it in one line."""
    obj = bpy.data.objects.get(operator.object_name) if operator.object_name else context.object
    try:
        material = blender_side(product).add_group(obj)
    except VtoError as exc:
        operator.report({"ERROR"}, str(exc))
        return {"CANCELLED"}
    operator.report({"INFO"}, f"added material '{material.name}' to '{obj.name}'")
    return {"FINISHED"}


class VTO_OT_add_material(bpy.types.Operator):
    """Add a new material to the active mesh: the chosen product's VTO node group over a bare shader"""

    bl_idname = "vto.add_material"
    bl_label = "Add VTO Material"
    bl_options = {"REGISTER", "UNDO"}

    product: EnumProperty(name="Product", items=material_product_items,
                          description="The product whose node group the new material holds")
    object_name: StringProperty(name="Object", default="", description="Mesh object (default: the active object)")

    @classmethod
    def poll(cls, context):
        return context.object is not None and context.object.type == "MESH"

    @classmethod
    def description(cls, context, properties):
        label = get_product(properties.product).label if properties.product else "a product's"
        return f"Add a \"VTO {label}\" material to the active mesh: its node group over a bare shader"

    def execute(self, context):
        return add_material(self, context, get_product(self.product))


class VTO_OT_add_lipstick_material(bpy.types.Operator):
    """Add a "VTO Lipstick" material to the active mesh: the lipstick node group over a bare-lips shader"""

    bl_idname = "vto.add_lipstick_material"  # vto.add_material(product="lipstick") under its name from before
    bl_label = "Add VTO Lipstick Material"
    bl_options = {"REGISTER", "UNDO"}

    object_name: StringProperty(name="Object", default="", description="Mesh object (default: the active object)")

    @classmethod
    def poll(cls, context):
        return VTO_OT_add_material.poll(context)

    def execute(self, context):
        return add_material(self, context, LIPSTICK)


_LAYER_ITEMS: list = []  # Blender keeps no copy of a callback's enum strings: they live here


def layer_product_items(self, context) -> list:
    """The face-layer products (vto_core.products; makeup_layer.layer_products), one item each, the first the
    default."""
    items = [(p.name, p.label, f"The {p.group_text} over the skin where the mesh's '{p.face_region.attribute}' "
              "attribute is") for p in makeup_layer.layer_products()]
    if items != _LAYER_ITEMS:
        _LAYER_ITEMS[:] = items
    return _LAYER_ITEMS


def change_layer(operator, context, change, done: str) -> set:
    """change(material, product) on the active object's active material, reported in one line either way."""
    obj = context.object
    product = get_product(operator.product)
    try:
        if obj is None or obj.active_material is None:
            raise VtoError(f"object '{obj.name}' has no material: give it its skin material first" if obj is not None
                           else "no active object: select the character's head mesh")
        change(obj.active_material, product)
    except VtoError as exc:
        operator.report({"ERROR"}, str(exc))
        return {"CANCELLED"}
    operator.report({"INFO"}, f"{done} the {product.label} layer of material '{obj.active_material.name}'")
    return {"FINISHED"}


class VTO_OT_add_makeup_layer(bpy.types.Operator):
    """Layer the chosen product into the active object's own material, over its skin shader, where the mesh's face
    region attribute (Find Face on Mesh) is"""

    bl_idname = "vto.add_makeup_layer"
    bl_label = "Add Makeup Layer"
    bl_options = {"REGISTER", "UNDO"}

    product: EnumProperty(name="Product", items=layer_product_items, description="The product layered over the skin")

    @classmethod
    def poll(cls, context):
        return context.object is not None

    def execute(self, context):
        return change_layer(self, context, makeup_layer.add_layer, "added")


class VTO_OT_remove_makeup_layer(bpy.types.Operator):
    """Take the chosen product's layer out of the active object's material, which is then as it was without it"""

    bl_idname = "vto.remove_makeup_layer"
    bl_label = "Remove Makeup Layer"
    bl_options = {"REGISTER", "UNDO"}

    product: EnumProperty(name="Product", items=layer_product_items, description="The product whose layer goes")

    @classmethod
    def poll(cls, context):
        return context.object is not None

    def execute(self, context):
        return change_layer(self, context, makeup_layer.remove_layer, "removed")


class VTO_OT_choose_layer(bpy.types.Operator):
    """Fill this makeup layer with the next Match (its group becomes the material's active node)"""

    bl_idname = "vto.choose_layer"
    bl_label = "Choose Makeup Layer"
    bl_options = {"REGISTER", "UNDO"}

    material_name: StringProperty(name="Material", description="The material wearing the layers")
    product: EnumProperty(name="Product", items=material_product_items, description="The layer Match fills")

    def execute(self, context):
        material = bpy.data.materials.get(self.material_name)
        try:
            if material is None:
                raise VtoError(f"no material '{self.material_name}' in this .blend")
            apply.choose_layer(material, get_product(self.product))
        except VtoError as exc:
            self.report({"ERROR"}, str(exc))
            return {"CANCELLED"}
        return {"FINISHED"}


def layer_choice(layout, material) -> None:
    """Where `material` wears several VTO groups, a row of them, the one Match fills pressed (vto.choose_layer)."""
    worn = apply.worn_products(material)
    if len(worn) < 2:
        return
    chosen = apply.material_product(material)
    row = layout.row(align=True)
    row.label(text="Fill:")
    for product in worn:
        button = row.operator(VTO_OT_choose_layer.bl_idname, text=product.label, depress=product is chosen)
        button.material_name, button.product = material.name, product.name


def layer_buttons(layout, material) -> None:
    """An "Add <Product> Layer" button a face layer `material` does not wear, a "Remove <Product> Layer" one a layer
    it wears (vto.add_makeup_layer, vto.remove_makeup_layer); none without a material."""
    if material is None:
        return
    worn = [product for product, _ in makeup_layer.layers(material)]
    for product in makeup_layer.layer_products():
        if product in worn:
            layout.operator(VTO_OT_remove_makeup_layer.bl_idname, text=f"Remove {product.label} Layer",
                            icon="REMOVE").product = product.name
        elif not blender_side(product).nodes(material):
            layout.operator(VTO_OT_add_makeup_layer.bl_idname, text=f"Add {product.label} Layer",
                            icon="ADD").product = product.name


class VTO_OT_add_hair_compositor(bpy.types.Operator):
    """Add the two VTO hair compositor groups to this scene's compositor, wired to the render and the output; the
    selected hair objects (curves, meshes, particle hair's emitter) give the hair mask from the render's own passes"""

    bl_idname = "vto.add_hair_compositor"
    bl_label = "Add VTO Hair Compositor"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        return context.scene is not None

    def execute(self, context):
        selected = list(getattr(context, "selected_objects", None) or ())
        try:
            nodes = [node for product in apply.compositor_products()
                     for node in blender_side(product).add_group(context.scene, selected)]
        except VtoError as exc:
            self.report({"ERROR"}, failure_line(exc))
            return {"CANCELLED"}
        self.report({"INFO"}, f"added {' and '.join(n.name for n in nodes)} to the compositor of "
                              f"'{context.scene.name}'")
        return {"FINISHED"}


_TARGET_ITEMS: list = []  # Blender keeps no copy of a callback's enum strings: they live here


def target_items(self, context) -> list:
    """The Match operator's targets, one a declared product (vto_core.products), the first the default."""
    items = [product.target_item for product in PRODUCTS.values()]
    if items != _TARGET_ITEMS:
        _TARGET_ITEMS[:] = items
    return _TARGET_ITEMS


class VTO_OT_match_from_photo(bpy.types.Operator):
    """Estimate the look of the reference photo and write it into the group's inputs (one undo step)"""

    bl_idname = "vto.match_from_photo"
    bl_label = "Match"
    bl_options = {"REGISTER", "UNDO"}

    target: EnumProperty(name="Target", items=target_items)
    material: StringProperty(name="Material", default="", description="Material name (default: the active one)")
    image_path: StringProperty(name="Image", subtype="FILE_PATH", description="Reference photo (default: the panel's)")
    image_name: StringProperty(name="Image Datablock", default="", description="An image of this .blend instead")
    mask_path: StringProperty(name="Mask", subtype="FILE_PATH", description="Optional mask image")
    crop: FloatVectorProperty(name="Crop", size=4, min=0.0, default=(0.0, 0.0, 1.0, 1.0),
                              description="x, y, w, h from the top-left, pixels or fractions")
    model_path: StringProperty(name="Model", subtype="FILE_PATH", description="Encoder (.onnx); default: the panel's")
    quality: EnumProperty(name="Quality", items=QUALITY_ITEMS, default="FAST")
    find_region: BoolProperty(name="Find Region", default=True,
                              description="Find the product's region in the photo ("
                                          f"{either(p.region for p in PRODUCTS.values())}); off: the image or crop "
                                          "is taken as it is, as framed on it")
    # The older names of find_region, one a product, still taken from scripts
    find_lips: BoolProperty(name="Find Lips", default=True, options={"HIDDEN"}, description="find_region's older name")
    find_hair: BoolProperty(name="Find Hair", default=True, options={"HIDDEN"}, description="find_region's older name")

    def settings(self, stored) -> dict:
        """The stored panel settings (if any), overridden by whatever was passed to this call."""
        settings = settings_dict(stored) if stored is not None else {"quality": "FAST"}
        passed = self.properties.is_property_set
        if passed("image_path") or passed("image_name"):
            settings.pop("image_path", None)
            settings.pop("image_name", None)
            settings["image_path" if passed("image_path") else "image_name"] = (
                self.image_path if passed("image_path") else self.image_name)
        for name in ("mask_path", "model_path", "quality"):
            if passed(name):
                settings[name] = getattr(self, name)
        for name in ("find_lips", "find_hair", "find_region"):  # the newest name passed wins
            if passed(name):
                settings["find_region"] = getattr(self, name)
        if passed("crop"):
            settings["crop"] = tuple(self.crop)
        return settings

    def begin(self, context):
        """(the validated MatchJob, the settings group to remember the values in); VtoError on bad input."""
        product = product_of_target(self.target)
        renderer = product.name
        material, stored = None, None
        if product.is_material:
            material = bpy.data.materials.get(self.material) if self.material else getattr(context, "material", None)
            if self.material and material is None:
                raise VtoError(f"no material '{self.material}' in this .blend")
            if material is None:
                raise VtoError("no material: pass material=NAME or select an object with a material")
            stored = getattr(material, "vto_match", None)
        else:
            stored = apply.stage_settings(context.scene, product)
        settings = self.settings(stored)
        if not self.properties.is_property_set("quality") and settings["quality"] not in product.fit.offered:
            settings["quality"] = "FAST"  # what the panel shows: it offers no other for this renderer
        settings["preference_model"] = preference_model(context, renderer)
        if product.is_material:
            return apply.MatchJob(renderer, settings, material_name=material.name), stored
        return apply.MatchJob(renderer, settings, scene=context.scene), stored

    def fail(self, exc: Exception) -> set:
        """One line in the report; nothing was written."""
        self.report({"ERROR"}, failure_line(exc))
        return {"CANCELLED"}

    def done(self, job, stored, values) -> set:
        """Write the values (targets checked again), remember them for the panel, report one line."""
        result = job.finish(values)
        for warning in job.warnings:
            self.report({"WARNING"}, warning)
        for note in job.notes:
            self.report({"INFO"}, note)
        if stored is not None:
            remember(stored, job.renderer, result["values"], result["model"], result["seconds"])
        if job.product.kind.tryon and stored is not None and not another_thread_renders():
            # the panel's Preview on Photo, after Match, on the photo Match read (not while Blender renders: a render
            # now would wait for the Python lock that render's thread needs, as Better does)
            preview.refresh(bpy.data.materials[job.material_name], job.prepared["reference"].whole)
        self.report({"INFO"}, f"matched {job.where} in {1000 * result['seconds']:.0f} ms: "
                              + ", ".join(apply.describe(result["spec"], result["values"])))
        return {"FINISHED"}

    def execute(self, context):
        window_manager = context.window_manager
        try:
            job, stored = self.begin(context)
        except Exception as exc:  # VtoError, or anything unforeseen: still one line, never a traceback in the UI
            return self.fail(exc)
        if job.budget:
            window_manager.progress_begin(0, job.budget)
        try:
            values = apply.drain(job.steps(), window_manager.progress_update if job.budget else None)
            return self.done(job, stored, values)
        except Exception as exc:
            return self.fail(exc)
        finally:
            if job.budget:
                window_manager.progress_end()

    def invoke(self, context, event):
        """From the UI, refinement runs a few renders per timer tick (the UI stays live; Esc cancels)."""
        if bpy.app.background or context.window is None:
            return self.execute(context)
        try:
            job, stored = self.begin(context)
        except Exception as exc:
            return self.fail(exc)
        if not job.budget:
            try:
                return self.done(job, stored, apply.drain(job.steps()))
            except Exception as exc:
                return self.fail(exc)
        window_manager = context.window_manager
        self._job, self._stored, self._steps = job, stored, job.steps()
        window_manager.progress_begin(0, job.budget)
        self._timer = window_manager.event_timer_add(0.02, window=context.window)
        window_manager.modal_handler_add(self)
        self.report({"INFO"}, f"refining with {job.budget} renders (Esc cancels, nothing is changed until the end)")
        return {"RUNNING_MODAL"}

    def modal(self, context, event):
        if event.type == "ESC":
            self.stop(context)
            self.report({"WARNING"}, "Match cancelled: nothing changed")
            return {"CANCELLED"}
        if event.type != "TIMER":
            return {"PASS_THROUGH"}
        deadline = time.perf_counter() + TICK_SECONDS
        try:
            while True:
                if another_thread_renders():
                    return {"RUNNING_MODAL"}  # wait: a render now would hold the Python lock that render's thread needs
                context.window_manager.progress_update(next(self._steps))
                if time.perf_counter() > deadline:
                    return {"RUNNING_MODAL"}
        except StopIteration as finished:
            self.stop(context)
            try:
                return self.done(self._job, self._stored, finished.value)
            except Exception as exc:
                return self.fail(exc)
        except Exception as exc:
            self.stop(context)
            return self.fail(exc)

    def stop(self, context) -> None:
        context.window_manager.event_timer_remove(self._timer)
        context.window_manager.progress_end()
        # Its scratch data (the default scenes a fit renders) goes now: a generator left to the garbage collector would
        # remove, whenever it is collected, every data-block made since it began, the artist's included.
        self._steps.close()


BLENDER_JOBS = ("RENDER_PREVIEW", "RENDER", "COMPOSITE")  # bpy.app.is_job_running's types that render in a thread


def another_thread_renders() -> bool:
    """Whether Blender renders in a job thread (the material preview and its icons, re-rendered after a material
    changes; an F12 render; the compositor) or a thread other than this one is inside Cycles' Python callbacks.

    Starting a render from the main thread then deadlocks Blender (seen in Blender 4.3: the main thread waits for the
    preview job holding the Python lock, the job waits for the lock). Measured in Blender 4.3's real window (a
    material changed every 3 s, polled every millisecond): the preview's job is running from its start, also while
    its thread is in C between the preview's renders, where no Python frame shows it. The frames still catch a render
    in a thread that Blender's job list does not hold."""
    import sys
    import threading

    for kind in BLENDER_JOBS:
        try:
            if bpy.app.is_job_running(kind):
                return True
        except ValueError:  # a job type this Blender does not have
            continue
    here = threading.get_ident()
    for ident, frame in sys._current_frames().items():
        while ident != here and frame is not None:
            if frame.f_code.co_name in ("render", "render_preview") and "cycles" in frame.f_code.co_filename:
                return True
            frame = frame.f_back
    return False


class VTO_OT_preview_on_photo(bpy.types.Operator):
    """Try the material's current values on the product's region of the reference photo (changes nothing)"""

    bl_idname = "vto.preview_on_photo"
    bl_label = "Preview on Photo"

    material: StringProperty(name="Material", default="", description="Material name (default: the active one)")

    def execute(self, context):
        material = bpy.data.materials.get(self.material) if self.material else getattr(context, "material", None)
        if material is None:
            self.report({"ERROR"}, f"no material '{self.material}' in this .blend" if self.material else
                        "no material: pass material=NAME or select an object with a material")
            return {"CANCELLED"}
        if another_thread_renders():
            self.report({"ERROR"}, "Blender is rendering a preview: press Preview on Photo again in a moment")
            return {"CANCELLED"}
        note = preview.refresh(material)[1]
        if note:
            self.report({"ERROR"}, note)
            return {"CANCELLED"}
        return {"FINISHED"}


class VTO_OT_find_face(bpy.types.Operator):
    """Find the face on the active mesh (a head, or a whole body): render it from its front, read the render with the
    face models, and write its lips and eyelids as the attributes the makeup layers read"""

    bl_idname = "vto.find_face"
    bl_label = "Find Face on Mesh"
    bl_options = {"REGISTER", "UNDO"}

    use_scene_camera: BoolProperty(name="From the Scene Camera", default=False,
                                   description="See the face from the scene's camera (default: the mesh's own front, "
                                               "back or sides, whichever shows a face)")

    @classmethod
    def poll(cls, context):
        return context.scene is not None

    def execute(self, context):
        from ..matching.face_on_mesh import drawn_landmarks, find_face, place_camera

        camera = context.scene.camera if self.use_scene_camera else None
        try:
            if self.use_scene_camera and camera is None:
                raise VtoError(f"scene '{context.scene.name}' has no camera")
            found = find_face(context.object, camera)
        except VtoError as exc:
            self.report({"ERROR"}, failure_line(exc))
            return {"CANCELLED"}
        place_camera(context.scene, context.object, found.view)
        preview.show_found_face(context.object.name, drawn_landmarks(found))
        for area in (a for a in getattr(context.screen, "areas", ()) if a.type == "VIEW_3D"):
            shading = area.spaces.active.shading  # the regions found, in the viewport's solid shading
            if shading.type == "SOLID":
                shading.color_type = "VERTEX"
        for note in found.notes:
            self.report({"WARNING"}, note)
        found_text = ", ".join(f"{name} on {count} vertices" for name, count in found.counts.items())
        self.report({"INFO"}, f"found the face on '{context.object.name}': {found_text}")
        return {"FINISHED"}


CLASSES = (VTO_OT_find_face, VTO_OT_add_material, VTO_OT_add_lipstick_material, VTO_OT_add_makeup_layer,
           VTO_OT_remove_makeup_layer, VTO_OT_choose_layer, VTO_OT_add_hair_compositor, VTO_OT_match_from_photo,
           VTO_OT_preview_on_photo)


def add_material_buttons(layout) -> None:
    """One "Add VTO <Product> Material" button a material product (vto.add_material)."""
    for product in PRODUCTS.values():
        if product.is_material:
            layout.operator(VTO_OT_add_material.bl_idname, text=f"Add VTO {product.label} Material",
                            icon="MATERIAL").product = product.name


def _material_menu(self, context):
    add_material_buttons(self.layout)


def register() -> None:
    for cls in CLASSES:
        bpy.utils.register_class(cls)
    bpy.types.MATERIAL_MT_context_menu.append(_material_menu)


def unregister() -> None:
    bpy.types.MATERIAL_MT_context_menu.remove(_material_menu)
    for cls in reversed(CLASSES):
        bpy.utils.unregister_class(cls)
