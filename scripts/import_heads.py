"""Turn three public head meshes into small test files: data/heads/<name>.blend (one head, metres, face towards -Y,
+Z up, one neutral skin material, nothing else in the file) and data/heads/heads.json (what was done to each).

    usage: .venv/bin/python scripts/import_heads.py SRC_DIR

SRC_DIR holds the originals, exactly as they are in their repositories (this script downloads nothing):
  base.obj                    makehumancommunity/mpfb2  src/mpfb/data/3dobjs/base.obj            (CC0)
  lips_solid.json.gz ...      makehumancommunity/mpfb2  src/mpfb/data/uv_layers/*.json.gz        (CC0, optional)
  mpfb_lips.jpg, mpfb_eyelids.jpg  makehumancommunity/mpfb2  src/mpfb/data/textures/            (CC0, optional)
  LeePerrySmith.glb, Map-COL.jpg   three.js examples/models/gltf/LeePerrySmith/ (CC BY 3.0)
  headmodel.obj               WoshuaJolk/referenceangle  public/models/headmodel.obj             (CC0)
Where each file was taken from (repository, commit, blob) is written in data/heads/README.md.

What is done to every head: import with bpy's own importer; turn it so the face looks along -Y (Blender's front
view); scale to metres (MakeHuman's decimetres by 0.1, the sculpt is already in metres, the scan has no unit and is
scaled to 0.232 m from chin to crown); cut it flat below the neck; centre it (x and y on the head's box, z half way
between chin and crown); one Principled BSDF "skin" material (the scan's own colour map, the others the plain skin
tone); shade smooth; decimate only if the saved file would pass 5 MB. The chin (menton) heights below were measured
on each original's midline profile, at the point where the chin's front turns into its underside.
"""

from __future__ import annotations

import gzip
import json
import math
import sys
from pathlib import Path

import bpy
import bmesh  # noqa: E402,I001 (bpy must come first: it puts bmesh on the path)
import numpy as np
from mathutils import Matrix

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "data" / "heads"
SKIN_TONE = (0.6, 0.45, 0.38)
EYE_WHITE = (0.8, 0.78, 0.74)
MAX_BYTES = 5 * 1024 * 1024
MAX_TEXTURE_BYTES = 2 * 1024 * 1024  # an original's colour map is packed only if it is this small
CHIN_TO_CROWN_M = 0.232  # adult menton-vertex height, used only where the original has no unit

# Per head, in the original's units once it is imported and turned face-to--Y:
#   turn_z: degrees about Z that make the face look along -Y
#   scale: original units to metres (None: from chin and crown, to CHIN_TO_CROWN_M)
#   chin_z: the menton's height; cut_z: everything below it goes (the neck stays, the shoulders go)
#   flip_v: the glb's UVs follow the OpenGL convention (three.js loads Map-COL.jpg with flipY on), so v is flipped back
HEADS = {
    "makehuman": dict(
        kind="character-generator export (MakeHuman / MPFB 2 base mesh hm08, default proportions)",
        source="base.obj", turn_z=0.0, scale=0.1, chin_z=6.12, cut_z=5.80),
    "lee_perry_smith": dict(
        kind="3D scan (Infinite Realities head scan of Lee Perry-Smith, as in the three.js examples)",
        source="LeePerrySmith.glb", texture="Map-COL.jpg", flip_v=True, turn_z=0.0, scale=None, chin_z=-0.45,
        cut_z=-1.25),
    "blender_sculpt": dict(
        kind="digital sculpt (Blender Studio Human Base Meshes: Head (Sculpting) - Realistic, by Dan Ulrich)",
        source="headmodel.obj", turn_z=180.0, scale=1.0, chin_z=-0.049, cut_z=-0.078),
}

MH_KEEP_EYES = {"helper-l-eye": "eye.L", "helper-r-eye": "eye.R"}  # the person's left eye is on +X
MH_FOCUS_MAPS = ("lips_solid", "lips_horizontal_split", "eyelids_solid", "eyelids_horizontal_split")
MH_MASKS = {"mpfb_lips": "mpfb_lips.jpg", "mpfb_eyelids": "mpfb_eyelids.jpg"}
MH_BODY_FACES = 13378  # the body group's faces come first in base.obj; MPFB's focus maps index these


def reset() -> None:
    bpy.ops.wm.read_factory_settings(use_empty=True)


def mesh_objects() -> list[bpy.types.Object]:
    return [o for o in bpy.data.objects if o.type == "MESH"]


def bake_transform(obj: bpy.types.Object, matrix: Matrix) -> None:
    """Put matrix @ obj's world matrix into its vertices; the object keeps an identity transform."""
    obj.data.transform(matrix @ obj.matrix_world)
    obj.parent = None
    obj.matrix_world = Matrix.Identity(4)


