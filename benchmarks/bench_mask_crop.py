"""The panel's mask path on lipstick references: how the crop around a lips mask decides the colour estimate.

Fresh looks (opacity >= 0.5) rendered at 128 px on fresh default sources; each reference and its lips mask written as
PNG and read back through the panel's own path (blender_addon.matching.reference.read_reference: the mask framed by
region_frame), against the whole render and against the mask's own box (what the panel did before: the box stretched
to the encoder's square). Reports the median |error| of R, G and B in 8-bit steps into
benchmarks/results/mask_crop.md.

    python -m benchmarks.bench_mask_crop [--model blender_addon/models/lipstick_encoder.onnx] [--n 24]
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np

from benchmarks.common import RESULTS, lip_colour, table, write_section
RES = 128
FIRST_SOURCE = 7000


def run(model: str, n: int, seed: int) -> str:
    """The table as markdown."""
    from blender_addon.renderers.products import render
    from blender_addon.matching.reference import read_reference
    from blender_addon.renderers.scene_lips import lips_mask
    from vto_core.imageio import resize, write_image
    from vto_core.inference import EncoderSession
    from vto_core.products import get_spec

    spec, session = get_spec("lipstick"), EncoderSession(model)
    size = session.input_size[0]
    rng = np.random.default_rng(seed)
    errors = {"whole render": [], "the mask's own box (before)": [], "the panel's mask path (region_frame)": []}
    with tempfile.TemporaryDirectory() as folder:
        for index in range(n):
            unit = rng.random(spec.size)
            opacity = spec.modelled.index("opacity")
            unit[opacity] = 0.5 + 0.5 * unit[opacity]
            values = spec.values(spec.denormalise(unit))
            source = FIRST_SOURCE + index
            image, mask = render("lipstick", values, source, RES, 16), lips_mask(source, RES)
            image_path, mask_path = Path(folder) / "reference.png", Path(folder) / "mask.png"
            write_image(image_path, image)
            write_image(mask_path, mask.astype(np.float32))
            rows, cols = np.nonzero(mask)
            views = {"whole render": image,
                     "the mask's own box (before)": image[rows.min():rows.max() + 1, cols.min():cols.max() + 1],
                     "the panel's mask path (region_frame)": read_reference({"image_path": str(image_path),
                                                                           "mask_path": str(mask_path)})[0]}
            for name, view in views.items():
                estimate = session.predict(resize(view, size, size))[0]
                errors[name].append(np.abs(lip_colour(estimate) - lip_colour(values)))
    rows = [[name, f"{np.median(found):.1f}"] for name, found in errors.items()]
    return (f"## Colour error by the crop the encoder sees ({Path(model).name})\n\n"
            f"{n} fresh looks (opacity >= 0.5, look seed {seed}) on default sources {FIRST_SOURCE}-"
            f"{FIRST_SOURCE + n - 1}, rendered at {RES} px with 16 spp; median |error| of R, G and B in 8-bit "
            "steps.\n\n" + table(["what the encoder sees", "colour error /255"], rows)
            + f"\n\nReproduce: `python -m benchmarks.bench_mask_crop --model {model} --n {n}`.")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--model", default="blender_addon/models/lipstick_encoder.onnx")
    parser.add_argument("--n", type=int, default=24)
    parser.add_argument("--seed", type=int, default=5)
    parser.add_argument("--results", default=str(RESULTS))
    args = parser.parse_args()
    write_section("mask_crop", "mask-crop", run(args.model, args.n, args.seed), Path(args.results))


if __name__ == "__main__":
    main()
