"""Match as a library: a product's parameters from a reference image; the encoder's estimate, optionally refined (its
command is blender_addon.matching.commands).

Layering: this module needs onnxruntime (the encoder) and, for refinement, bpy (the renderer); it never imports torch
or `training`, because the extension ships without them. `--refine render:B` (a Gauss-Newton fit through the real
renderer, blender_addon.matching.refine; `cma:B` the derivative-free CMA-ES search) runs anywhere bpy does, inside
Blender too. `--refine imitator:K` is the pipeline layer's
(pipeline.match passes its refinement in as `imitator_refine`); without it, as inside Blender, it is one line.

Refinement compares renders of the reference's own source with the reference, so it needs that source: a seed of
the default scene (`--source SEED`), or for hair a photo with its `<name>_mask` beside it (the photo is its own
source). Without one the encoder's estimate is the answer, and the command says so.
"""

from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np

from vto_core.dataset import DEFAULT_SAMPLES
from vto_core.errors import VtoError
from vto_core.inference import EncoderSession
from vto_core.products import QUALITIES, get_product, get_spec, layered_over_bare_skin

from ..renderers.products import blender_side, check_lighting
from .colour_fit import fit_photo_fast
from .photo_fit import NO_REGION, iter_fit_photo, photo_values
from vto_core.photo.photo_reader import at_size

from .reference import read_reference
from .refine import OBJECTIVES, SIGMA, SIGMA_FROM_MEAN, drain, refine_by_render

NO_SOURCE = "no source for the reference (--source): refinement skipped, the encoder's estimate stands"
NO_IMITATOR = ("--refine imitator:K needs torch and the training package, which this Python lacks (e.g. inside "
               "Blender); use --refine render:B, or run `vto match` where torch is")


def parse_refine(text: str) -> tuple[str, int]:
    """'none' | 'imitator:K' | 'render:B' | 'cma:B' -> (kind, K or B)."""
    kind, _, amount = text.partition(":")
    if kind == "none" and not amount:
        return "none", 0
    if kind in ("imitator", "render", "cma") and amount.isdigit() and int(amount) >= 1:
        return kind, int(amount)
    raise VtoError(f"--refine takes none, imitator:K (K >= 1 gradient steps), render:B or cma:B (B >= 1 renders), "
                   f"got '{text}'")


class SourceRenderer:
    """R(X, .) on one fixed source X, at res px, `samples` spp and one Cycles seed: values -> (res, res, 3).

    source: a default-scene seed (int or digits), or where the product's photo is its own source (hair) a photo with
    its mask, rendered (or loaded) once here; `renders` counts the calls. lighting: the default scene's ("wide",
    "portrait"; None: its default) where the product has lightings (lips); the others have only their own.
    """

    def __init__(self, renderer: str, source, res: int, samples: int = DEFAULT_SAMPLES, seed: int = 0,
                 lighting: str | None = None):
        self.spec = get_spec(renderer)
        self.res, self.samples, self.seed, self.renders, self.lighting = res, samples, seed, 0, lighting
        check_lighting(get_product(renderer), lighting)
        self.source, self.bound = source, blender_side(renderer).bind(source, res, samples, seed, lighting)

    def __call__(self, values: dict[str, float]) -> np.ndarray:
        values = self.spec.check_values(values)
        self.renders += 1
        return self.bound.render(values)

    def source_image(self) -> np.ndarray:
        """X as the imitator sees it (the dataset's 'source'): the bare lips (opacity 0), or the hair source."""
        self.renders += get_product(self.spec.renderer).kind.renders_source
        return self.bound.source_image()


def own_mask(product, image_path: Path) -> str | None:
    """The '<name>_mask' image beside the photo, where a photo is its own source (its kind's photo_is_own_source)."""
    if not product.kind.photo_is_own_source:
        return None
    return next((str(mask) for mask in sorted(image_path.parent.glob(image_path.stem + "_mask.*"))), None)


def own_source(product, image_path: Path) -> str | None:
    """The photo, where it is its own source: its kind says so (a compositor stage) and its mask is beside it."""
    return str(image_path) if own_mask(product, image_path) else None


