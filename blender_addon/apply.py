"""Match from photo, the logic under the panel, the operator and `vto match --material`: plain functions, no UI.

One call, `match_into_material` or `match_into_hair`, does everything in this order: resolve and load the model
(cached per file), check that it estimates this renderer's spec, read the reference (file or image datablock, with
an optional crop or mask), find the group nodes and refuse linked inputs, estimate (and refine where asked), and only
then write the group's inputs. Every failure before the writes is a VtoError with one line, so nothing has changed.

Settings are a plain dict (glTF-Blender-IO style), so the panel, the operator's own properties and the command line
all feed the same function:
    image_path | image_name     the reference: a file, or an image datablock already in the .blend
    crop                        (x, y, w, h) from the top-left: pixels, or fractions when all four are <= 1; or None
    mask_path                   an image whose > 0.5 region is the lips (the reference is cropped to it) or the
                                hair (the photo's hair for refinement: Better / Best)
    model_path                  the encoder; "" = the add-on preferences' path, else the shipped default
    quality                     FAST (encoder only), BETTER (render:25), BEST (render:100)
"""

from __future__ import annotations

import math
import os
import time
import warnings
from collections.abc import Callable
from pathlib import Path

import numpy as np

from vto_core.errors import VtoError
from vto_core.imageio import read_image, resize
from vto_core.inference import EncoderSession, cached_session
from vto_core.specs import RendererSpec, get_spec

from .match import load_reference

MODELS = Path(__file__).parent / "models"
QUALITY_BUDGET = {"FAST": 0, "BETTER": 25, "BEST": 100}  # renders of the render search (blender_addon.refine)
NO_LIPSTICK_SOURCE = ("Better and Best refine by rendering the reference's own source; a photo of a real face has "
                      "none, so only Fast (the encoder's estimate) applies to lipstick")
MIN_SIZE = 8


def default_model(renderer: str) -> Path:
    """The shipped encoder of `renderer`: blender_addon/models/<renderer>_encoder.onnx."""
    return MODELS / f"{renderer}_encoder.onnx"


def resolve_model(renderer: str, override: str = "", preference: str = "") -> Path:
    """The model to use: a per-material/per-call override, else the preferences' path, else the shipped one."""
    chosen = override or preference
    if chosen:
        return Path(_abspath(chosen))
    return default_model(renderer)


def _abspath(path: str) -> str:
    """A Blender-relative path ('//x') made absolute against the open .blend; others as they are."""
    if path.startswith("//"):
        import bpy

        return bpy.path.abspath(path)
    return os.path.expanduser(path)


def check_model(session: EncoderSession, renderer: str, path) -> RendererSpec:
    """The model's spec, refused with the reason when it is for another renderer or another version of the spec."""
    spec = session.spec
    if spec.renderer != renderer:
        raise VtoError(f"{Path(path).name} estimates {spec.renderer} parameters, not {renderer}: choose a "
                       f"{renderer} encoder")
    current = get_spec(renderer).by_name
    for param in spec.modelled_params:
        known = current.get(param.name)
        if known is None:
            raise VtoError(f"{Path(path).name} estimates '{param.name}', which this add-on's {renderer} group has "
                           "no input for: the model was made for another spec")
        if (known.low, known.high, known.wraps, known.scale, known.unit_high) != (
                param.low, param.high, param.wraps, param.scale, param.unit_high):
            raise VtoError(f"{Path(path).name} was made for another {renderer} spec: its '{param.name}' spans "
                           f"[{param.low:g}, {param.high:g}], the add-on's [{known.low:g}, {known.high:g}]")
    return spec


def load_model(renderer: str, model_path) -> tuple[EncoderSession, RendererSpec]:
    """The cached session of `model_path` and its (checked) spec."""
    session = cached_session(model_path)
    return session, check_model(session, renderer, model_path)


# --- the reference ------------------------------------------------------------------------------------------------

