"""Find Face on Mesh on heads that no one here made (data/heads): the regions it writes against outlines drawn by hand
on each head's front render, on a head turned, posed and subdivided, from the scene camera, and its refusals."""

import json
import math
import subprocess
import sys

import numpy as np
import pytest

pytestmark = pytest.mark.blender
bpy = pytest.importorskip("bpy")

from benchmarks.heads import EYES, NAMES, front_camera, front_shot, open_head, outline, region_scores  # noqa: E402
from blender_addon.matching import face_on_mesh  # noqa: E402
from blender_addon.matching.face_on_mesh import FACE_CAMERA, attributes_seen, camera_view, find_face  # noqa: E402
from vto_core.errors import VtoError  # noqa: E402
from vto_core.products import EYESHADOW, LIPSTICK  # noqa: E402

LIPS, LIDS = LIPSTICK.face_region.attribute, EYESHADOW.face_region.attribute


@pytest.fixture(autouse=True)
def clean():
    """Whatever a test added to the session's file goes again."""
    kinds = ("objects", "meshes", "materials", "cameras", "armatures", "images")
    before = {kind: set(getattr(bpy.data, kind).keys()) for kind in kinds}
    yield
    for kind in kinds:
        blocks = getattr(bpy.data, kind)
        bpy.data.batch_remove([blocks[name] for name in set(blocks.keys()) - before[kind]])


# What the shipped face model reaches on these heads, against outlines drawn by hand (benchmarks/results/
# face_regions.md): lips IoU 0.66-0.75 (its own lips polygon on the very render the outlines were drawn on: 0.67-0.83),
# vto_lid 0.47-0.78 at the brow. The bars sit below those, so a region lost or misplaced fails.
LIPS_IOU, LASH_AT_MOST, BROW_AT_LEAST, OUTSIDE_AT_MOST = 0.6, 0.1, 0.35, 0.05


@pytest.fixture(scope="module", params=NAMES)
def head(request):  # noqa: F811 (module-scoped: its objects stay until the module's end)
    """(name, region_scores of the attributes found, as its front camera sees them)."""
    name = request.param
    obj = open_head(name)
    find_face(obj)
    seen = attributes_seen(obj, camera_view(front_camera(name), front_shot(name)["resolution"][0]),
                           (LIPS, LIDS, "vto_lid"))
    return name, region_scores(outline(name), seen)


def test_lips_match_the_hand_outline(head):
    name, scores = head
    assert scores["lips_iou"] >= LIPS_IOU, f"{name}: lips IoU {scores['lips_iou']:.3f}"
    assert scores["lips_outside"] <= OUTSIDE_AT_MOST, f"{name}: lips weigh {scores['lips_outside']:.3f} far outside"


@pytest.mark.parametrize("eye", EYES)
def test_lids_run_from_the_lash_line_to_the_brow(head, eye):
    name, scores = head
    assert scores[f"{eye}_lash"] <= LASH_AT_MOST, f"{name} {eye}: vto_lid {scores[f'{eye}_lash']:.2f} at the lash line"
    assert scores[f"{eye}_brow"] >= BROW_AT_LEAST, f"{name} {eye}: vto_lid {scores[f'{eye}_brow']:.2f} at the brow"
    assert scores["lids_below"] <= OUTSIDE_AT_MOST, f"{name}: lids weigh {scores['lids_below']:.3f} below the eyes"


def test_a_turned_posed_subdivided_head_is_found():
    """Facing +X, bent by an armature and under a Subdivision modifier: found from its side, the attributes written
    on the base mesh's own vertices; the framing camera is placed by the operator."""
    obj = open_head("lee_perry_smith")
    before = len(obj.data.vertices)
    obj.rotation_mode, obj.rotation_euler = "XYZ", (0.0, 0.0, math.radians(90))
    arm = bpy.data.objects.new("Rig", bpy.data.armatures.new("Rig"))
    bpy.context.scene.collection.objects.link(arm)
    obj.modifiers.new("Pose", "ARMATURE").object = arm
    obj.modifiers.new("Smooth", "SUBSURF").levels = 1
    bpy.context.view_layer.objects.active = obj
    import blender_addon

    blender_addon.register()
    try:
        assert bpy.ops.vto.find_face() == {"FINISHED"}
    finally:
        blender_addon.unregister()
    lips = np.empty(before, np.float32)
    obj.data.attributes[LIPS].data.foreach_get("value", lips)
    assert len(obj.data.vertices) == before and (lips > 0.5).sum() >= 20
    assert all(m.show_viewport for m in obj.modifiers)  # the modifiers are back as they were
    camera = bpy.data.objects[f"{FACE_CAMERA} {obj.name}"]
    looks = np.array(camera.matrix_world)[:3, 2]  # the camera's back axis: towards the face's front, +X
    assert looks[0] > 0.95