def match(model: str, image_path: str, source=None, refine: str = "none", imitator: str | None = None,
          res: int | None = None, samples: int = DEFAULT_SAMPLES, seed: int = 0, objective: str = "mse",
          start_at: str = "encoder", imitator_refine=None, lighting: str | None = None, quality: str = "fast",
          crop=None, mask_path: str | None = None, find_region: bool = True, neutral_light: bool = True) -> dict:
    """Estimate (and refine) the parameters of `image_path`.

    The reference is made ready as the panel makes it (blender_addon.matching.reference.read_reference): a crop, a mask,
    or the lips or the hair found in the photo (find_region; False takes the image as it is); a hair photo's
    '<name>_mask' beside it is its mask. With a `source` the image is a render of that source and is read whole.
    quality: "fast" (the encoder), "better" or "best" (the photo fit of blender_addon.matching.photo_fit, no source
    needed). refine: against a known source instead ('render:B', 'cma:B', 'imitator:K').
    Returns {'renderer', 'params': all parameters (raw values), 'refined', 'note', 'notes', 'encoder_ms'} (a photo:
    also 'fast_ms', the encoder's estimate fitted through the colour imitator) and, when
    refined, 'method', 'refine_ms', 'renders' or 'steps' (and 'loss_start', 'loss' for refine). res: the render size
    of render search (default: the reference's own, which must then be square). start_at: refinement starts at the
    'encoder' estimate or the 'mean' preset. imitator_refine: (spec, imitator run, source, reference, start unit, steps,
    samples, seed, lighting) -> a refinement with .unit, .loss, .start_loss, .steps; needed by imitator:K
    (pipeline.match gives it). lighting: the default lips scene's, for a lipstick --source (None: its default).
    neutral_light: a photo's light is read from its skin and taken out before the estimate (vto_core.photo.photo_reader;
    'light' in the result); False reads the photo's colours as they are. A render of a known source is read as it is.
    """
    kind, amount = parse_refine(refine)
    quality = str(quality).upper()
    if quality not in QUALITIES:
        raise VtoError(f"--quality takes fast, better or best, got '{quality.lower()}'")
    if quality != "FAST" and kind != "none":
        raise VtoError("--quality better/best fits the photo's colour without its source; --refine refines against a "
                       "known --source: choose one")
    if kind == "imitator" and not imitator:
        raise VtoError("--refine imitator:K needs --imitator RUN (the imitator run the encoder was trained with)")
    if start_at not in ("encoder", "mean"):
        raise VtoError(f"--start takes encoder or mean, got '{start_at}'")
    if objective not in OBJECTIVES:
        raise VtoError(f"--objective takes {' or '.join(OBJECTIVES)}, got '{objective}'")
    session = EncoderSession(model)
    spec = session.spec
    product = get_product(spec.renderer)
    if source is None and mask_path is None and crop is None:
        mask_path = own_mask(product, Path(image_path))
    settings = {"image_path": image_path, "crop": crop, "mask_path": mask_path,
                "find_region": find_region and source is None,
                "neutral_light": neutral_light and source is None}
    prepared = read_reference(spec.renderer, settings)
    started = time.perf_counter()
    values = session.predict_views([prepared.images])[0]
    result = {"renderer": spec.renderer, "params": values, "refined": False, "note": "", "notes": prepared.notes,
              "encoder_ms": 1000 * (time.perf_counter() - started)}
    turn = round(math.degrees(prepared.turn), 1)  # the face's roll the region was read upright from
    if prepared.found is not None:  # the region found ("lips", "eyelids": the first of each place read)
        result[product.region] = {"how": prepared.found.how, "box": list(prepared.found.box),
                                  "faces": prepared.found.faces, "turn": turn, "views": len(prepared.images)}
    if prepared.hair is not None:
        result["hair"] = {"box": list(prepared.hair.box), "faces": prepared.hair.faces,
                          "share": round(float(prepared.hair.mask.mean()), 4), "turn": turn}
    if prepared.light is not None:
        result["light"] = {"gains": [round(float(g), 4) for g in prepared.light.gains],
                           "read_from": prepared.light.read_from}
    encoder = {k: values[k] for k in spec.modelled}  # Better and Best's candidate starts: it and Fast's
    if source is None and prepared.region is not None:  # a photo: Fast (hair: its colour, through the colour imitator)
        fast, note = fit_photo_fast(spec, prepared.region, encoder, quality=quality)
        result["notes"] = prepared.notes + ([note] if note else [])
        result["params"] = values = spec.full_values(photo_values(spec, fast))
        result["fast_ms"] = 1000 * (time.perf_counter() - started)  # the encoder (and, for hair, the colour fit)
    if quality != "FAST":
        if prepared.region is None:
            raise VtoError(f"--quality {quality.lower()} {NO_REGION} (not --whole-image)")
        started = time.perf_counter()
        renders = []
        fitted = drain(iter_fit_photo(spec, prepared.region, encoder, quality, samples=samples,
                                      others=({k: values[k] for k in spec.modelled},),
                                      photo=(prepared.whole, (prepared.regions or [None])[0])),
                       renders.append)
        result["notes"] = result["notes"] + layered_over_bare_skin(product)  # a layer where it reads bare skin
        result.update(params=spec.full_values(photo_values(spec, fitted)), refined=True, method=quality.lower(),
                      renders=renders[-1],
                      refine_ms=1000 * (time.perf_counter() - started))
        return result
    if kind == "none":
        return result
    if source is None:
        source = own_source(product, Path(image_path))
    if source is None:
        result["note"] = NO_SOURCE
        return result
    reference = prepared.whole
    if start_at == "mean":
        from vto_core.presets import load_presets, preset_matrix

        start_unit = preset_matrix(spec, load_presets(spec.renderer)).mean(axis=0)
    else:
        start_unit = spec.normalise(spec.vector(values))
    wraps = np.array([p.wraps for p in spec.modelled_params])
    started = time.perf_counter()
    if kind in ("render", "cma"):
        if res is None:
            if reference.shape[0] != reference.shape[1]:
                raise VtoError(f"{image_path} is {reference.shape[1]}x{reference.shape[0]}; renders are square: pass "
                               "--res R to compare at R x R")
            res = reference.shape[0]
        on_source = SourceRenderer(spec.renderer, source, res, samples, seed, lighting)
        held = None
        if on_source.bound.own_photo and Path(str(source)).resolve() == Path(image_path).resolve():
            held = blender_side(product).fit_held(spec, spec.values(spec.denormalise(start_unit)))
        refined = refine_by_render(lambda u: on_source(spec.values(spec.denormalise(u))), at_size(reference, res, res),
                                   start_unit, amount, seed, wraps, objective,
                                   SIGMA_FROM_MEAN if start_at == "mean" else SIGMA, held,
                                   "fit" if kind == "render" and objective == "mse" else "cma")
        result["renders"] = refined.renders
    else:
        if imitator_refine is None:
            raise VtoError(NO_IMITATOR)
        refined = imitator_refine(spec, imitator, source, reference, start_unit, amount, samples, seed, lighting)
        result["steps"] = refined.steps
    result.update(params=spec.values(spec.denormalise(refined.unit)), refined=True, method=refine,
                  refine_ms=1000 * (time.perf_counter() - started), loss_start=refined.start_loss, loss=refined.loss)
    return result
