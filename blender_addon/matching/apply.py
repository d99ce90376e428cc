"""Match from photo, the logic under the panel, the operator and `vto match --material`: plain functions, no UI.

One call, `match_into_material` or `match_into_stage`, does everything in this order: resolve and load the model
(cached per file), check that it estimates this renderer's spec, read the reference (file or image datablock, with
an optional crop or mask), find the group nodes and refuse linked inputs, estimate (and refine where asked), and only
then write the group's inputs. Every failure before the writes is a VtoError with one line, so nothing has changed.

Settings are a plain dict (glTF-Blender-IO style), so the panel, the operator's own properties and the command line
all feed the same function:
    image_path | image_name     the reference: a file, or an image datablock already in the .blend
    crop                        (x, y, w, h) from the top-left: pixels, or fractions when all four are <= 1; or None
    mask_path                   an image whose > 0.5 region is the lips (the reference is framed around it) or the
                                hair (the encoder reads its largest square; Better and Best fit all of it)
    find_region                 find the product's region (default True). Lips, no mask: with the face locator;
                                hair, no crop or mask: around the largest face (a picture with no face is read whole
                                as a patch of hair). False takes the image (or crop) as it is (all hair), as
                                a product that finds no region yet always does (eye shadow: one eye, framed)
    neutral_light               read the photo's light from the skin beside the lips and take it out (default
                                True; blender_addon.matching.reference)
    model_path                  the encoder; "" = the add-on preferences' path, else the shipped default
    quality                     FAST (the encoder's estimate; for hair fitted to the hair's colour through the
                                colour imitator), BETTER, BEST (fitted through the real renderer:
                                blender_addon.matching.photo_fit)
"""

from __future__ import annotations

import time
import warnings
from collections.abc import Callable
from pathlib import Path

import numpy as np

from vto_core.errors import VtoError
from vto_core.inference import EncoderSession, cached_session
from vto_core.products import PRODUCTS, QUALITIES, Product, get_product, get_spec, layered_over_bare_skin
from vto_core.specs import RendererSpec

from ..renderers.products import blender_side
from ..shipped import MODELS
from .colour_fit import fast_polish_passes, iter_fit_photo_fast
from .photo_fit import NO_REGION, iter_fit_photo, photo_values
from .reference import absolute_path, read_reference
from .refine import drain



def default_model(renderer: str) -> Path:
    """The shipped encoder of `renderer`: blender_addon/models/<renderer>_encoder.onnx."""
    return MODELS / f"{renderer}_encoder.onnx"


def resolve_model(renderer: str, override: str = "", preference: str = "") -> Path:
    """The model to use: a per-material/per-call override, else the preferences' path, else the shipped one."""
    chosen = override or preference
    if chosen:
        return Path(absolute_path(chosen))
    return default_model(renderer)


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


# --- the targets --------------------------------------------------------------------------------------------------

def group_nodes(product: Product, target) -> list:
    """The product's group nodes in `target`: a material (a material product) or a scene (a compositor stage)."""
    return blender_side(product).nodes(target)


def worn_products(material) -> list[Product]:
    """The material products whose groups `material` uses, in declaration order ([] for none)."""
    return [p for p in PRODUCTS.values() if p.is_material and group_nodes(p, material)]


def material_product(material) -> Product | None:
    """The material product that Match fills in `material`: the one whose group is its active node (the layer
    chosen, where it wears several), else the first it wears (None: it wears none)."""
    worn = worn_products(material)
    active = material.node_tree.nodes.active if worn else None
    return next((p for p in worn if active in group_nodes(p, material)), worn[0] if worn else None)


def choose_layer(material, product: Product) -> None:
    """Make `product`'s group the active node of `material`, so that Match fills it; VtoError where it wears none."""
    nodes = group_nodes(product, material)
    if not nodes:
        raise VtoError(f"material '{material.name}' wears no {product.label}")
    material.node_tree.nodes.active = nodes[0]


def compositor_products() -> list[Product]:
    """The compositor stage products (hair colour), each with its match settings on the scene (stage_settings)."""
    return [p for p in PRODUCTS.values() if not p.is_material]


def stage_settings(scene, product: Product):
    """`scene`'s stored Match settings of compositor product `product` (Scene.vto_<name>_match), or None."""
    return getattr(scene, f"vto_{product.name}_match", None)


