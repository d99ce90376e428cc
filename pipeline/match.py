"""`vto match` with imitator refinement: blender_addon's match command, given the imitator of training.refine."""

from __future__ import annotations

import numpy as np

from vto_core.errors import VtoError
from vto_core.specs import RendererSpec


def imitator_refiner(spec: RendererSpec, imitator_run: str):
    """training.refine.ImitatorRefiner for `spec`; a one-line error where torch is missing."""
    try:
        from training.refine import ImitatorRefiner
    except ImportError:
        from blender_addon.matching.match import NO_IMITATOR

        raise VtoError(NO_IMITATOR) from None
    return ImitatorRefiner(imitator_run, spec)


def imitator_inputs(refiner, renderer: str, source, reference: np.ndarray, samples: int, seed: int,
                    lighting: str | None = None):
    """(X, reference) at the imitator's size: X rendered (or loaded) there, the reference resized."""
    from blender_addon.matching.match import SourceRenderer
    from vto_core.photo.photo_reader import at_size

    height, width = refiner.image_size
    if height != width:
        raise VtoError(f"the imitator works on {height}x{width} images; the default scenes render square ones")
    x = SourceRenderer(renderer, source, height, samples, seed, lighting).source_image()
    return x, at_size(reference, height, width)


def refine_with_imitator(spec: RendererSpec, imitator_run: str, source, reference: np.ndarray, start_unit: np.ndarray,
                         steps: int, samples: int, seed: int, lighting: str | None = None):
    """`steps` gradient steps through the imitator from `start_unit` (m,): training.refine.ImitatorRefined."""
    refiner = imitator_refiner(spec, imitator_run)
    return refiner.refine(*imitator_inputs(refiner, spec.renderer, source, reference, samples, seed, lighting),
                          start_unit, steps)


def cmd_match(argv: list[str]) -> int:
    """vto match, as blender_addon.matching.commands.cmd_match, with --refine imitator:K available."""
    from blender_addon.matching.commands import cmd_match as addon_cmd_match

    return addon_cmd_match(argv, imitator_refine=refine_with_imitator)
