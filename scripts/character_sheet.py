"""docs/character_*.png: an artist's own head, and the look that Match reads from a real portrait on it.

    .venv/bin/python scripts/character_sheet.py [--head makehuman] [--out docs/]

Writes, in --out (about 20 s on two cores):
  character_head.png     the head as given (its own skin material), seen by the framing camera Find Face places
  character_found.png    what Find Face on Mesh found: its front render with the landmarks drawn | the regions it wrote
                         on the mesh, tinted over the head's render (red: vto_lips, blue: vto_eyelids)
  character_matched.png  the portrait (its face, eyes and lips) | the head wearing the lipstick and the eye shadow that
                         Match (Fast) wrote into its skin material's makeup layers, the values written under it
  character_hair.png     the head with particle hair (2000 strands on a scalp vertex group, its own hair material in
                         its own slot, combed by the script) plain | through the VTO Hair Compositor, the hair matched
                         (Fast) from a portrait | that portrait

Sources and licences of what it shows:
  - the heads of data/heads (heads.json; README.md has the sources): makehuman.blend, the MakeHuman base mesh hm08
    (MakeHuman Team), CC0 1.0 (the default); lee_perry_smith.blend, "Infinite, 3D Head Scan by Lee Perry-Smith", CC BY
    3.0 (based on a work at www.triplegangers.com); blender_sculpt.blend, "Head (Sculpting) - Realistic" by Dan
    Ulrich (Blender Studio), CC0 by its uploader's word (not yet checked at the source);
  - the portraits of benchmarks/photos (photos.json): official NASA astronaut portraits, works of the U.S. federal
    government, public domain: Linda Godwin (the makeup: bare lips and lids, on which the project's own try-on, as
    `vto tryon`, draws the eye shadow "Royal Purple" and then the lipstick "Classic Red") and Lisa Nowak (the hair).
Renders: Cycles CPU, 320 px (the hair's 280), 32 samples, denoised, Standard view, lit as an artist sees the character:
a world of strength 0.6 and a key light from above the camera (as Find Face's own render).
"""

from __future__ import annotations

import argparse
import math
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

PHOTOS = ROOT / "benchmarks" / "photos"
MAKEUP_PHOTO = "nasa_linda_godwin.jpg"  # natural lips and bare lids: the try-on's makeup is all there is
HAIR_PHOTO = "nasa_lisa_nowak.jpg"  # light-to-medium brown hair
TRIED_ON = (("eyeshadow", "Royal Purple"), ("lipstick", "Classic Red"))  # in this order: the lipstick over the shadow
RES, SAMPLES = 320, 32
HAIR_RES = 280  # px: the hair sheet's three panels
PHOTO_LEVELS = 31  # the portrait's crops in character_matched.png: 5 bits a channel (the renders keep 8)
CAPTION = 18  # px of each caption line
TINT = 0.65  # how much of a region's colour covers the head where the region weighs 1
HAIR_STRANDS = 2000
CLOSE_UP, CLOSE_MARGIN = 100, 1.25  # px high, and the margin around the landmarks, of the close-ups (RES wide)
# Face-mesh landmarks (MediaPipe's 468) the close-ups frame: both eyes with their brows, and the lips.
EYES = (33, 133, 159, 145, 263, 362, 386, 374, 70, 105, 300, 334)
LIPS = (61, 291, 0, 17, 13, 14, 40, 270, 91, 321)
HAIR_LENGTH, HAIR_RADIUS, HAIR_LIFT = 0.07, 0.0015, 0.001  # m: a bob; a strand's root radius; off the skin
HAIR_RISE, HAIR_COMB = 0.4, (0.5, 0.9)  # a strand leaves the scalp this much along its normal, then falls (back, down)
FRAME_TOLERANCE = 0.02  # comb_hair: a strand's frame found within this share of its length
HAIR_PULL_BACK = 1.35  # the hair shot's camera: the framing camera moved back this many times its distance