def world_points(objs: list[bpy.types.Object]) -> np.ndarray:
    pts = []
    for o in objs:
        co = np.empty(len(o.data.vertices) * 3)
        o.data.vertices.foreach_get("co", co)
        co = co.reshape(-1, 3)
        m = np.array(o.matrix_world)
        pts.append(co @ m[:3, :3].T + m[:3, 3])
    return np.concatenate(pts)


def delete_verts(obj: bpy.types.Object, drop: np.ndarray) -> None:
    bm = bmesh.new()
    bm.from_mesh(obj.data)
    bm.verts.ensure_lookup_table()
    bmesh.ops.delete(bm, geom=[bm.verts[i] for i in np.flatnonzero(drop)], context="VERTS")
    bm.to_mesh(obj.data)
    bm.free()


def cut_below(obj: bpy.types.Object, z: float) -> None:
    """Cut the mesh flat at height z and drop what is below (the object has an identity transform)."""
    bm = bmesh.new()
    bm.from_mesh(obj.data)
    bmesh.ops.bisect_plane(bm, geom=bm.verts[:] + bm.edges[:] + bm.faces[:], dist=1e-7, plane_co=(0.0, 0.0, z),
                           plane_no=(0.0, 0.0, 1.0), clear_inner=True)
    bm.to_mesh(obj.data)
    bm.free()


def flip_v(obj: bpy.types.Object) -> None:
    for layer in obj.data.uv_layers:
        uv = np.empty(len(obj.data.loops) * 2)
        layer.data.foreach_get("uv", uv)
        uv[1::2] = 1.0 - uv[1::2]
        layer.data.foreach_set("uv", uv)


def drop_loose(obj: bpy.types.Object) -> None:
    """Drop vertices that no face uses (left where the cut took their faces)."""
    used = np.zeros(len(obj.data.vertices), bool)
    fv = np.empty(len(obj.data.loops), np.int64)
    obj.data.loops.foreach_get("vertex_index", fv)
    used[fv] = True
    if not used.all():
        delete_verts(obj, ~used)


def load_makehuman(src: Path) -> tuple[bpy.types.Object, list[bpy.types.Object]]:
    """base.obj as one mesh (file order kept, so face i is MPFB's face i); keep the body and the two eye helpers,
    drop the other helpers (tights, skirt, hair, teeth, tongue, eyelashes, genitals) and the joint cubes."""
    bpy.ops.wm.obj_import(filepath=str(src / "base.obj"), use_split_objects=False, use_split_groups=False,
                          import_vertex_groups=True)
    (obj,) = mesh_objects()
    me = obj.data
    assert len(me.vertices) == 19158 and len(me.polygons) == 18486, "not the hm08 base mesh"
    assert all(me.polygons[i].loop_total == 4 and me.polygons[i].loop_start == 4 * i for i in range(MH_BODY_FACES))
    # the original indices travel with the geometry, so MPFB's per-face / per-vertex data still apply
    me.attributes.new("mh_vertex_index", "INT", "POINT").data.foreach_set("value", np.arange(len(me.vertices)))
    me.attributes.new("mh_face_index", "INT", "FACE").data.foreach_set("value", np.arange(len(me.polygons)))
    group = {g.name: g.index for g in obj.vertex_groups}
    member = np.full(len(me.vertices), -1)
    for v in me.vertices:
        for g in v.groups:
            if g.group in (group["body"], group["helper-l-eye"], group["helper-r-eye"]):
                member[v.index] = g.group
    keep = member >= 0
    add_focus_maps(obj, src)
    delete_verts(obj, ~keep)
    # the eyes become objects of their own
    eyes = []
    for helper, name in MH_KEEP_EYES.items():
        bm = bmesh.new()
        bm.from_mesh(obj.data)
        layer = bm.verts.layers.deform.active
        gi = obj.vertex_groups[helper].index
        bmesh.ops.delete(bm, geom=[v for v in bm.verts if gi not in v[layer]], context="VERTS")
        eye_mesh = bpy.data.meshes.new(name)
        bm.to_mesh(eye_mesh)
        bm.free()
        eye = bpy.data.objects.new(name, eye_mesh)
        eye.matrix_world = obj.matrix_world
        bpy.context.scene.collection.objects.link(eye)
        eyes.append(eye)
    body_gi = obj.vertex_groups["body"].index
    not_body = np.array([all(g.group != body_gi for g in v.groups) for v in obj.data.vertices])
    delete_verts(obj, not_body)
    add_mask_groups(obj, src)
    for o in [obj] + eyes:
        for g in [g for g in o.vertex_groups if not g.name.startswith("mpfb_")]:
            o.vertex_groups.remove(g)
        for name in [u.name for u in o.data.uv_layers if o is not obj and u.name.startswith("focus_")]:
            o.data.uv_layers.remove(o.data.uv_layers[name])
    return obj, eyes


