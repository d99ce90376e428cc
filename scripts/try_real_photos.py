"""The shipped encoders on a real photograph: scikit-image's astronaut portrait, cropped to the lips and to the hair.

    .venv/bin/python scripts/try_real_photos.py [--out out/real]

Writes OUT/sheet.png (per renderer: the photo crop | the estimate rendered on the default scene, at 128 px) and
OUT/estimates.json. What the estimates look like is reported in the model cards; this script is how to see it.

For the lips it also measures the colour: the photo's mean lip colour (the reddest fifth of the crop by CIELAB a*:
lips, not skin or teeth) against the estimate's apparent lip colour (the median over default sources 0-7 at 64 px
of the lips' mean colour in its render), as CIEDE2000.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
import skimage.data

from blender_addon.commands import render
from vto_core.imageio import resize, write_image
from vto_core.inference import EncoderSession

MODELS = Path(__file__).resolve().parent.parent / "blender_addon" / "models"
# (row slice, column slice) of the 512 x 512 astronaut portrait: the mouth, and a patch of hair only (with the face
# and the background in the crop the hair encoder reads skin: the default hair scene never shows a face).
CROPS = {"lipstick": (slice(117, 173), slice(196, 252)), "hair": (slice(20, 90), slice(150, 230))}
SOURCES = {"lipstick": 1, "hair": 1}
SHOW = 128
LIP_SHARE = 0.2  # the reddest fifth of the mouth crop is lip
ISSUE_LIP_COLOUR = np.array([204.0, 142.0, 135.0]) / 255  # the photo's lip colour as the issue's goal measured it


def photo_lip_colour(crop: np.ndarray) -> np.ndarray:
    """Mean display sRGB (3,) of the crop's lip pixels: its reddest LIP_SHARE by CIELAB a*."""
    from skimage.color import rgb2lab

    redness = rgb2lab(crop)[..., 1]
    return crop[redness >= np.quantile(redness, 1.0 - LIP_SHARE)].mean(axis=0)


def rendered_lip_colour(values: dict, sources=range(8), res: int = 64) -> np.ndarray:
    """Median over default `sources` of the lips' mean display sRGB (3,) in the estimate's render."""
    from blender_addon.scene_lips import lips_mask

    return np.median([render("lipstick", values, source, res, 16)[lips_mask(source, res)].mean(axis=0)
                      for source in sources], axis=0)


def ciede2000(a: np.ndarray, b: np.ndarray) -> float:
    """CIEDE2000 between two display sRGB colours (3,) in [0, 1]."""
    from skimage.color import deltaE_ciede2000, rgb2lab

    return float(deltaE_ciede2000(rgb2lab(a.reshape(1, 1, 3)), rgb2lab(b.reshape(1, 1, 3)))[0, 0])


def main() -> None:
    """Estimate each renderer's parameters from its crop and render them beside it."""
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", default="out/real")
    parser.add_argument("--lipstick-model", default=str(MODELS / "lipstick_encoder.onnx"))
    args = parser.parse_args()
    out = Path(args.out)
    photo = skimage.data.astronaut().astype(np.float32) / 255
    rows, estimates = [], {}
    for renderer, (rows_slice, cols_slice) in CROPS.items():
        model = Path(args.lipstick_model) if renderer == "lipstick" else MODELS / f"{renderer}_encoder.onnx"
        if not model.exists():
            continue
        crop = photo[rows_slice, cols_slice]
        values = EncoderSession(str(model)).predict(crop)[0]
        estimates[renderer] = {k: round(float(v), 3) for k, v in values.items()}
        if renderer == "lipstick":
            photo_colour, estimate_colour = photo_lip_colour(crop), rendered_lip_colour(values)
            estimates["lip_colour"] = {"photo": (photo_colour * 255).round(1).tolist(),
                                       "estimate": (estimate_colour * 255).round(1).tolist(),
                                       "ciede2000": round(ciede2000(photo_colour, estimate_colour), 2),
                                       "ciede2000_to_issue_colour": round(ciede2000(ISSUE_LIP_COLOUR,
                                                                                    estimate_colour), 2)}
        rendered = render(renderer, values, SOURCES[renderer], SHOW, 32)
        rows.append(np.concatenate([resize(crop, SHOW, SHOW), rendered], axis=1))
    out.mkdir(parents=True, exist_ok=True)
    write_image(out / "sheet.png", np.concatenate(rows, axis=0))
    (out / "estimates.json").write_text(json.dumps(estimates, indent=1))
    print(json.dumps({"sheet": str(out / "sheet.png"), **estimates}))


if __name__ == "__main__":
    main()
