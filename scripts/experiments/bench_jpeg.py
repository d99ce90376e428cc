"""How far JPEG compression moves a lipstick encoder's colour estimate, against the estimate's own error.

The last renders of a `vto dataset` folder (those a training run on it holds out) are written as JPEG through
OpenImageIO at several qualities, either at the encoder's 64 px or at 4x that size and then shrunk to 64 px (a photo is usually larger than the crop the encoder
sees), and read back; the encoder's red, green and blue estimates are compared with those from the lossless render
and with the truth, in 8-bit steps. Writes a section of scripts/experiments/results/jpeg.md.

    python -m scripts.experiments.bench_jpeg --data DATA [--model blender_addon/models/lipstick_encoder.onnx] [--n 300]
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np

from benchmarks.common import lip_colour, table, write_section
SETTINGS = ((90, 1), (70, 1), (50, 1), (30, 1), (70, 4), (50, 4), (30, 4))  # (JPEG quality, size factor)


def jpeg_view(image: np.ndarray, quality: int, factor: int, folder: Path) -> np.ndarray:
    """image (H, W, 3) in [0, 1] -> the same size after a JPEG round trip at `factor` times its size."""
    from vto_core.imageio import jpeg_round_trip, resize

    height, width = image.shape[:2]
    big = resize(image, height * factor, width * factor) if factor > 1 else image
    back = jpeg_round_trip(big, quality, folder)
    return resize(back, height, width) if factor > 1 else back


def run(data: str, model: str, n: int) -> str:
    """The table of shifts and errors, as markdown."""
    from vto_core.dataset import DatasetReader
    from vto_core.inference import EncoderSession

    reader = DatasetReader(data)
    session = EncoderSession(model)
    positions = range(max(len(reader) - n, 0), len(reader))  # the end: what training holds out (val_fraction)
    samples = [reader[i] for i in positions]
    truth = np.array([lip_colour(reader.spec.values(s.raw)) for s in samples])

    def colours(images):
        return np.array([lip_colour(estimate) for estimate in session.predict(images)])

    lossless = colours([s.render for s in samples])
    rows = [["lossless", "-", "0.00", f"{np.median(np.abs(lossless - truth)):.2f}"]]
    with tempfile.TemporaryDirectory() as folder:
        for quality, factor in SETTINGS:
            found = colours([jpeg_view(s.render, quality, factor, Path(folder)) for s in samples])
            rows.append([f"JPEG quality {quality}", f"{64 * factor} px",
                         f"{np.median(np.abs(found - lossless)):.2f}", f"{np.median(np.abs(found - truth)):.2f}"])
    return (f"## JPEG against the colour estimate ({Path(model).name})\n\n"
            f"The last {len(samples)} renders of `{data}` (held out in training); medians over looks and channels, "
            "8-bit steps.\n\n"
            + table(["view", "JPEG written at", "shift from the lossless estimate", "error against the truth"], rows)
            + f"\n\nReproduce: `python -m scripts.experiments.bench_jpeg --data DATA --model {model} --n {n}`.")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", required=True, help="a lipstick `vto dataset` folder")
    parser.add_argument("--model", default="blender_addon/models/lipstick_encoder.onnx")
    parser.add_argument("--n", type=int, default=300)
    parser.add_argument("--results", default=str(Path(__file__).parent / "results"))
    args = parser.parse_args()
    write_section("jpeg", "jpeg-colour", run(args.data, args.model, args.n), Path(args.results))


if __name__ == "__main__":
    main()