def datablock_pixels(image) -> np.ndarray:
    """A bpy image datablock as display values (H, W, 3), top row first.

    Read from its file when it has an unmodified one on disk (as a file reference would be); else from its pixels:
    byte images hold display values already, float images scene-linear ones (converted to sRGB).
    """
    path = _abspath(image.filepath_raw) if image.filepath_raw else ""
    if path and os.path.isfile(path) and image.packed_file is None and not image.is_dirty:
        return load_reference(path)
    width, height = image.size
    channels = image.channels
    if width * height == 0 or channels < 1:
        raise VtoError(f"image '{image.name}' has no pixels (is its file missing?)")
    flat = np.empty(width * height * channels, np.float32)
    image.pixels.foreach_get(flat)
    pixels = np.flipud(flat.reshape(height, width, channels))
    rgb = np.repeat(pixels[..., :1], 3, axis=2) if channels < 3 else pixels[..., :3]
    if image.is_float:
        from vto_core.colour import linear_to_srgb

        rgb = linear_to_srgb(np.clip(np.nan_to_num(rgb, nan=0.0), 0.0, None))
    return _checked(np.ascontiguousarray(rgb, dtype=np.float32), f"image '{image.name}'")


def _checked(image: np.ndarray, what: str) -> np.ndarray:
    if image.shape[0] < MIN_SIZE or image.shape[1] < MIN_SIZE:
        raise VtoError(f"{what}: image is {image.shape[1]}x{image.shape[0]}; at least {MIN_SIZE}x{MIN_SIZE} is needed")
    return np.clip(np.nan_to_num(image, nan=0.0, posinf=1.0, neginf=0.0), 0.0, 1.0)


def crop_box(crop, width: int, height: int) -> tuple[int, int, int, int]:
    """(x, y, w, h) from the top-left, in pixels or (all four <= 1) fractions -> pixel box inside the image."""
    values = [float(v) for v in crop]
    if len(values) != 4 or not all(math.isfinite(v) for v in values):
        raise VtoError(f"a crop is four finite numbers x, y, w, h, got {tuple(crop)}")
    if all(0.0 <= v <= 1.0 for v in values):
        values = [values[0] * width, values[1] * height, values[2] * width, values[3] * height]
    x, y, w, h = (int(round(v)) for v in values)
    if x < 0 or y < 0 or w < MIN_SIZE or h < MIN_SIZE or x + w > width or y + h > height:
        raise VtoError(f"crop x={x}, y={y}, w={w}, h={h} px does not fit the {width}x{height} image with at least "
                       f"{MIN_SIZE}x{MIN_SIZE} px inside it")
    return x, y, w, h


def read_mask(path: str, shape: tuple[int, int]) -> np.ndarray:
    """A mask image (its mean over channels > 0.5 is the region) as (H, W) float32 0/1, resized to `shape`."""
    path = _abspath(path)
    if not os.path.isfile(path):
        raise VtoError(f"no mask image at {path}")
    rgb, _ = read_image(path)
    mask = np.nan_to_num(rgb.mean(axis=-1), nan=0.0)
    if mask.shape != shape:
        mask = resize(mask, *shape)
    mask = (mask > 0.5).astype(np.float32)
    if not mask.any():
        raise VtoError(f"mask {path} is empty: no pixel above 0.5")
    return mask


def read_reference(settings: dict) -> tuple[np.ndarray, np.ndarray | None]:
    """The reference (H, W, 3) in [0, 1] after the crop, and its mask (H, W) or None; one-line errors."""
    if settings.get("image_path"):
        reference = load_reference(_abspath(settings["image_path"]))
    elif settings.get("image_name"):
        import bpy

        image = bpy.data.images.get(settings["image_name"])
        if image is None:
            raise VtoError(f"no image '{settings['image_name']}' in this .blend")
        reference = datablock_pixels(image)
    else:
        raise VtoError("no reference image: choose a file or an image of this .blend")
    mask = read_mask(settings["mask_path"], reference.shape[:2]) if settings.get("mask_path") else None
    crop = settings.get("crop")
    if crop is not None:
        x, y, w, h = crop_box(crop, reference.shape[1], reference.shape[0])
    elif mask is not None and settings.get("crop_to_mask", True):
        rows, cols = np.nonzero(mask)
        y, x = rows.min(), cols.min()
        h, w = max(rows.max() + 1 - y, MIN_SIZE), max(cols.max() + 1 - x, MIN_SIZE)
        y, x = min(y, reference.shape[0] - h), min(x, reference.shape[1] - w)
    else:
        return reference, mask
    reference = np.ascontiguousarray(reference[y:y + h, x:x + w])
    return reference, None if mask is None else np.ascontiguousarray(mask[y:y + h, x:x + w])


# --- the targets --------------------------------------------------------------------------------------------------

