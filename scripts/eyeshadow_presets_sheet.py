"""docs/eyeshadow_presets.png: every eye-shadow preset on the default eye, named with its finish.

    .venv/bin/python scripts/eyeshadow_presets_sheet.py [--source 2] [--columns 6] [--res 128] [--samples 32]
        [--out docs/eyeshadow_presets.png]
"""

from __future__ import annotations

import argparse
import json

import numpy as np

CAPTION = 18  # px under each render for its name and finish


def caption(text: str, width: int) -> np.ndarray:
    """White text on black: (CAPTION, width, 3) float32."""
    import OpenImageIO as oiio

    buf = oiio.ImageBuf(oiio.ImageSpec(width, CAPTION, 3, "float"))
    oiio.ImageBufAlgo.render_text(buf, 3, CAPTION - 5, text, 10, "", (1.0, 1.0, 1.0))
    return buf.get_pixels(oiio.FLOAT).reshape(CAPTION, width, 3)


def main() -> None:
    """Render the presets in the file's order, `columns` a row, each above its caption."""
    from blender_addon.renderers.product_eyeshadow import render_eyeshadow
    from vto_core.imageio import write_image
    from vto_core.presets import PRESET_DIR

    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--source", type=int, default=2, help="the default eye scene's source seed")
    parser.add_argument("--columns", type=int, default=6)
    parser.add_argument("--res", type=int, default=128)
    parser.add_argument("--samples", type=int, default=32)
    parser.add_argument("--out", default="docs/eyeshadow_presets.png")
    args = parser.parse_args()
    rows = json.loads((PRESET_DIR / "eyeshadow.json").read_text())["presets"]
    cells = [np.concatenate([render_eyeshadow(row["params"], args.source, args.res, args.samples),
                             caption(f"{row['name']} ({row['finish']})", args.res)], axis=0) for row in rows]
    cells += [np.zeros_like(cells[0])] * (-len(cells) % args.columns)
    sheet = np.concatenate([np.concatenate(cells[i:i + args.columns], axis=1)
                            for i in range(0, len(cells), args.columns)], axis=0)
    write_image(args.out, sheet, bits=8)
    print(args.out)


if __name__ == "__main__":
    main()
