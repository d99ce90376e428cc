"""Hair colour in the artist's own render: Add VTO Hair Compositor with the hair objects selected masks the stage by
the render's own passes (object index for curves and meshes, material index for particle hair), so the render is
recoloured only where the hair is, under any camera, with no mask image."""

import numpy as np
import pytest
from scipy import ndimage

pytestmark = pytest.mark.blender
bpy = pytest.importorskip("bpy")

from blender_addon.compat import compositor_tree, enable_nodes  # noqa: E402
from blender_addon.renderers.cycles import render_user_scene  # noqa: E402
from blender_addon.renderers.product_hair import RENDERER, free_pass_index, hair_ids  # noqa: E402
from blender_addon.renderers.scene_build import uv_sphere  # noqa: E402
from vto_core.errors import VtoError  # noqa: E402

RES = 32


def coloured(name: str, rgb) -> bpy.types.Material:
    material = bpy.data.materials.new(name)
    enable_nodes(material)
    material.node_tree.nodes["Principled BSDF"].inputs["Base Color"].default_value = (*rgb, 1.0)
    return material


def sphere(scene, name: str, radius: float, location, material) -> bpy.types.Object:
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(*uv_sphere(24, 12, radius))
    mesh.materials.append(material)
    obj = bpy.data.objects.new(name, mesh)
    obj.location = location
    scene.collection.objects.link(obj)
    return obj


@pytest.fixture
def shot():
    """A head and a hair cap (a mesh), a camera in front and a white world: (scene, head, hair)."""
    scene = bpy.data.scenes.new("Hair Shot")
    scene.render.engine = "CYCLES"
    scene.cycles.device, scene.cycles.samples, scene.cycles.use_denoising = "CPU", 4, False
    scene.render.resolution_x = scene.render.resolution_y = RES
    world = bpy.data.worlds.new("Hair Shot")
    enable_nodes(world)
    scene.world = world
    head = sphere(scene, "Head", 1.0, (0, 0, 0), coloured("Skin", (0.6, 0.4, 0.3)))
    hair = sphere(scene, "Hair Cap", 0.7, (0.0, 0.6, 0.6), coloured("Hair", (0.25, 0.15, 0.08)))
    camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    camera.location, camera.rotation_euler = (0, 0, 5), (0, 0, 0)
    scene.collection.objects.link(camera)
    scene.camera = camera
    yield scene, head, hair
    bpy.data.scenes.remove(scene)


def with_stage(scene) -> np.ndarray:
    """The scene's render through its compositor, the stage turned up (shine and intensity 1)."""
    color = next(n for n in compositor_tree(scene).nodes if getattr(n, "node_tree", None)
                 and n.node_tree.name.startswith("VTO Hair Color"))
    color.inputs["Shine"].default_value, color.inputs["Intensity"].default_value = 1.0, 1.0
    scene.render.use_compositing = True
    return render_user_scene(scene, seed=0)


def plain(scene) -> np.ndarray:
    scene.render.use_compositing = False
    try:
        return render_user_scene(scene, seed=0)
    finally:
        scene.render.use_compositing = True


def hair_pixels(scene, hair) -> np.ndarray:
    """(RES, RES) bool: where the hair shows, its neighbours within a pixel included (the mask is anti-aliased)."""
    hidden = {obj: obj.hide_render for obj in scene.objects}
    try:
        for obj in scene.objects:
            obj.hide_render = obj is not hair and obj.type == "MESH"
        scene.render.use_compositing = False
        alone = render_user_scene(scene, seed=0)
    finally:
        for obj, value in hidden.items():
            obj.hide_render = value
    background = render_user_scene_world(scene)
    return ndimage.binary_dilation(np.abs(alone - background).max(-1) > 1e-3)


def render_user_scene_world(scene) -> np.ndarray:
    hidden = {obj: obj.hide_render for obj in scene.objects}
    try:
        for obj in scene.objects:
            obj.hide_render = obj.type == "MESH"
        return render_user_scene(scene, seed=0)
    finally:
        for obj, value in hidden.items():
            obj.hide_render = value


def test_the_hair_objects_pass_masks_the_stage_under_any_camera(shot):
    scene, head, hair = shot
    nodes = RENDERER.add_group(scene, [hair, scene.camera])  # the selection: a camera among it is left out
    assert hair.pass_index >= 1 and head.pass_index != hair.pass_index
    tree = compositor_tree(scene)
    id_mask = tree.nodes["VTO Hair ID Mask IndexOB"]
    assert nodes[1].inputs["Mask"].links[0].from_node == id_mask
    assert scene.view_layers[0].use_pass_object_index
    for location in ((0, 0, 5), (1.5, 0.5, 4.5)):  # the mask follows another camera, with no mask image
        scene.camera.location = location
        recoloured, before = with_stage(scene), plain(scene)
        where = hair_pixels(scene, hair)
        changed = np.abs(recoloured - before).max(-1)
        assert where.any() and (~where).any()
        assert changed[~where].max() <= 1 / 255 + 1e-6, changed[~where].max()
        assert changed[where].max() > 0.02  # the hair itself is recoloured