def add_focus_maps(obj: bpy.types.Object, src: Path) -> None:
    """MPFB's focus UV maps ({face: {loop: [u, v]}}, the UV an ink layer uses) as UV layers focus_<name>; loops
    outside the focus get the base UV scaled by 0.01, as MPFB's MeshService.add_uv_map_from_dict does."""
    me = obj.data
    base = np.empty(len(me.loops) * 2)
    me.uv_layers[0].data.foreach_get("uv", base)
    for name in MH_FOCUS_MAPS:
        path = src / f"{name}.json.gz"
        if not path.is_file():
            continue
        with gzip.open(path, "rt") as f:
            focus = json.load(f)
        uv = base.reshape(-1, 2) * 0.01
        for face, loops in focus.items():
            for loop, coords in loops.items():
                uv[int(loop)] = coords
        layer = me.uv_layers.new(name=f"focus_{name}", do_init=False)
        layer.data.foreach_set("uv", uv.ravel())
    me.uv_layers.active_index = 0


def add_mask_groups(obj: bpy.types.Object, src: Path) -> None:
    """MPFB's lips and eyelids masks (grey JPEGs in the base UV layout) as vertex groups mpfb_lips, mpfb_eyelids:
    each vertex weighs the mask's mean over its loops' UVs."""
    me = obj.data
    uv = np.empty(len(me.loops) * 2)
    me.uv_layers[0].data.foreach_get("uv", uv)
    uv = uv.reshape(-1, 2)
    lv = np.empty(len(me.loops), np.int64)
    me.loops.foreach_get("vertex_index", lv)
    for group, filename in MH_MASKS.items():
        path = src / filename
        if not path.is_file():
            continue
        image = bpy.data.images.load(str(path))
        w, h = image.size
        px = np.empty(w * h * image.channels, np.float32)
        image.pixels.foreach_get(px)
        grey = px.reshape(h, w, image.channels)[:, :, 0]  # bpy's rows run bottom to top, as UV v does
        bpy.data.images.remove(image)
        x = np.clip((uv[:, 0] * w).astype(int), 0, w - 1)
        y = np.clip((uv[:, 1] * h).astype(int), 0, h - 1)
        value = grey[y, x]
        weight = np.bincount(lv, value, len(me.vertices)) / np.maximum(np.bincount(lv, None, len(me.vertices)), 1)
        vg = obj.vertex_groups.new(name=group)
        for i in np.flatnonzero(weight > 0.01):
            vg.add([int(i)], float(weight[i]), "REPLACE")


def load_gltf(src: Path, filename: str) -> tuple[bpy.types.Object, list]:
    bpy.ops.import_scene.gltf(filepath=str(src / filename))
    for o in [o for o in bpy.data.objects if o.type != "MESH"]:  # the file's camera and lamp empties
        bpy.data.objects.remove(o)
    (obj,) = mesh_objects()
    return obj, []


def load_obj(src: Path, filename: str) -> tuple[bpy.types.Object, list]:
    bpy.ops.wm.obj_import(filepath=str(src / filename))
    (obj,) = mesh_objects()
    return obj, []


def skin_material(texture: Path | None) -> bpy.types.Material:
    mat = bpy.data.materials.new("skin")
    mat.use_nodes = True
    nodes = mat.node_tree.nodes
    bsdf = nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (*SKIN_TONE, 1.0)
    bsdf.inputs["Roughness"].default_value = 0.5
    mat.diffuse_color = (*SKIN_TONE, 1.0)
    if texture is not None:
        image = bpy.data.images.load(str(texture))
        image.pack()
        tex = nodes.new("ShaderNodeTexImage")
        tex.image = image
        tex.location = (-400, 300)
        mat.node_tree.links.new(tex.outputs["Color"], bsdf.inputs["Base Color"])
    return mat


def eye_material() -> bpy.types.Material:
    mat = bpy.data.materials.new("eye")
    mat.use_nodes = True
    bsdf = mat.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (*EYE_WHITE, 1.0)
    bsdf.inputs["Roughness"].default_value = 0.2
    mat.diffuse_color = (*EYE_WHITE, 1.0)
    return mat


def set_material(obj: bpy.types.Object, mat: bpy.types.Material) -> None:
    obj.data.materials.clear()
    obj.data.materials.append(mat)
    obj.data.polygons.foreach_set("material_index", np.zeros(len(obj.data.polygons), np.int64))
    obj.data.polygons.foreach_set("use_smooth", np.ones(len(obj.data.polygons), bool))