def lipstick_nodes(material) -> list:
    """The "VTO Lipstick" group nodes of `material` (none when it has no node tree)."""
    from .nodes_lipstick import GROUP_NAME

    if material is None or not material.use_nodes or material.node_tree is None:
        return []
    return [n for n in material.node_tree.nodes if n.bl_idname == "ShaderNodeGroup" and n.node_tree is not None
            and n.node_tree.name.startswith(GROUP_NAME)]


def hair_nodes(scene) -> list:
    """The "VTO Hair Swatch" / "VTO Hair Color" group nodes of `scene`'s compositor."""
    from .nodes_hair import COLOR_GROUP, SWATCH_GROUP

    tree = getattr(scene, "node_tree", None) if scene is not None else None
    if tree is None:
        return []
    return [n for n in tree.nodes if n.bl_idname == "CompositorNodeGroup" and n.node_tree is not None
            and n.node_tree.name.startswith((SWATCH_GROUP, COLOR_GROUP))]


def writable_sockets(nodes: list, spec: RendererSpec, where: str) -> list:
    """(socket, name) for each modelled parameter on each node having its input; linked inputs are an error."""
    targets = []
    for node in nodes:
        for param in spec.modelled_params:
            socket = node.inputs.get(param.socket)
            if socket is None:
                continue
            if socket.is_linked:
                raise VtoError(f"input '{socket.name}' of node '{node.name}' in {where} is driven by a link, so it "
                               f"cannot take the estimated {param.name}; unlink it, or use a model without "
                               f"{param.name}")
            targets.append((socket, param.name))
    missing = set(spec.modelled) - {name for _, name in targets}
    if missing:
        raise VtoError(f"{where}: no group input for {', '.join(sorted(missing))} (a group from another version?)")
    return targets


def current_values(nodes: list, spec: RendererSpec) -> dict[str, float]:
    """The first node's value of each modelled parameter it has (what a match would overwrite)."""
    values = {}
    for node in nodes:
        for param in spec.modelled_params:
            socket = node.inputs.get(param.socket)
            if socket is not None and param.name not in values:
                values[param.name] = float(socket.default_value)
    return values


# --- the estimate -------------------------------------------------------------------------------------------------

def estimate(session: EncoderSession, spec: RendererSpec, reference: np.ndarray) -> dict[str, float]:
    """The encoder's estimate of the modelled parameters (raw units)."""
    values = session.predict(reference)[0]
    return {name: float(values[name]) for name in spec.modelled}


def iter_refine_hair(spec: RendererSpec, reference: np.ndarray, mask: np.ndarray, start: dict[str, float],
                     budget: int, res: int, seed: int = 0):
    """Render search (CMA-ES through the hair stage) on the photo itself, its mask as the hair: `budget` renders.

    Intensity and blend are held at full effect while searching and keep the encoder's values (hair.OWN_SOURCE_HELD).

    A generator: yields the renders made so far, returns the refined modelled values.
    """
    from .hair import HairSource, own_source_held, run_hair_stage
    from .refine import iter_refine_by_render

    rgb = reference if reference.shape[:2] == (res, res) else resize(reference, res, res)
    small_mask = mask if mask.shape == (res, res) else (resize(mask, res, res) > 0.5).astype(np.float32)
    source = HairSource(np.clip(rgb, 0, 1).astype(np.float32), small_mask)
    wraps = np.array([p.wraps for p in spec.modelled_params])
    refined = yield from iter_refine_by_render(
        lambda unit: run_hair_stage(source, spec.values(spec.denormalise(unit))), source.rgb,
        spec.normalise(spec.vector(start)), budget, seed, wraps, held=own_source_held(spec, start))
    full = spec.values(spec.denormalise(refined.unit))
    return {name: float(full[name]) for name in spec.modelled}


def prepare(renderer: str, settings: dict) -> dict:
    """Everything up to the estimate, nothing written: {'session', 'spec', 'model', 'reference', 'mask', 'budget'}."""
    quality = settings.get("quality", "FAST")
    if quality not in QUALITY_BUDGET:
        raise VtoError(f"quality is FAST, BETTER or BEST, got '{quality}'")
    budget = QUALITY_BUDGET[quality]
    if budget and renderer == "lipstick":
        raise VtoError(NO_LIPSTICK_SOURCE)
    model = resolve_model(renderer, settings.get("model_path", ""), settings.get("preference_model", ""))
    session, spec = load_model(renderer, model)
    # A lipstick mask says where the lips are: the encoder sees that region. A hair mask is the hair of the whole
    # photo (the hair encoder sees whole portraits): it is refinement's source mask, not a crop.
    reference, mask = read_reference({"crop_to_mask": renderer == "lipstick", **settings})
    if budget and mask is None:
        raise VtoError(f"quality {quality.title()} refines hair on the photo itself and needs its hair mask: choose "
                       "a mask image, or use Fast")
    return {"session": session, "spec": spec, "model": str(model), "reference": reference, "mask": mask,
            "budget": budget}