def test_the_framing_camera_holds_the_face_in_a_wide_or_tall_frame():
    """The scene's own frame (16:9, then 9:16) shows the whole face (its landmarks cast on the mesh) with a margin,
    and the camera is drawn at the head's scale."""
    from bpy_extras.object_utils import world_to_camera_view
    from mathutils import Vector

    obj = open_head("makehuman")
    found = find_face(obj)
    scene = bpy.context.scene
    size = (scene.render.resolution_x, scene.render.resolution_y)
    face = [Vector(point) for point in found.points if np.isfinite(point).all()]
    try:
        for width, height in ((1920, 1080), (1080, 1920)):
            scene.render.resolution_x, scene.render.resolution_y = width, height
            camera = face_on_mesh.place_camera(scene, obj, found.view)
            bpy.context.view_layer.update()
            seen = np.array([tuple(world_to_camera_view(scene, camera, point))[:2] for point in face])
            assert len(seen) > 400 and (seen > 0.1).all() and (seen < 0.9).all(), f"{width} x {height}: out of frame"
        assert camera.data.display_size < 0.1  # metres: a head's scale
    finally:
        scene.render.resolution_x, scene.render.resolution_y = size


def unchanged(obj) -> tuple:
    return (sorted(a.name for a in obj.data.attributes), len(bpy.data.objects), len(bpy.data.scenes),
            len(bpy.data.materials), len(bpy.data.cameras), len(bpy.data.worlds))


def test_refusals_are_one_line_and_change_nothing():
    obj = open_head("lee_perry_smith")
    camera = bpy.data.objects.new("Behind", bpy.data.cameras.new("Behind"))
    bpy.context.scene.collection.objects.link(camera)
    camera.location, camera.rotation_euler = (0.0, 1.5, 0.0), (math.radians(90), 0.0, 0.0)  # looking at the back
    bpy.ops.mesh.primitive_cube_add(size=0.2)
    cube = bpy.context.object
    state = unchanged(obj), unchanged(cube)
    cases = [(cube, None, f"found no face on '{cube.name}'"), (obj, camera, "camera 'Behind'"),
             (None, None, "select a mesh"),
             (camera, None, "not a mesh")]
    for target, seen_from, words in cases:
        with pytest.raises(VtoError) as caught:
            find_face(target, seen_from)
        assert words in str(caught.value) and "\n" not in str(caught.value)
    with pytest.raises(VtoError, match="no vertex group 'Nope'"):
        find_face(obj, None, {"lips": "Nope"})
    with pytest.raises(VtoError, match="no face region 'cheeks'"):
        find_face(obj, None, {"cheeks": "Nope"})
    assert (unchanged(obj), unchanged(cube)) == state


def test_a_vertex_group_gives_the_region_weight():
    obj = open_head("makehuman")
    group = next(g for g in obj.vertex_groups if "lips" in g.name)
    find_face(obj, None, {LIPSTICK.face_region.name: group.name})
    lips = np.empty(len(obj.data.vertices), np.float32)
    obj.data.attributes[LIPS].data.foreach_get("value", lips)
    np.testing.assert_allclose(lips, face_on_mesh.group_weights(obj, group.name))
    group.name = "Lips"  # named as the region: used without being asked, and said so
    obj.data.attributes.remove(obj.data.attributes[LIPS])
    found = find_face(obj)
    obj.data.attributes[LIPS].data.foreach_get("value", lips)
    np.testing.assert_allclose(lips, face_on_mesh.group_weights(obj, "Lips"))
    assert "the lips weigh as vertex group 'Lips' says" in found.notes


def vto(*args) -> subprocess.CompletedProcess:
    """The `vto` command in a process of its own (it opens and imports files)."""
    return subprocess.run([sys.executable, "-c", "from vto_core.cli import main; main()", *map(str, args)],
                          capture_output=True, text=True, timeout=300)


def test_cli_writes_the_mesh_with_its_regions(tmp_path):
    obj = open_head("lee_perry_smith")
    for other in bpy.context.scene.objects:
        other.select_set(other == obj)
    bpy.ops.wm.obj_export(filepath=str(tmp_path / "head.obj"), export_materials=False, export_selected_objects=True)
    out = tmp_path / "head.blend"
    done = vto("find-face", "--mesh", tmp_path / "head.obj", "--preview", tmp_path / "found.png", "--out", out)
    assert done.returncode == 0, done.stderr
    printed = json.loads(done.stdout.strip().splitlines()[-1])
    assert printed["regions"][LIPS] > 20 and printed["regions"][LIDS] > 20 and (tmp_path / "found.png").is_file()
    with bpy.data.libraries.load(str(out)) as (source, target):
        target.meshes = [printed["object"]] if printed["object"] in source.meshes else list(source.meshes)
    assert LIPS in target.meshes[0].attributes and LIDS in target.meshes[0].attributes
    for args, words in ((("--mesh", tmp_path / "none.obj", "--out", tmp_path / "x.blend"), "no file at"),
                        (("--mesh", tmp_path / "head.obj", "--out", tmp_path / "x.png"), "must be a .blend"),
                        (("--mesh", tmp_path / "found.png", "--out", tmp_path / "x.blend"), "cannot read")):
        done = vto("find-face", *args)
        assert done.returncode == 2 and words in done.stderr and len(done.stderr.strip().splitlines()) == 1
    assert not (tmp_path / "x.blend").exists()