def caption(lines: list[str], width: int) -> np.ndarray:
    """White text on black, a line each: (CAPTION * len(lines), width, 3) float32 (OpenImageIO's own font)."""
    import OpenImageIO as oiio

    buf = oiio.ImageBuf(oiio.ImageSpec(width, CAPTION * len(lines), 3, "float"))
    for i, line in enumerate(lines):
        oiio.ImageBufAlgo.render_text(buf, 4, CAPTION * (i + 1) - 5, line, 11, "", (1.0, 1.0, 1.0))
    return buf.get_pixels(oiio.FLOAT).reshape(CAPTION * len(lines), width, 3)


def panel(image: np.ndarray, lines: list[str], rows: int) -> np.ndarray:
    """`image` over its caption, padded to `rows` caption lines."""
    return np.concatenate([image, caption(lines + [""] * (rows - len(lines)), image.shape[1])], axis=0)


def sheet(panels: list[tuple[np.ndarray, list[str]]]) -> np.ndarray:
    rows = max(len(lines) for _, lines in panels)
    return np.concatenate([panel(image, lines, rows) for image, lines in panels], axis=1)


def light(scene, camera) -> None:
    """A world of strength 0.6 and a sun from 35 degrees above the camera (Find Face's front_scene)."""
    import bpy

    from blender_addon.compat import enable_nodes

    world = bpy.data.worlds.new("Character World")
    enable_nodes(world)
    world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.6
    scene.world = world
    key = bpy.data.objects.new("Character Key", bpy.data.lights.new("Character Key", "SUN"))
    key.data.energy = 2.0
    scene.collection.objects.link(key)
    key.matrix_world = camera.matrix_world.copy()
    key.rotation_euler.rotate_axis("X", -math.radians(35))


def render(scene, height: int = RES) -> np.ndarray:
    """The scene through its camera: (height, RES, 3) display sRGB (Standard view)."""
    from blender_addon.renderers.cycles import configure_cycles, render_passes, to_display

    configure_cycles(scene, RES, SAMPLES, 0)
    scene.render.resolution_y = height
    return to_display(render_passes(scene)["Combined"][..., :3])


def box(points: np.ndarray, indices, aspect: float, margin: float) -> tuple[np.ndarray, float]:
    """The box (centre (2,), width) around landmarks `points`[indices] (N, 2), `margin` times their extent, at
    least `aspect` (width / height) wide."""
    chosen = points[list(indices)]
    chosen = chosen[~np.isnan(chosen).any(axis=1)]
    low, high = chosen.min(axis=0), chosen.max(axis=0)
    return (low + high) / 2, margin * max(high[0] - low[0], aspect * (high[1] - low[1]))


def close_up(scene, camera, found, indices) -> np.ndarray:
    """The head's landmarks `indices` close up (CLOSE_UP px high): a camera of the framing camera's lens and axis
    centred on them, as they lie in Find Face's front render, at their depth on the mesh."""
    import bpy
    from mathutils import Matrix

    view = found.view
    (cx, cy), width = box(found.landmarks, indices, RES / CLOSE_UP, CLOSE_MARGIN)  # px of the front render
    depth = float(np.nanmedian(view.project(found.points[list(indices)])[1]))
    metres = depth / (view.focal * view.res)  # per pixel of the front render, at that depth
    target = (view.origin + (cx - view.res / 2) * metres * view.right - (cy - view.res / 2) * metres * view.up
              - depth * view.back)
    shot = bpy.data.objects.new("Character Close-up", camera.data.copy())
    shot.data.sensor_fit = "HORIZONTAL"  # `width` across the frame (place_camera fits a wide frame's height)
    scene.collection.objects.link(shot)
    shot.matrix_world = Matrix(np.array(camera.matrix_world))
    shot.location = tuple(target + view.back * width * metres * view.focal)
    previous, scene.camera = scene.camera, shot
    try:
        return render(scene, CLOSE_UP)
    finally:
        scene.camera = previous
        bpy.data.objects.remove(shot)


def rgb(values: dict) -> str:
    return f"RGB {values['red']:.0f} {values['green']:.0f} {values['blue']:.0f}"