def iter_compute(prepared: dict):
    """The estimate, refined when the budget asks. A generator: yields renders made so far (none for Fast) and
    returns modelled parameter -> raw value, inside its range."""
    spec = prepared["spec"]
    values = estimate(prepared["session"], spec, prepared["reference"])
    if prepared["budget"]:
        values = yield from iter_refine_hair(spec, prepared["reference"], prepared["mask"], values,
                                             prepared["budget"], prepared["session"].input_size[0])
    return values


def drain(steps, progress: Callable[[int], None] | None = None):
    """Run a generator to its end, passing each yielded count to `progress`; its return value."""
    while True:
        try:
            done = next(steps)
        except StopIteration as finished:
            return finished.value
        if progress is not None:
            progress(done)


def write(targets: list, values: dict[str, float]) -> None:
    """Set each target socket to its value (called only once everything is validated)."""
    for socket, name in targets:
        socket.default_value = values[name]


class MatchJob:
    """One match, validated before anything is written: begin (checks, may raise), steps(), then finish(values).

    The operator's modal form runs steps() a few renders per timer tick; finish() checks the targets again (the user
    may have linked an input meanwhile) before writing.
    """

    def __init__(self, renderer: str, settings: dict, material_name: str = "", scene=None):
        self.renderer, self.material_name, self.scene = renderer, material_name, scene
        self.started = time.perf_counter()
        self.nodes()  # the target first: a material without the group is the clearest error
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            self.prepared = prepare(renderer, settings)
        self.warnings = [str(w.message) for w in caught]  # e.g. NaN pixels read as 0: the operator reports them
        self.spec = self.prepared["spec"]
        self.targets()

    @property
    def where(self) -> str:
        return (f"material '{self.material_name}'" if self.renderer == "lipstick"
                else f"the compositor of scene '{self.scene.name}'")

    @property
    def budget(self) -> int:
        return self.prepared["budget"]

    def nodes(self) -> list:
        if self.renderer == "lipstick":
            import bpy

            material = bpy.data.materials.get(self.material_name)
            if material is None:
                raise VtoError(f"no material '{self.material_name}' in this .blend")
            nodes = lipstick_nodes(material)
            if not nodes:
                raise VtoError(f"material '{self.material_name}' does not use the 'VTO Lipstick' node group (add "
                               "one with Add VTO Lipstick Material)")
            return nodes
        nodes = hair_nodes(self.scene)
        if not nodes:
            raise VtoError(f"scene '{self.scene.name}' has no VTO hair compositor groups (add them with Add VTO "
                           "Hair Compositor)")
        return nodes

    def targets(self) -> list:
        return writable_sockets(self.nodes(), self.spec, self.where)

    def steps(self):
        return iter_compute(self.prepared)

    def finish(self, values: dict[str, float]) -> dict:
        """Check the targets again, then write: {'values', 'spec', 'model', 'previous', 'seconds'}."""
        targets = self.targets()
        previous = current_values(self.nodes(), self.spec)
        write(targets, values)
        return {"values": values, "spec": self.spec, "model": self.prepared["model"], "previous": previous,
                "seconds": time.perf_counter() - self.started, "warnings": self.warnings}


def match_into_material(material_name: str, settings: dict,
                        progress: Callable[[int], None] | None = None) -> dict:
    """Estimate the lipstick look of the reference and write it into `material_name`'s "VTO Lipstick" group inputs.

    Returns {'values', 'spec', 'model', 'seconds', 'previous'}; raises VtoError (nothing written) on any bad input.
    """
    job = MatchJob("lipstick", settings, material_name=material_name)
    return job.finish(drain(job.steps(), progress))


def match_into_hair(scene, settings: dict, progress: Callable[[int], None] | None = None) -> dict:
    """The hair look of the reference written into the hair compositor groups of `scene`; as match_into_material."""
    job = MatchJob("hair", settings, scene=scene)
    return job.finish(drain(job.steps(), progress))


