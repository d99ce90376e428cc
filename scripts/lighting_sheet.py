"""docs/lighting.png: the same looks on default sources 0-7 under wide (top rows) and portrait (bottom rows) light.

    .venv/bin/python scripts/lighting_sheet.py [--looks "Classic Red|Bare Nude|Plum"] [--res 96] [--out docs/lighting.png]
"""

from __future__ import annotations

import argparse

import numpy as np


def main() -> None:
    """Render the sheet: one row per (lighting, look), one column per source."""
    from blender_addon.renderers.product_lipstick import render_lipstick
    from vto_core.imageio import write_image
    from vto_core.presets import load_presets

    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--looks", default="Classic Red|Bare Nude|Plum")
    parser.add_argument("--sources", type=int, default=8)
    parser.add_argument("--res", type=int, default=96)
    parser.add_argument("--out", default="docs/lighting.png")
    args = parser.parse_args()
    presets = load_presets("lipstick")
    rows = [np.concatenate([render_lipstick(presets[look], source, args.res, 16, 0, lighting=lighting)
                            for source in range(args.sources)], axis=1)
            for lighting in ("wide", "portrait") for look in args.looks.split("|")]
    gap = np.ones((args.res // 12, rows[0].shape[1], 3), np.float32)
    half = len(rows) // 2
    write_image(args.out, np.concatenate(rows[:half] + [gap] + rows[half:], axis=0), bits=8)
    print(args.out)


if __name__ == "__main__":
    main()