def tried_on_portrait(folder: Path) -> tuple[Path, list[tuple[str, str, dict]]]:
    """The makeup portrait with the eye shadow, then the lipstick, drawn on by the project's try-on (`vto tryon`'s
    own functions): (its path, [(product, preset, values)])."""
    from blender_addon.renderers.commands import tryon_params
    from blender_addon.renderers.products import blender_side
    from vto_core.dataset import DEFAULT_SAMPLES
    from vto_core.imageio import read_image, write_image
    from vto_core.products import get_spec

    path, worn = PHOTOS / MAKEUP_PHOTO, []
    for product, preset in TRIED_ON:
        values = get_spec(product).check_values(tryon_params(preset, product))
        photo, _ = read_image(str(path))
        path = folder / f"tried_on_{product}.png"
        write_image(str(path), blender_side(product).tryon(photo, values, crop=None,
                                                                   samples=DEFAULT_SAMPLES, seed=0))
        worn.append((product, preset, values))
    return path, worn


def photo_crop(path: Path, indices) -> np.ndarray:
    """The photo around its face's landmarks `indices`, as close_up frames the head's: (CLOSE_UP, RES, 3)."""
    from blender_addon.shipped import photo_reader
    from vto_core.imageio import read_image, resize

    photo, _ = read_image(str(path))
    face = photo_reader().face_of(np.ascontiguousarray(photo[..., :3], np.float32))
    (cx, cy), width = box(face.landmarks, indices, RES / CLOSE_UP, CLOSE_MARGIN)
    height = width * CLOSE_UP / RES
    x0, y0 = int(round(cx - width / 2)), int(round(cy - height / 2))
    return resize(photo[y0:y0 + int(round(height)), x0:x0 + int(round(width)), :3], CLOSE_UP, RES)


def face_crop(path: Path, size: int, margin: float = 1.5, up: float = 0.1) -> np.ndarray:
    """The photo's face, a square `margin` times its landmarks' extent, resized to `size`."""
    from blender_addon.shipped import photo_reader
    from vto_core.imageio import read_image, resize

    photo, _ = read_image(str(path))
    face = photo_reader().face_of(np.ascontiguousarray(photo[..., :3], np.float32))
    low, high = face.landmarks.min(axis=0), face.landmarks.max(axis=0)
    side = margin * float((high - low).max())
    cx, cy = (low + high) / 2 - np.array([0.0, up * side])
    x0 = int(np.clip(cx - side / 2, 0, photo.shape[1] - side))
    y0 = int(np.clip(cy - side / 2, 0, photo.shape[0] - side))
    side = int(min(side, *photo.shape[:2]))
    return resize(photo[y0:y0 + side, x0:x0 + side, :3], size, size)


def scalp_group(obj, found) -> str:
    """A vertex group of the head's scalp: the vertices above the forehead's top landmark, and those behind the ears
    above the jaw. Returns its name."""
    points = np.array([obj.matrix_world @ v.co for v in obj.data.vertices])
    view = found.view
    forehead = found.points[10]  # the face mesh's top landmark, at the hairline
    ear = np.nanmean(found.points[[234, 454]], axis=0)  # the face's sides
    up = (points - forehead) @ view.up
    behind = -(points - ear) @ view.back  # positive behind the ears
    height = (points - ear) @ view.up
    scalp = (up > 0.005) | ((behind > 0.01) & (height > -0.02))
    group = obj.vertex_groups.new(name="scalp")
    group.add([int(i) for i in np.flatnonzero(scalp)], 1.0, "REPLACE")
    return group.name


def add_hair(scene, obj, found):
    """Particle hair on the head's scalp, its own brown hair material in its own slot: returns the material."""
    import bpy

    from blender_addon.compat import enable_nodes

    group = scalp_group(obj, found)
    material = bpy.data.materials.new("Character Hair")
    enable_nodes(material)
    nodes = material.node_tree.nodes
    bsdf = nodes["Principled BSDF"]
    hair = nodes.new("ShaderNodeBsdfHairPrincipled")
    hair.parametrization = "MELANIN"
    hair.inputs["Melanin"].default_value = 0.55
    hair.inputs["Roughness"].default_value = 0.35
    material.node_tree.links.new(hair.outputs[0], nodes["Material Output"].inputs["Surface"])
    nodes.remove(bsdf)
    obj.data.materials.append(material)
    modifier = obj.modifiers.new("Hair", "PARTICLE_SYSTEM")
    system = modifier.particle_system
    system.vertex_group_density = group
    settings = system.settings
    settings.type = "HAIR"
    settings.count = HAIR_STRANDS
    settings.material = len(obj.material_slots)
    settings.child_type = "NONE"
    settings.normal_factor, settings.factor_random = 0.02, 0.0  # grown straight out, then combed (comb_hair)
    settings.hair_step = 8
    settings.root_radius, settings.tip_radius, settings.radius_scale = 1.0, 0.4, HAIR_RADIUS
    settings.display_step = settings.render_step = 3
    scene.cycles_curves.shape = "THICK"
    comb_hair(obj, modifier, found.view)
    return material