def describe(spec: RendererSpec, values: dict[str, float]) -> list[str]:
    """One line per estimated value: 'Red: 183.2 8-bit sRGB' (name from the spec's socket, then its unit)."""
    return [f"{spec.by_name[name].socket}: {value:.3g}" + (f" {spec.by_name[name].unit}" if spec.by_name[name].unit
                                                           else "") for name, value in values.items()]


# --- the starting points ------------------------------------------------------------------------------------------

LIPSTICK_MATERIAL = "VTO Lipstick"


def add_lipstick_material(obj):
    """A new "VTO Lipstick" material on `obj` (a mesh): a Principled BSDF (the bare lips) -> the lipstick group ->
    Material Output, appended to its slots and made active. Returns the material."""
    import bpy

    from .nodes_lipstick import lipstick_material

    if obj is None or obj.type != "MESH":
        raise VtoError("select a mesh object to add the lipstick material to")
    material = lipstick_material(LIPSTICK_MATERIAL)
    obj.data.materials.append(material)
    obj.active_material_index = len(obj.material_slots) - 1
    return material


def add_hair_compositor(scene) -> list:
    """The two hair groups in `scene`'s compositor, wired: the hair swatch image -> "VTO Hair Swatch" -> Viewer (the
    recoloured swatch), the render -> "VTO Hair Color" -> Composite (a hair mask goes into its Mask input; Gradient
    stays 1, the whole hair). Returns the two group nodes."""
    import bpy

    from .hair import SWATCH_PATH
    from .nodes_hair import COLOR_GROUP, SWATCH_GROUP, color_group, swatch_group

    scene.use_nodes = True
    tree = scene.node_tree
    nodes, links = tree.nodes, tree.links
    def existing(idname: str):
        return next((n for n in nodes if n.bl_idname == idname), None) or nodes.new(idname)

    render, composite = existing("CompositorNodeRLayers"), existing("CompositorNodeComposite")
    swatch_image = nodes.new("CompositorNodeImage")
    swatch_image.name = swatch_image.label = "VTO Hair Swatch Image"
    swatch_image.image = bpy.data.images.load(str(SWATCH_PATH), check_existing=True)
    mask_image = nodes.new("CompositorNodeImage")
    mask_image.name = mask_image.label = "VTO Hair Mask (choose an image)"
    swatch = nodes.new("CompositorNodeGroup")
    swatch.name = swatch.label = SWATCH_GROUP
    swatch.node_tree = swatch_group()
    color = nodes.new("CompositorNodeGroup")
    color.name = color.label = COLOR_GROUP
    color.node_tree = color_group()
    color.inputs["Mask"].default_value = 1.0
    color.inputs["Gradient"].default_value = 1.0
    viewer = existing("CompositorNodeViewer")
    links.new(swatch_image.outputs["Image"], swatch.inputs["Image"])
    links.new(swatch.outputs[0], viewer.inputs[0])
    links.new(render.outputs["Image"], color.inputs["Image"])
    links.new(color.outputs[0], composite.inputs["Image"])
    mask_image.location, color.location, composite.location = (-400, -300), (0, 0), (300, 0)
    swatch_image.location, swatch.location, viewer.location = (-400, 300), (0, 300), (300, 300)
    return [swatch, color]


def save_blend_atomic(path: str) -> str:
    """Save the open file to `path` atomically: a temporary .blend in the same folder, then os.replace.

    On any failure the temporary file is removed and `path` is left as it was.
    """
    import shutil

    import bpy

    path = os.path.abspath(path)
    folder, name = os.path.split(path)
    if not os.path.isdir(folder):
        raise VtoError(f"cannot save {path}: no folder {folder}")
    temporary = os.path.join(folder, f".{name}.vto-{os.getpid()}.tmp.blend")
    try:
        try:
            done = bpy.ops.wm.save_as_mainfile(filepath=temporary, copy=True, check_existing=False)
        except RuntimeError as exc:
            raise VtoError(f"cannot save {path}: {str(exc).strip().splitlines()[0]}") from None
        if "FINISHED" not in done or not os.path.isfile(temporary):
            raise VtoError(f"cannot save {path}: Blender did not write the file")
        if os.path.isfile(path):
            shutil.copymode(path, temporary)
        os.replace(temporary, path)
    finally:
        if os.path.exists(temporary):
            os.remove(temporary)
    return path