def written_params(spec: RendererSpec) -> list:
    """The parameters a match writes: the modelled ones, and what a photo fixes (the product's photo_fixes)."""
    return [spec.by_name[name] for name in get_product(spec.renderer).written(spec)]


def writable_sockets(nodes: list, spec: RendererSpec, where: str) -> list:
    """(socket, name) for each written parameter on each node having its input; linked inputs are an error."""
    targets = []
    for node in nodes:
        for param in written_params(spec):
            socket = node.inputs.get(param.socket)
            if socket is None:
                continue
            if socket.is_linked:
                raise VtoError(f"input '{socket.name}' of node '{node.name}' in {where} is driven by a link, so it "
                               f"cannot take the estimated {param.name}; unlink it, or use a model without "
                               f"{param.name}")
            targets.append((socket, param.name))
    missing = {p.name for p in written_params(spec)} - {name for _, name in targets}
    if missing:
        raise VtoError(f"{where}: no group input for {', '.join(sorted(missing))} (a group from another version?)")
    return targets


def current_values(nodes: list, spec: RendererSpec) -> dict[str, float]:
    """The first node's value of each written parameter it has (what a match would overwrite)."""
    values = {}
    for node in nodes:
        for param in written_params(spec):
            socket = node.inputs.get(param.socket)
            if socket is not None and param.name not in values:
                values[param.name] = float(socket.default_value)
    return values


# --- the estimate -------------------------------------------------------------------------------------------------

def estimate(session: EncoderSession, spec: RendererSpec, views: list[np.ndarray]) -> dict[str, float]:
    """The encoder's estimate of the modelled parameters (raw units) from the views of one product (both eyes: their
    mean)."""
    values = session.predict_views([views])[0]
    return {name: float(values[name]) for name in spec.modelled}


def prepare(renderer: str, settings: dict) -> dict:
    """Everything up to the estimate, nothing written: {'session', 'spec', 'model', 'reference' (a
    reference.Reference), 'quality', 'budget'}."""
    quality = settings.get("quality", "FAST")
    if quality not in QUALITIES:
        raise VtoError(f"quality is FAST, BETTER or BEST, got '{quality}'")
    model = resolve_model(renderer, settings.get("model_path", ""), settings.get("preference_model", ""))
    session, spec = load_model(renderer, model)
    reference = read_reference(renderer, settings)
    if quality != "FAST" and reference.region is None:
        raise VtoError(f"quality {quality.title()} {NO_REGION}")
    if quality != "FAST":
        budget = get_product(renderer).fit.renders[quality][1]
    else:  # Fast's polish passes, where there is a region to fit
        budget = fast_polish_passes(renderer) if reference.region is not None else 0
    return {"session": session, "spec": spec, "model": str(model), "reference": reference, "quality": quality,
            "budget": budget}