def hair_frame(points: np.ndarray, polygon: list[int], local: np.ndarray, grown: np.ndarray) -> tuple[float, object]:
    """(error, rotation (3, 3) or None) from a strand's hair space to its object's: Blender's (particle.cc,
    triatomat) of the face its root is on, y along its first edge, z its normal, x = y cross z, for the corner the
    tessellated face starts at (any of the polygon's): the one that takes the grown strand's tip `local` (hair space)
    nearest to `grown` (object space, from the root). The error: how far, over the strand's length."""
    best = (np.inf, None)
    for start in range(len(polygon)):
        v1, v2, v3 = (points[polygon[(start + k) % len(polygon)]] for k in range(3))
        y = (v2 - v1) / np.linalg.norm(v2 - v1)
        z = np.cross(v2 - v1, v3 - v1)
        z /= np.linalg.norm(z)
        rotation = np.column_stack([np.cross(y, z), y, z])
        best = min(best, (float(np.linalg.norm(rotation @ local - grown) / np.linalg.norm(grown)), rotation),
                   key=lambda candidate: candidate[0])
    return best


def comb_hair(obj, modifier, view) -> None:
    """Comb the straight strands as grown: each leaves the scalp along its normal and falls back and down the head
    (a parabola, HAIR_LENGTH long give or take a fifth), kept HAIR_LIFT off the skin. The keys are written in
    each strand's hair space (hair_frame); particle edit mode, entered and left once, makes them editable."""
    import bpy
    from mathutils import Vector
    from mathutils.bvhtree import BVHTree

    with bpy.context.temp_override(object=obj, active_object=obj):
        bpy.context.view_layer.objects.active = obj
        bpy.ops.particle.particle_edit_toggle()
        bpy.ops.particle.particle_edit_toggle()
    depsgraph = bpy.context.evaluated_depsgraph_get()
    depsgraph.update()
    grown = obj.evaluated_get(depsgraph).particle_systems[modifier.particle_system.name].particles
    skin = BVHTree.FromObject(obj, depsgraph)
    points = np.array([v.co for v in obj.data.vertices])
    polygons = [list(p.vertices) for p in obj.data.polygons]
    faces = BVHTree.FromPolygons(points.tolist(), polygons)
    to_object = np.linalg.inv(np.array(obj.matrix_world)[:3, :3])
    fall = to_object @ (HAIR_COMB[0] * -view.back + HAIR_COMB[1] * -view.up)  # back and down the head
    rng = np.random.default_rng(0)
    missed = 0
    for particle, straight in zip(modifier.particle_system.particles, grown):
        keys = particle.hair_keys
        root = np.array(straight.hair_keys[0].co)
        tip, grown_tip = np.array(keys[-1].co_local), np.array(straight.hair_keys[-1].co) - root
        on = [faces.find_nearest(Vector(root))[2]]  # a quad's root lies on its bilinear patch, not on a triangle
        on += [hit[2] for hit in sorted(faces.find_nearest_range(Vector(root), 1e-3), key=lambda hit: hit[3])]
        error, rotation = min((hair_frame(points, polygons[f], tip, grown_tip) for f in on),
                              key=lambda candidate: candidate[0])  # the root's face, or, on an edge, its neighbour's
        if error > FRAME_TOLERANCE:  # a non-planar quad's frame is a little off its first triangle's
            missed += 1
            continue
        normal, length = rotation[:, 2], HAIR_LENGTH * rng.uniform(0.8, 1.2)
        for j, key in enumerate(keys):
            t = j / (len(keys) - 1)
            at = root + length * (HAIR_RISE * t * normal + t * t * fall)
            if j:
                near, out, _, _ = skin.find_nearest(Vector(at))
                lift = HAIR_LIFT * (1 + 2 * t)
                if near is not None and (Vector(at) - near).dot(out) < lift:
                    at = np.array(near + out * lift)
            key.co_object_set(obj, modifier, particle, Vector(rotation.T @ (at - root)))  # hair space, see above
    if missed:
        print(f"hair: {missed} strands left straight (no face frame found)")