def purge() -> None:
    """Nothing in the file but the head's objects and what they use."""
    keep = set(mesh_objects())
    for o in list(bpy.data.objects):
        if o not in keep:
            bpy.data.objects.remove(o)
    for c in list(bpy.data.collections):
        bpy.data.collections.remove(c)
    for o in keep:
        if o.name not in bpy.context.scene.collection.objects:
            bpy.context.scene.collection.objects.link(o)
    for coll in (bpy.data.worlds, bpy.data.cameras, bpy.data.lights):
        for block in list(coll):
            coll.remove(block)
    bpy.data.orphans_purge(do_local_ids=True, do_linked_ids=True, do_recursive=True)


def save(path: Path) -> int:
    bpy.context.preferences.filepaths.save_version = 0  # no .blend1 beside it
    bpy.ops.wm.save_as_mainfile(filepath=str(path), compress=True, copy=False)
    return path.stat().st_size


def import_head(name: str, spec: dict, src: Path) -> dict:
    reset()
    if name == "makehuman":
        head, eyes = load_makehuman(src)
    elif spec["source"].endswith(".glb"):
        head, eyes = load_gltf(src, spec["source"])
    else:
        head, eyes = load_obj(src, spec["source"])
    parts = [head] + eyes
    turn = Matrix.Rotation(math.radians(spec["turn_z"]), 4, "Z")
    for o in parts:
        bake_transform(o, turn)
    vertices_before_cut = len(head.data.vertices)

    # cut below the neck (in the original's units), then scale and centre
    cut_below(head, spec["cut_z"])
    drop_loose(head)
    if spec.get("flip_v"):
        flip_v(head)
    pts = world_points(parts)
    crown = float(pts[:, 2].max())
    scale = spec["scale"] or CHIN_TO_CROWN_M / (crown - spec["chin_z"])
    lo, hi = pts.min(0), pts.max(0)
    centre = np.array([(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, (spec["chin_z"] + crown) / 2])
    move = Matrix.Diagonal((scale, scale, scale, 1.0)) @ Matrix.Translation(-centre)
    for o in parts:
        bake_transform(o, move)

    texture = src / spec["texture"] if spec.get("texture") else None
    if texture is not None and texture.stat().st_size > MAX_TEXTURE_BYTES:
        texture = None
    set_material(head, skin_material(texture))
    if eyes:
        eye_mat = eye_material()
        for e in eyes:
            set_material(e, eye_mat)
    head.name = head.data.name = "head"
    for e in eyes:
        e.data.name = e.name

    pts = world_points([head])
    chin_z = (spec["chin_z"] - centre[2]) * scale
    crown_z = float(pts[:, 2].max())
    head["chin_z"] = chin_z
    head["crown_z"] = crown_z
    head["front_y"] = float(pts[:, 1].min())
    head["source_file"] = spec["source"]
    head["kind"] = spec["kind"]
    purge()

    path = OUT / f"{name}.blend"
    size = save(path)
    decimated = None
    while size > MAX_BYTES:  # not needed by any of the three at the time of writing
        ratio = 0.9 * MAX_BYTES / size
        mod = head.modifiers.new("decimate", "DECIMATE")
        mod.ratio = ratio
        bpy.context.view_layer.objects.active = head
        bpy.ops.object.modifier_apply(modifier=mod.name)
        decimated = len(head.data.vertices)
        size = save(path)
    record = {
        "file": path.name,
        "kind": spec["kind"],
        "source_file": spec["source"],
        "vertices_before_cut": vertices_before_cut,
        "vertices": len(head.data.vertices),
        "faces": len(head.data.polygons),
        "eye_objects": [e.name for e in eyes],
        "eye_vertices": sum(len(e.data.vertices) for e in eyes),
        "decimated_to": decimated,
        "turn_z_deg": spec["turn_z"],
        "scale": scale,
        "cut_below_original_z": spec["cut_z"],
        "chin_z_m": round(chin_z, 4),
        "crown_z_m": round(crown_z, 4),
        "chin_to_crown_m": round(crown_z - chin_z, 4),
        "size_m": [round(float(v), 4) for v in np.ptp(world_points(mesh_objects()), 0)],
        "base_colour": f"texture {texture.name}" if texture is not None else list(SKIN_TONE),
        "uv_layers": [u.name for u in head.data.uv_layers],
        "vertex_groups": [g.name for g in head.vertex_groups],
        "bytes": size,
    }
    print(json.dumps({name: record}))
    return record


def main(argv: list[str]) -> None:
    if len(argv) != 1:
        sys.exit(__doc__)
    src = Path(argv[0]).resolve()
    OUT.mkdir(parents=True, exist_ok=True)
    records = {name: import_head(name, spec, src) for name, spec in HEADS.items()}
    (OUT / "heads.json").write_text(json.dumps(records, indent=2) + "\n")


if __name__ == "__main__":
    main(sys.argv[1:])