def iter_compute(prepared: dict):
    """The encoder's estimate of the photo with its light taken out (Fast; for hair fitted to the hair's colour
    statistics through the colour imitator, its mean colour then polished on FAST_POLISH stage passes), or, when the
    quality asks, fitted to the colour statistics through the real renderer on default sources from the unpolished fit
    (blender_addon.matching.photo_fit). A generator: yields renders made so far (none for lips' Fast) and returns
    parameter -> raw value, inside its range: the modelled ones and what a photo fixes (photo_fit.photo_values)."""
    from ..scratch import scratch_data

    spec, reference = prepared["spec"], prepared["reference"]
    values = encoder = estimate(prepared["session"], spec, reference.images)
    if reference.region is not None:
        values, note = yield from iter_fit_photo_fast(spec, reference.region, values, quality=prepared["quality"])
        reference.notes += [note] if note else []
    values = photo_values(spec, values)
    if prepared["quality"] != "FAST":
        reference.notes += layered_over_bare_skin(get_product(spec.renderer))  # a layer where it reads bare skin
        with scratch_data():  # the default scenes the fit renders leave nothing in the artist's .blend
            values = yield from iter_fit_photo(spec, reference.region, encoder, prepared["quality"],
                                               others=(values,), photo=(reference.whole, (reference.regions or [None])[0]))
        values = photo_values(spec, values)
    return values


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
        self.product = get_product(renderer)
        self.started = time.perf_counter()
        self.nodes()  # the target first: a material without the group is the clearest error
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            self.prepared = prepare(renderer, settings)
        self.warnings = [str(w.message) for w in caught]  # e.g. NaN pixels read as 0: the operator reports them
        self.notes = self.prepared["reference"].notes  # e.g. which face's lips were used
        self.spec = self.prepared["spec"]
        self.targets()

    @property
    def where(self) -> str:
        return blender_side(self.product).where(self.target())

    @property
    def budget(self) -> int:
        return self.prepared["budget"]

    def target(self):
        """The material (a material product) or the scene (a compositor stage) the match writes into."""
        if not self.product.is_material:
            return self.scene
        import bpy

        material = bpy.data.materials.get(self.material_name)
        if material is None:
            raise VtoError(f"no material '{self.material_name}' in this .blend")
        return material

    def nodes(self) -> list:
        target = self.target()
        nodes = group_nodes(self.product, target)
        if not nodes:
            raise VtoError(blender_side(self.product).missing_group(target))
        return nodes

    def targets(self) -> list:
        return writable_sockets(self.nodes(), self.spec, self.where)

    def steps(self):
        return iter_compute(self.prepared)

    def finish(self, values: dict[str, float]) -> dict:
        """Check the targets again, then write: {'values', 'spec', 'model', 'previous', 'seconds'}."""
        targets = self.targets()
        previous = current_values(self.nodes(), self.spec)
        # what the target needs besides its inputs (the hair stage's curve): computed first, so a refusal writes nothing
        write_fitted, notes = blender_side(self.product).fitted_target(self.target(), values)
        write(targets, values)
        write_fitted()
        return {"values": values, "spec": self.spec, "model": self.prepared["model"], "previous": previous,
                "seconds": time.perf_counter() - self.started, "warnings": self.warnings,
                "notes": self.notes + notes}


def match_into_material(material_name: str, settings: dict,
                        progress: Callable[[int], None] | None = None, product: Product | None = None) -> dict:
    """Estimate the look of the reference and write it into the inputs of the group `material_name` uses ("VTO
    Lipstick", "VTO Eye Shadow"): `product`'s, else its chosen layer's (material_product).

    Returns {'values', 'spec', 'model', 'seconds', 'previous'}; raises VtoError (nothing written) on any bad input.
    """
    import bpy

    material = bpy.data.materials.get(material_name)
    if product is not None and material is not None and product not in worn_products(material):
        raise VtoError(f"material '{material_name}' wears no {product.label}")
    product = product or material_product(material) or next(p for p in PRODUCTS.values() if p.is_material)
    job = MatchJob(product.name, settings, material_name=material_name)
    return job.finish(drain(job.steps(), progress))


def match_into_stage(scene, settings: dict, product: Product, progress: Callable[[int], None] | None = None
                     ) -> dict:
    """The look of the reference written into compositor product `product`'s groups of `scene` (the hair's); as
    match_into_material."""
    job = MatchJob(product.name, settings, scene=scene)
    return job.finish(drain(job.steps(), progress))


def describe(spec: RendererSpec, values: dict[str, float]) -> list[str]:
    """One line per estimated value, as its group input shows it: 'Red: 200.677 8-bit sRGB' (unit from the spec)."""

    def shown(value: float) -> str:
        # What Blender draws for a float socket (precision 3, subtype NONE): the stored float32, 3 decimals, more for
        # small values so 0.0004 is not "0.000" (UI_calc_float_precision, interface.cc).
        value = float(np.float32(value))
        precision, magnitude = 3, abs(value)
        if 1e-7 < magnitude < 1e-3:
            digits = f"{round(magnitude * 1e7):07d}"  # the first 7 decimals
            first = next(i for i, d in enumerate(digits) if d != "0")
            used = digits[first + 1:first + 4].rstrip("0")
            precision = max(precision, min(first + 1 + len(used), 6))
        return f"{value:.{precision}f}"

    return [f"{spec.by_name[name].socket}: {shown(value)}" + (f" {spec.by_name[name].unit}" if spec.by_name[name].unit
                                                             else "") for name, value in values.items()]