def hair_pixels(scene, material) -> np.ndarray:
    """(HAIR_RES, HAIR_RES) bool: where the hair material shows (its pass index in the material-index pass, 1 spp)."""
    from blender_addon.renderers.cycles import configure_cycles, render_passes

    scene.view_layers[0].use_pass_material_index = True
    configure_cycles(scene, HAIR_RES, 1, 0)
    scene.cycles.use_denoising = False
    return np.abs(render_passes(scene)["IndexMA"][..., 0] - material.pass_index) < 0.5


def hair_camera(scene, camera, view):
    """A camera on the framing camera's axis, HAIR_PULL_BACK times as far: it sees the whole head."""
    import bpy

    shot = bpy.data.objects.new("Character Hair Camera", camera.data.copy())
    scene.collection.objects.link(shot)
    shot.matrix_world = camera.matrix_world.copy()
    shot.location = shot.location + shot.matrix_world.col[2].xyz * (HAIR_PULL_BACK - 1) * view.distance
    shot.data.clip_end = view.distance * 100
    return shot


def match_layers(material, layers, settings: dict) -> dict[str, dict[str, float]]:
    """Add Makeup Layer of each face layer into the skin `material`, then Match (Fast) each from the portrait of
    `settings`: product name -> the values written."""
    from blender_addon.matching import apply
    from blender_addon.renderers.makeup_layer import add_layer

    for product in layers:
        add_layer(material, product)
    written = {}
    for product in layers:
        result = apply.match_into_material(material.name, settings, product=product)
        written[product.name] = result["values"]
        print(f"match {product.name}: " + ", ".join(f"{k} {v:.3f}" for k, v in result["values"].items()))
        for note in result["notes"] + result["warnings"]:
            print(f"match {product.name}: {note}")
    return written