def test_particle_hair_is_told_by_its_material_and_needs_one(shot):
    scene, head, hair = shot
    head.modifiers.new("Hair", "PARTICLE_SYSTEM")
    settings = head.particle_systems[0].settings
    settings.type, settings.count = "HAIR", 20
    with pytest.raises(VtoError, match="particle hair of 'Head[.0-9]*' has no material"):
        head.material_slots[0].material = None
        RENDERER.add_group(scene, [head])
    assert compositor_tree(scene) is None or not compositor_tree(scene).nodes  # refused before anything changed
    head.data.materials.append(coloured("Strands", (0.1, 0.05, 0.02)))
    settings.material = 2
    whole, materials = hair_ids([head, hair])
    assert whole == [hair] and [m.name for m in materials] == ["Strands"]
    RENDERER.add_group(scene, [head, hair])
    tree = compositor_tree(scene)
    assert {"VTO Hair ID Mask IndexOB", "VTO Hair ID Mask IndexMA"} <= {n.name for n in tree.nodes}
    assert scene.view_layers[0].use_pass_material_index and bpy.data.materials["Strands"].pass_index >= 1


def test_a_free_pass_index_keeps_a_shared_one_and_avoids_the_others_ids():
    class Item:
        def __init__(self, index):
            self.pass_index = index

    a, b, c = Item(3), Item(3), Item(1)
    assert free_pass_index([a, b], [a, b, c]) == 3  # theirs, used by nothing else
    assert free_pass_index([a], [a, Item(3), c]) == 4  # another id uses 3
    assert free_pass_index([Item(0)], [c]) == 2


def test_a_match_fits_the_stage_to_the_renders_own_hair(shot):
    """After a hair Match's write, the artist's render shows the recoloured swatch's colour on its hair (the curve
    fitted to that render's own hair, in scene-linear values), and a later fit of the internal passes leaves it."""
    from blender_addon.renderers.hair import load_swatch, render_hair
    from blender_addon.renderers.nodes_hair import COLOR_GROUP, LUT_NODE
    from vto_core.colour import srgb_to_lab
    from vto_core.hair import swatch_target
    from vto_core.presets import load_presets
    from vto_core.products import HAIR

    scene, head, hair = shot
    scene.view_settings.view_transform = "Standard"  # what is shown is the scene-linear values, sRGB-encoded
    RENDERER.add_group(scene, [hair])
    presets = load_presets(HAIR.name)
    for name in ("Platinum", "Soft Black"):
        values = HAIR.spec.full_values(presets[name])
        values.update(shine=0.0, intensity=1.0)  # the colour alone, over all the hair
        for node in RENDERER.nodes(scene):  # as a Match writes them
            for param in HAIR.spec.params:
                if param.socket in node.inputs:
                    node.inputs[param.socket].default_value = values[param.name]
        settings = lambda: (scene.render.resolution_percentage, scene.render.use_compositing,  # noqa: E731
                            scene.render.filepath, scene.cycles.samples, scene.cycles.use_denoising,
                            scene.render.image_settings.file_format)
        scene.cycles.use_denoising = True  # the fit's render turns it off (a Blender without OpenImageDenoise)
        before = settings()
        write, notes = RENDERER.fitted_target(scene, values)
        assert settings() == before  # the scene rendered small for the fit, then as it was
        scene.cycles.use_denoising = False
        write()
        assert notes == [f"the hair's curve fitted to the hair of scene '{scene.name}' as it renders"]
        scene.render.use_compositing = True
        shown = render_user_scene(scene, seed=0)
        inner = ndimage.binary_erosion(hair_pixels(scene, hair), iterations=2)
        target = swatch_target(load_swatch(), values).reshape(-1, 3).mean(axis=0)
        error = np.abs(srgb_to_lab(shown[inner].mean(axis=0)[None])[0] - srgb_to_lab(target[None])[0])[0]
        assert error < 6.0, f"{name}: the hair's L* {error:.1f} off the recoloured swatch's"
    curve = [tuple(p.location) for p in bpy.data.node_groups[COLOR_GROUP].nodes[LUT_NODE].mapping.curves[0].points]
    render_hair(values, 1, 16, 1)  # the internal passes fit their own group
    assert [tuple(p.location) for p in bpy.data.node_groups[COLOR_GROUP].nodes[LUT_NODE].mapping.curves[0].points] \
        == curve
