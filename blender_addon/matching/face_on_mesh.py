"""Find Face on Mesh: a character's face regions found on its own head mesh. A camera is framed on the mesh's face, the
mesh rendered there in Cycles with its own materials, the render read with the shipped face models as a photo is, and
every face region a declared product names is written on the mesh as the point attributes its makeup layer reads:
FaceRegion.attribute (0 to 1) and the layer's own coordinates (the eyelids' vto_lid, vto_lid_u)."""

from __future__ import annotations

import contextlib
import math
from dataclasses import dataclass, field

import bpy
import numpy as np

from vto_core.errors import VtoError
from vto_core.photo.face_regions import region_width
from vto_core.photo.surface_regions import edge_width, region_on_surface
from vto_core.products import either

from ..compat import enable_nodes
from ..renderers.cycles import configure_cycles, render_passes, to_display
from ..renderers.makeup_layer import layer_products
from ..renderers.products import blender_side
from ..shipped import photo_reader

SEARCH_RES, FRONT_RES = 192, 320  # px: the render that finds the face, and the one framed on it that reads it
SAMPLES = 4  # undenoised: the face models read a face through this much noise (16 samples, 512 px or another light
# move the regions no closer to hand outlines: docs/experiments/character.md)
LENS, SENSOR = 85.0, 36.0  # mm: a portrait lens, as the photos are taken
FACE_MARGIN = 1.8  # the framed square spans this many times the face's landmarks
HEAD_SHARE = 0.28  # a tall mesh's top share where its head is, framed when the whole mesh shows no face
FRONTAL = (0.3, 0.7)  # the nose tip's place between the eyes' outer corners on a face seen from its front
SEEN_TOLERANCE = 0.01  # of the frame's side: a vertex this far behind the surface a ray meets first is still seen
SKIN = (0.6, 0.45, 0.38, 1.0)  # the neutral skin of a mesh without materials (linear)
FACE_CAMERA = "VTO Face Camera"
REGION_COLOURS = ((0.9, 0.15, 0.2), (0.15, 0.35, 0.95), (0.2, 0.8, 0.3), (0.9, 0.7, 0.1))  # per product, in order
FAR_UV = (0.5, 1.0)  # region coordinates of the vertices far from every region: its far edge's middle (a lid's brow)
REGIONS_SHOWN = "vto_regions"  # the colour attribute that shows the regions found in the viewport
# Modifiers that move vertices without changing the mesh's topology: evaluated, the mesh keeps its vertex order.
DEFORMING = {"ARMATURE", "CAST", "CURVE", "DISPLACE", "HOOK", "LAPLACIANDEFORM", "LATTICE", "MESH_DEFORM",
             "SHRINKWRAP", "SIMPLE_DEFORM", "SMOOTH", "CORRECTIVE_SMOOTH", "LAPLACIANSMOOTH", "SURFACE_DEFORM",
             "WARP", "WAVE", "MESH_CACHE", "MESH_SEQUENCE_CACHE"}
# Fronts tried (the direction the face looks, up), Blender's front view first: in the object's own axes, then in the
# world's (an imported file's object may carry its axis conversion: its own axes are then not the head's).
FRONTS = (((0, -1, 0), (0, 0, 1)), ((0, 1, 0), (0, 0, 1)), ((-1, 0, 0), (0, 0, 1)), ((1, 0, 0), (0, 0, 1)))


