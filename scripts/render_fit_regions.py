"""Render the hair regions the hair fits start from (renderers.product_hair.FIT_SOURCES at FIT_RES, DEFAULT_SAMPLES)
into blender_addon/data/hair_fit_regions.npz (run once on bpy 4.5; the file is committed, and
tests/blender_addon/matching/test_photo_fit.py renders one again against it).

.venv/bin/python scripts/render_fit_regions.py"""

import bpy
import numpy as np

from blender_addon.renderers.product_hair import FIT_REGIONS, FIT_RES, FIT_SOURCES
from blender_addon.renderers.hair import render_hair_source
from blender_addon.shipped import DATA
from vto_core.dataset import DEFAULT_SAMPLES


def main() -> None:
    """rgb_SEED (FIT_RES, FIT_RES, 3) float32 display sRGB and mask_SEED (FIT_RES, FIT_RES) uint8 for each seed."""
    regions = {}
    for seed in FIT_SOURCES:
        hair = render_hair_source(seed, FIT_RES, DEFAULT_SAMPLES, 0)
        regions[f"rgb_{seed}"] = hair.rgb.astype(np.float32)
        regions[f"mask_{seed}"] = (hair.mask > 0.5).astype(np.uint8)
    np.savez_compressed(DATA / FIT_REGIONS, blender=np.array(bpy.app.version_string), res=FIT_RES,
                        samples=DEFAULT_SAMPLES, **regions)
    print(DATA / FIT_REGIONS)


if __name__ == "__main__":
    main()