def main() -> None:
    import bpy
    from scipy import ndimage

    from benchmarks.heads import open_head
    from blender_addon.matching import apply
    from blender_addon.matching.face_on_mesh import (REGION_COLOURS, drawn_landmarks, find_face,
                                                     place_camera, scene_attributes)
    from blender_addon.renderers.cycles import configure_cycles, render_user_scene
    from blender_addon.renderers.makeup_layer import layer_products
    from blender_addon.renderers.products import blender_side
    from vto_core.products import HAIR

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--head", default="makehuman", help="a head of data/heads (heads.json)")
    parser.add_argument("--out", default="docs/", help="the folder the PNGs go in")
    args = parser.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    started = time.perf_counter()

    def done(name: str, image: np.ndarray) -> None:
        """Write the sheet as an 8-bit PNG, compressed hard (Pillow's optimize): the sheets stay small."""
        from PIL import Image

        path = out / name
        Image.fromarray(np.round(np.clip(image, 0, 1) * 255).astype(np.uint8)).save(path, optimize=True)
        print(f"{path}  ({path.stat().st_size // 1024} KB, {time.perf_counter() - started:.0f} s)")

    # 1. The head as given, from the framing camera Find Face places.
    scene = bpy.data.scenes.new(f"Character {args.head}")
    bpy.context.window.scene = scene  # the context's: particle edit mode (comb_hair) works on its view layer
    obj = open_head(args.head, scene)
    found = find_face(obj)
    for note in found.notes:
        print(f"find face: {note}")
    print("find face: vertices weighing above 0.5:", found.counts)
    camera = place_camera(scene, obj, found.view)
    scene.camera = camera
    light(scene, camera)
    head = render(scene)
    done("character_head.png", head)

    # 2. What Find Face found: the landmarks on its front render, the regions tinted on the head.
    layers = layer_products()
    names = tuple(product.face_region.attribute for product in layers)
    weights = scene_attributes(scene, names, RES)
    tinted = head.copy()
    for k, tint in enumerate(REGION_COLOURS[:len(names)]):
        w = TINT * np.clip(weights[..., k:k + 1], 0, 1)
        tinted = tinted * (1 - w) + np.array(tint, np.float32) * w
    legend = ", ".join(f"{['red', 'blue', 'green', 'yellow'][k]}: {name}" for k, name in enumerate(names))
    done("character_found.png", sheet([
        (drawn_landmarks(found), ["Find Face on Mesh: the front render,", "the face's landmarks found"]),
        (tinted, ["the regions written on the mesh", legend])]))

    # 3. The look of a real portrait, matched into the head's own skin material.
    with tempfile.TemporaryDirectory(prefix="character-sheet-") as work:
        portrait, worn = tried_on_portrait(Path(work))
        photo = np.concatenate([face_crop(portrait, RES)] + [photo_crop(portrait, part) for part in (EYES, LIPS)])
        settings = {"image_path": str(portrait.resolve()), "model_path": "", "crop": None, "mask_path": "",
                    "quality": "FAST", "find_region": True, "neutral_light": True}  # as match_material_cli's
        written = match_layers(obj.active_material, layers, settings)
    photo = np.round(photo * PHOTO_LEVELS) / PHOTO_LEVELS  # its JPEG noise would take most of the PNG's bytes
    matched = np.concatenate([render(scene)] + [close_up(scene, camera, found, part) for part in (EYES, LIPS)])
    labels = {p.name: p.label for p in layers}
    done("character_matched.png", sheet([
        (photo, ["the portrait: Linda Godwin (NASA), tried on:"]
         + [f"{labels[name]} {preset}: {rgb(values)}" for name, preset, values in worn]),
        (matched, ["matched (Fast) into the skin material:"]
         + [f"{labels[name]}: {rgb(values)}, opacity {values['opacity']:.2f}" for name, values in written.items()])]))

    # 4. Hair recoloured in the character's own render.
    hair_material = add_hair(scene, obj, found)
    scene.camera = hair_camera(scene, camera, found.view)
    blender_side(HAIR).add_group(scene, [obj])  # masks the stage by the hair material's pass index
    hair = hair_pixels(scene, hair_material)
    configure_cycles(scene, HAIR_RES, SAMPLES, 0)  # use_compositing off: the render as it was
    plain = render_user_scene(scene)
    hair_settings = dict(settings, image_path=str((PHOTOS / HAIR_PHOTO).resolve()))  # a file of the repository
    result = apply.match_into_stage(scene, hair_settings, HAIR)
    print("match hair: " + ", ".join(f"{k} {v:.3f}" for k, v in result["values"].items()))
    for note in result["notes"] + result["warnings"]:
        print(f"match hair: {note}")
    scene.render.use_compositing = True
    recoloured = render_user_scene(scene)
    changed = np.abs(recoloured - plain).max(axis=-1)
    near = ndimage.binary_dilation(hair)  # the mask is anti-aliased: a pixel beside a strand's may change
    print(f"hair: {int(hair.sum())} px of hair, mean change there {changed[hair].mean() * 255:.1f}/255; "
          f"largest change off it (1 px around it left out) {changed[~near].max() * 255:.1f}/255")
    print("hair mean colour (display 0-255): plain", np.round(plain[hair].mean(axis=0) * 255).tolist(),
          "recoloured", np.round(recoloured[hair].mean(axis=0) * 255).tolist())
    values = ", ".join(f"{name} {result['values'][name]:.2f}" for name in ("hue", "saturation", "gamma", "exposure"))
    done("character_hair.png", sheet([
        (plain, ["particle hair, its own material"]),
        (recoloured, ["VTO Hair Compositor, matched (Fast):", values]),
        (face_crop(PHOTOS / HAIR_PHOTO, HAIR_RES, margin=2.2, up=0.12), ["the portrait: Lisa Nowak (NASA)"])]))
    print(f"{time.perf_counter() - started:.0f} s")


if __name__ == "__main__":
    main()