@dataclass
class View:
    """A camera for the search: at `origin`, with its right, up and back (towards the viewer) axes, world space; the
    frame spans `side` world units at `distance`."""

    origin: np.ndarray  # (3,)
    right: np.ndarray
    up: np.ndarray
    back: np.ndarray
    side: float
    res: int
    focal: float = LENS / SENSOR  # the lens over the sensor's width

    @property
    def distance(self) -> float:
        return self.side * self.focal

    def project(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """World points (N, 3) -> (pixels (N, 2) x right, y down, pixel i's centre at i + 0.5; depth (N,) in front)."""
        offset = np.asarray(points, np.float64) - self.origin
        depth = -(offset @ self.back)
        scale = self.focal * self.res / np.maximum(depth, 1e-9)
        return np.column_stack([self.res / 2 + (offset @ self.right) * scale,
                                self.res / 2 - (offset @ self.up) * scale]), depth

    def ray(self, pixel: np.ndarray) -> np.ndarray:
        """The world direction (3,) through a pixel (2,), unit length."""
        x, y = (np.asarray(pixel, np.float64) - self.res / 2) / (self.focal * self.res)
        direction = x * self.right - y * self.up - self.back
        return direction / np.linalg.norm(direction)

    def matrix(self):
        """The camera object's world matrix."""
        from mathutils import Matrix

        rotation = np.column_stack([self.right, self.up, self.back])
        return Matrix([list(rotation[0]) + [self.origin[0]], list(rotation[1]) + [self.origin[1]],
                       list(rotation[2]) + [self.origin[2]], [0.0, 0.0, 0.0, 1.0]])


def view_at(centre: np.ndarray, front: np.ndarray, up: np.ndarray, side: float, res: int) -> View:
    """A camera looking at `centre` (3,) from its `front` (3,), with `up` (3,), framing `side` world units there."""
    back = front / np.linalg.norm(front)
    right = np.cross(up, back)
    right /= np.linalg.norm(right)
    true_up = np.cross(back, right)
    distance = side * LENS / SENSOR
    return View(np.asarray(centre, np.float64) + back * distance, right, true_up, back, side, res)


def camera_view(camera: bpy.types.Object, res: int) -> View:
    """The scene camera as a View (its own lens; a perspective camera only)."""
    if camera.type != "CAMERA" or camera.data.type != "PERSP":
        raise VtoError(f"camera '{camera.name}' is not a perspective camera")
    matrix = np.array(camera.matrix_world)
    rotation = matrix[:3, :3] / np.linalg.norm(matrix[:3, :3], axis=0)
    focal = camera.data.lens / camera.data.sensor_width
    return View(matrix[:3, 3], rotation[:, 0], rotation[:, 1], rotation[:, 2], 1.0 / focal, res, focal)


@dataclass
class Surface:
    """A mesh object's vertices as its modifiers deform them (world space), and its triangles."""

    points: np.ndarray  # (N, 3) the original mesh's vertices, in its order
    triangles: np.ndarray  # (T, 3)
    rotation: np.ndarray  # (3, 3) the object's own axes in the world (columns)
    note: str = ""

    def bvh(self):
        from mathutils.bvhtree import BVHTree

        return BVHTree.FromPolygons(self.points.tolist(), self.triangles.tolist(), all_triangles=True)


@contextlib.contextmanager
def deforming_only(obj: bpy.types.Object):
    """Modifiers that change the topology (subdivision, mirror, ...) off for the block, then back as they were."""
    off = [m for m in obj.modifiers if m.show_viewport and m.type not in DEFORMING]
    for modifier in off:
        modifier.show_viewport = False
    try:
        yield
    finally:
        for modifier in off:
            modifier.show_viewport = True


def surface_of(obj: bpy.types.Object) -> Surface:
    """`obj`'s vertices posed by its deforming modifiers (an armature, shape keys), in its own vertex order."""
    with deforming_only(obj):
        depsgraph = bpy.context.evaluated_depsgraph_get()
        depsgraph.update()  # the object's matrix_world too, after a move not yet evaluated
        evaluated = obj.evaluated_get(depsgraph)
        mesh = evaluated.to_mesh()
        try:
            note = ""
            if len(mesh.vertices) != len(obj.data.vertices):  # a geometry-nodes modifier made new vertices
                mesh, note = obj.data, f"'{obj.name}' is read without its modifiers (they change its vertices)"
            points = np.empty(len(mesh.vertices) * 3)
            mesh.vertices.foreach_get("co", points)
            mesh.calc_loop_triangles()
            triangles = np.empty(len(mesh.loop_triangles) * 3, np.int64)
            mesh.loop_triangles.foreach_get("vertices", triangles)
        finally:
            evaluated.to_mesh_clear()
    matrix = np.array(evaluated.matrix_world)
    world = points.reshape(-1, 3) @ matrix[:3, :3].T + matrix[:3, 3]
    return Surface(world, triangles.reshape(-1, 3), matrix[:3, :3] / np.linalg.norm(matrix[:3, :3], axis=0), note)


@contextlib.contextmanager
def front_scene(obj: bpy.types.Object):
    """A scene of its own that shows `obj` (its own materials; a neutral skin where it has none) under a white world
    and a key from above the camera; removed, with all it made, on leaving. Yields (scene, camera object)."""
    made = []
    scene = bpy.data.scenes.new("VTO Find Face")
    try:
        scene.collection.objects.link(obj)
        for other in {m.object for m in obj.modifiers if getattr(m, "object", None)} | {obj.parent} - {None}:
            scene.collection.objects.link(other)  # an armature's pose reaches the mesh only from inside the scene
        camera = bpy.data.objects.new(FACE_CAMERA, bpy.data.cameras.new(FACE_CAMERA))
        made += [camera.data, camera]
        camera.data.lens, camera.data.sensor_width, camera.data.sensor_fit = LENS, SENSOR, "HORIZONTAL"
        scene.collection.objects.link(camera)
        scene.camera = camera
        world = bpy.data.worlds.new("VTO Find Face")
        made.append(world)
        enable_nodes(world)
        world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.6
        scene.world = world
        key = bpy.data.objects.new("VTO Find Face Key", bpy.data.lights.new("VTO Find Face Key", "SUN"))
        made += [key.data, key]
        key.data.energy = 2.0
        scene.collection.objects.link(key)
        scene.render.use_persistent_data = True  # the second render reuses the first's scene
        if not any(slot.material for slot in obj.material_slots):
            skin = bpy.data.materials.new("VTO Find Face Skin")
            made.append(skin)
            enable_nodes(skin)
            skin.node_tree.nodes["Principled BSDF"].inputs["Base Color"].default_value = SKIN
            scene.view_layers[0].material_override = skin
        yield scene, camera, key
    finally:
        bpy.data.scenes.remove(scene)
        bpy.data.batch_remove(made)


def aim(camera: bpy.types.Object, view: View, near: float, far: float) -> None:
    """Put camera object `camera` on `view`, its lens and clipping (`near`, `far`) with it."""
    camera.matrix_world = view.matrix()
    camera.data.lens = view.focal * camera.data.sensor_width
    camera.data.clip_start, camera.data.clip_end = max(near, 1e-4), far


def render_view(scene, camera, key, view: View, near: float, far: float) -> np.ndarray:
    """The scene through `view`: (res, res, 3) display sRGB."""
    aim(camera, view, near, far)
    key.matrix_world = view.matrix()
    key.rotation_euler.rotate_axis("X", -math.radians(35))  # from above the camera, as a portrait's key
    configure_cycles(scene, view.res, SAMPLES)
    scene.cycles.use_denoising = False
    return to_display(render_passes(scene)["Combined"][..., :3])


def frontal(landmarks: np.ndarray) -> float:
    """The nose tip's place between the eyes' outer corners, along them: 0.5 on a face seen from its front."""
    right_eye, left_eye, nose = landmarks[33], landmarks[263], landmarks[1]
    across = left_eye - right_eye
    return float((nose - right_eye) @ across / max(across @ across, 1e-9))


def fronts(rotation: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
    """(front, up) unit vectors (3,) of FRONTS in the object's axes (`rotation` (3, 3)), then those in the world's
    that differ from them."""
    tried = []
    for axes in (rotation, np.eye(3)):
        for front, up in FRONTS:
            front, up = (axes @ np.array(v, float) for v in (front, up))
            front, up = front / np.linalg.norm(front), up / np.linalg.norm(up)
            if not any(front @ f > 0.99 and up @ u > 0.99 for f, u in tried):
                tried.append((front, up))
    return tried


def search_views(surface: Surface, camera: bpy.types.Object | None):
    """The views that may show the face: the scene camera's alone when given; else, for each front of FRONTS (in
    the object's axes, then in the world's), the whole mesh framed, then a tall mesh's head."""
    if camera is not None:
        yield camera_view(camera, SEARCH_RES)
        return
    for front, up in fronts(surface.rotation):
        right = np.cross(up, front)
        across, high, deep = surface.points @ right, surface.points @ up, surface.points @ front
        width, height = np.ptp(across), np.ptp(high)
        centre = right * (across.min() + width / 2) + up * (high.min() + height / 2) + front * deep.max()
        yield view_at(centre, front, up, 1.1 * max(width, height), SEARCH_RES)
        side = HEAD_SHARE * height  # a whole body: its head
        top = high > high.max() - side
        centre = (right * (across[top].min() + np.ptp(across[top]) / 2) + up * (high.max() - side / 2)
                  + front * deep[top].max())
        yield view_at(centre, front, up, side, SEARCH_RES)


@dataclass
class FaceOnMesh:
    """What Find Face on Mesh found and wrote on a mesh."""

    landmarks: np.ndarray  # (468, 2) px in the front render
    front: np.ndarray  # (FRONT_RES, FRONT_RES, 3) display sRGB: the front render
    view: View
    counts: dict[str, int]  # each region attribute -> vertices it weighs above 0.5
    points: np.ndarray  # (468, 3) the landmarks cast onto the surface (world; NaN where a ray missed)
    notes: list[str] = field(default_factory=list)


def read_face(image: np.ndarray):
    """The face of a render (FaceRead), or None, through the photo reader (as photos are read)."""
    return photo_reader().face_of(np.ascontiguousarray(image, np.float32))


def find_front(obj, surface: Surface, bvh, camera=None) -> tuple[View, object, np.ndarray]:
    """The front view framed on `obj`'s face and its face read there: (view, FaceRead, render); VtoError (one line)
    where no view shows a face from its front. `bvh`: the surface's."""
    points = surface.points
    reach = float(np.linalg.norm(np.ptp(points, axis=0))) or 1.0
    with front_scene(obj) as (scene, camera_object, key):
        for view in search_views(surface, camera):
            far = view.distance + 2 * reach + float(np.linalg.norm(view.origin - points.mean(axis=0)))
            face = read_face(render_view(scene, camera_object, key, view, view.distance * 0.01, far))
            if face is None or not FRONTAL[0] <= frontal(face.landmarks) <= FRONTAL[1]:
                continue
            centre_pixel = face.landmarks.mean(axis=0)
            hit = bvh.ray_cast(view.origin.tolist(), view.ray(centre_pixel).tolist())[0]
            if hit is None:
                continue
            hit = np.array(hit)
            depth = float(view.project(hit[None])[1][0])
            extent = float(np.ptp(face.landmarks, axis=0).max()) / view.res * depth * SENSOR / LENS
            framed = view_at(hit, view.back, view.up, FACE_MARGIN * extent, FRONT_RES)
            image = render_view(scene, camera_object, key, framed, framed.distance * 0.01, far + framed.distance)
            face = read_face(image)
            if face is not None:
                return framed, face, image
    where = f"camera '{camera.name}' (the face turned away, or out of its frame)" if camera is not None else \
        "its front, back or sides"
    raise VtoError(f"found no face on '{obj.name}' from {where}")


def seen(view: View, points: np.ndarray, bvh) -> np.ndarray:
    """Which points (N, 3) the view sees: the first surface a ray to each meets is the point's own (N,) bool."""
    tolerance = SEEN_TOLERANCE * view.side
    shown = np.zeros(len(points), bool)
    for i, point in enumerate(points):
        offset = point - view.origin
        distance = float(np.linalg.norm(offset))
        hit = bvh.ray_cast(view.origin.tolist(), (offset / distance).tolist(), distance + tolerance)
        shown[i] = hit[0] is None or hit[3] >= distance - tolerance
    return shown


def region_values(landmarks: np.ndarray, pixels: np.ndarray, shown: np.ndarray, product) -> dict[str, np.ndarray]:
    """A product's attributes at points (N, 2) px of the front render (those `shown` (N,) seen): its region weight
    (the largest of its regions') and its layer's own coordinates, from the region each point is most in."""
    layer = blender_side(product).photo_layer
    weights, uvs, ranks = [], [], []
    for region in product.face_regions:
        vertices, quads, mesh_uvs = layer.mesh(landmarks, None, region)
        w, uv, distance = region_on_surface(pixels, shown, vertices[:, :2], quads, mesh_uvs,
                                            edge_width(region_width(landmarks, region)))
        weights.append(w)
        uvs.append(uv)
        ranks.append(np.where(w > 0, 1.0 + w, -distance / (1.0 + distance)))  # inside first; outside, the nearer
    take = np.argmax(ranks, axis=0)[None, :, None]
    values = {product.face_region.attribute: np.max(weights, axis=0)}
    if layer.attributes is not None:
        values.update(layer.attributes(np.take_along_axis(np.stack(uvs), take, axis=0)[0]))
    return values


def candidates(landmarks: np.ndarray, pixels: np.ndarray, depth: np.ndarray, products) -> np.ndarray:
    """The points (N,) bool in front of the camera and within the box of a product's region (and its soft edge):
    the only ones a region can weigh."""
    near = np.zeros(len(pixels), bool)
    for region in (region for product in products for region in product.face_regions):
        box = landmarks[list(region.loops[0])]
        margin = 2 * edge_width(region_width(landmarks, region))
        near |= np.all((pixels >= box.min(axis=0) - margin) & (pixels <= box.max(axis=0) + margin), axis=1)
    return near & (depth > 0)


def group_weights(obj: bpy.types.Object, name: str) -> np.ndarray:
    """A vertex group's weights (N,) (0 where a vertex is not in it); VtoError where `obj` has no such group."""
    group = obj.vertex_groups.get(name)
    if group is None:
        raise VtoError(f"'{obj.name}' has no vertex group '{name}'")
    weights = np.zeros(len(obj.data.vertices))
    for vertex in obj.data.vertices:
        for element in vertex.groups:
            if element.group == group.index:
                weights[vertex.index] = element.weight
    return weights


def checked_mesh(obj) -> None:
    """VtoError (one line) unless `obj` is a mesh object with faces."""
    if obj is None:
        raise VtoError("select a mesh: Find Face on Mesh reads the active object's face")
    if obj.type != "MESH":
        raise VtoError(f"'{obj.name}' is a {obj.type.lower()}, not a mesh")
    if len(obj.data.polygons) == 0:
        raise VtoError(f"'{obj.name}' has no faces")


def find_face(obj: bpy.types.Object, camera: bpy.types.Object | None = None,
              groups: dict[str, str] | None = None) -> FaceOnMesh:
    """Find the face on mesh `obj` and write its regions' attributes (with `camera`: seen from it; `groups`: region
    name -> a vertex group that says where that region is, used for its weight; None: the groups named as a region,
    any case, such as "Lips"). Nothing is changed on a VtoError."""
    checked_mesh(obj)
    products = layer_products()
    names = {region.name for product in products for region in product.face_regions}
    if groups is None:
        groups = {group.name.lower(): group.name for group in obj.vertex_groups if group.name.lower() in names}
    for name in groups:
        if name not in names:
            raise VtoError(f"no face region '{name}'; choose from {either(sorted(names))}")
    given = {name: group_weights(obj, group) for name, group in groups.items()}
    surface = surface_of(obj)
    bvh = surface.bvh()
    view, face, image = find_front(obj, surface, bvh, camera)
    landmarks = np.asarray(face.landmarks, np.float64)
    pixels, depth = view.project(surface.points)
    near = candidates(landmarks, pixels, depth, products)
    shown = np.zeros(len(pixels), bool)
    shown[near] = seen(view, surface.points[near], bvh)
    values: dict[str, np.ndarray] = {}
    for product in products:
        layer = blender_side(product).photo_layer
        far = layer.attributes(np.array([FAR_UV])) if layer.attributes is not None else {}
        for name, inside in region_values(landmarks, pixels[near], shown[near], product).items():
            column = np.full(len(pixels), far[name][0] if name in far else 0.0, np.float32)
            column[near] = inside
            values[name] = column
        if product.face_region.name in given:
            values[product.face_region.attribute] = given[product.face_region.name].astype(np.float32)
    cast = np.full((len(landmarks), 3), np.nan)
    for i, pixel in enumerate(landmarks):
        hit = bvh.ray_cast(view.origin.tolist(), view.ray(pixel).tolist())[0]
        if hit is not None:
            cast[i] = hit
    write_attributes(obj, values, products)
    counts = {product.face_region.attribute: int((values[product.face_region.attribute] > 0.5).sum())
              for product in products}
    notes = [surface.note] if surface.note else []
    notes += [f"the {name} weigh as vertex group '{group}' says" for name, group in groups.items()]
    notes += [f"only {count} vertices weigh the {product.face_region.name} on '{obj.name}': too few for a clean edge "
              "(subdivide the mesh there)" for product in products
              if 0 < (count := counts[product.face_region.attribute]) < 12]
    return FaceOnMesh(landmarks, image, view, counts, cast, notes)


def write_attributes(obj: bpy.types.Object, values: dict[str, np.ndarray], products) -> None:
    """Each (N,) array as a float point attribute of `obj`'s mesh (replacing one of that name), and the regions in
    the viewport: a colour attribute of the products' colours by weight, made the active colour."""
    mesh = obj.data
    for name, column in values.items():
        old = mesh.attributes.get(name)
        if old is not None:
            mesh.attributes.remove(old)
        mesh.attributes.new(name, "FLOAT", "POINT").data.foreach_set("value", np.asarray(column, np.float32))
    colour = np.ones((len(mesh.vertices), 4), np.float32)
    for product, tint in zip(products, REGION_COLOURS * 4):
        weight = values[product.face_region.attribute][:, None]
        colour[:, :3] = colour[:, :3] * (1 - weight) + np.array(tint) * weight
    old = mesh.color_attributes.get(REGIONS_SHOWN)
    if old is not None:
        mesh.color_attributes.remove(old)
    shown = mesh.color_attributes.new(REGIONS_SHOWN, "FLOAT_COLOR", "POINT")
    shown.data.foreach_set("color", colour.ravel())
    mesh.color_attributes.active_color = shown
    mesh.update()


def place_camera(scene: bpy.types.Scene, obj: bpy.types.Object, view: View) -> bpy.types.Object:
    """The framing camera of `obj`'s face in `scene` (got or made: "VTO Face Camera <object>"), placed on `view`: the
    artist can look through it, and it renders the character's face."""
    name = f"{FACE_CAMERA} {obj.name}"
    camera = bpy.data.objects.get(name)
    if camera is None or camera.type != "CAMERA":
        camera = bpy.data.objects.new(name, bpy.data.cameras.new(name))
    if camera.name not in scene.collection.objects and scene not in camera.users_scene:
        scene.collection.objects.link(camera)
    wide = scene.render.resolution_x >= scene.render.resolution_y  # the square framed fits the frame's short side
    camera.data.lens, camera.data.sensor_fit = LENS, "VERTICAL" if wide else "HORIZONTAL"
    camera.data.sensor_width = camera.data.sensor_height = SENSOR
    camera.data.clip_start, camera.data.clip_end = view.distance * 0.01, view.distance * 100
    camera.data.display_size = 0.2 * view.side  # drawn at the head's scale, not across it
    camera.matrix_world = view.matrix()
    return camera


def drawn_landmarks(found: FaceOnMesh) -> np.ndarray:
    """The front render with the landmarks drawn (each makeup layer's regions' in its viewport colour, the rest
    white): (H, W, 3) display sRGB."""
    image = found.front.copy()
    tints = {i: tint for product, tint in zip(layer_products(), REGION_COLOURS * 4)
             for region in product.face_regions for loop in region.loops for i in loop}
    height, width = image.shape[:2]
    for i, (x, y) in enumerate(np.round(found.landmarks - 0.5).astype(int)):
        image[max(y - 1, 0):min(y + 2, height), max(x - 1, 0):min(x + 2, width)] = tints.get(i, (1.0, 1.0, 1.0))
    return image


def attributes_seen(obj: bpy.types.Object, view: View, names: tuple[str, ...]) -> np.ndarray:
    """Up to three of `obj`'s float attributes as `view` sees them on its surface (scene_attributes):
    (res, res, len(names)) linear, 0 off the mesh. What the regions found look like from a camera."""
    with front_scene(obj) as (scene, camera, _):
        aim(camera, view, view.distance * 0.01, view.distance * 100)
        return scene_attributes(scene, names, view.res)


def scene_attributes(scene: bpy.types.Scene, names: tuple[str, ...], res: int) -> np.ndarray:
    """Up to three float attributes of `scene`'s meshes as its camera sees them (emitted, no light, each pixel its
    own point): (res, res, len(names)) linear, 0 where none is. A scene of its own renders them: `scene` stays."""
    material = bpy.data.materials.new("VTO Attributes Seen")
    seen_in = bpy.data.scenes.new("VTO Attributes Seen")
    try:
        enable_nodes(material)
        nodes, links = material.node_tree.nodes, material.node_tree.links
        nodes.clear()
        combine = nodes.new("ShaderNodeCombineXYZ")
        for i, name in enumerate(names[:3]):
            links.new(nodes.new("ShaderNodeAttribute").outputs["Fac"], combine.inputs[i])
            nodes[-1].attribute_name = name
        emission = nodes.new("ShaderNodeEmission")
        links.new(combine.outputs[0], emission.inputs["Color"])
        links.new(emission.outputs[0], nodes.new("ShaderNodeOutputMaterial").inputs["Surface"])
        for obj in scene.objects:
            seen_in.collection.objects.link(obj)
        seen_in.camera = scene.camera
        seen_in.view_layers[0].material_override = material
        configure_cycles(seen_in, res, 4)
        seen_in.cycles.use_denoising = False
        seen_in.cycles.filter_width = 0.01  # each pixel its own point: no blur across the edges measured
        return render_passes(seen_in)["Combined"][..., :len(names[:3])]
    finally:
        bpy.data.scenes.remove(seen_in)
        bpy.data.materials.remove(material)
