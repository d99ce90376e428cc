"""Convert MediaPipe's selfie segmentation model (the person against the background, 256 x 256) to ONNX, once.

Source: the PyPI wheel mediapipe==0.10.21 (Apache-2.0, Google LLC), file
    mediapipe/modules/selfie_segmentation/selfie_segmentation.tflite   249,505 bytes, sha256 9ee168ec...d1462f5c
(the same file in every wheel from 0.10.5 to 0.10.21; wheels from 0.10.30 on carry no .tflite). Input (1, 256, 256, 3)
NHWC, display RGB in [0, 1]; output `activation_10` (1, 256, 256, 1), the probability that a pixel is the person.

tflite2onnx 0.4.1 cannot convert it (it has no HARD_SWISH, and MediaPipe's custom op Convolution2DTransposeBias), so
this script reads the flatbuffer with the `tflite` package and writes each of the graph's 11 op types as ONNX nodes
itself: CONV_2D, DEPTHWISE_CONV_2D (Conv with group), HARD_SWISH, RELU, LOGISTIC, AVERAGE_POOL_2D, MUL, ADD,
RESIZE_BILINEAR (half-pixel centres), DEQUANTIZE (float16 weights widened to float32 initialisers, exact) and the
custom transposed convolution (ConvTranspose; its options are TfLiteTransposeConvParams: padding, stride w, stride h
as int32). The ONNX graph runs in NCHW: input (1, 3, 256, 256), output (1, 1, 256, 256).

Run in a venv of its own, never the project's:
    python3 -m venv /tmp/conv && /tmp/conv/bin/pip install tflite==2.18.0 onnx==1.23.2 onnxruntime==1.31.1 numpy
    pip download mediapipe==0.10.21 --no-deps --only-binary=:all: --python-version 3.11 \\
        --platform manylinux_2_28_x86_64 -d /tmp/wheels
    unzip -q /tmp/wheels/mediapipe-0.10.21-*.whl 'mediapipe/modules/selfie_segmentation/*' -d /tmp/mp
    /tmp/conv/bin/python scripts/convert_selfie_model.py \\
        --tflite /tmp/mp/mediapipe/modules/selfie_segmentation/selfie_segmentation.tflite --out blender_addon/models
Parity with MediaPipe's own graph: scripts/selfie_parity.py (in a venv with the mediapipe wheel).
"""

from __future__ import annotations

import argparse
import hashlib
import struct
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
SHA256 = "9ee168ec7c8f2a16c56fe8e1cfbc514974cbbb7e434051b455635f1bd1462f5c"
OPSET = 14  # HardSwish
METADATA = {
    "source": "mediapipe 0.10.21 (PyPI), mediapipe/modules/selfie_segmentation/selfie_segmentation.tflite",
    "source_url": "https://pypi.org/project/mediapipe/0.10.21/",
    "source_sha256": SHA256,
    "licence": "Apache-2.0 (MediaPipe model, Google LLC)",
    "converted_with": "scripts/convert_selfie_model.py (tflite {tflite}, onnx {onnx})",
    "layout": "NCHW float32; input display RGB in [0, 1]; output person probability",
}
ACTIVATIONS = {0: None, 1: "Relu"}  # tflite ActivationFunctionType: NONE, RELU (the only ones this graph fuses)


class Converter:
    """Walks one tflite subgraph and collects ONNX nodes and initialisers."""

    def __init__(self, model, tflite):
        self.model, self.tflite = model, tflite
        self.graph = model.Subgraphs(0)
        self.nodes, self.initialisers, self.constants = [], [], {}
        self.op_names = {v: k for k, v in vars(tflite.BuiltinOperator).items() if not k.startswith("_")}

    # -- tensors --
    def name(self, index: int) -> str:
        """The ONNX name of tflite tensor `index`."""
        return self.graph.Tensors(index).Name().decode()

    def shape(self, index: int) -> list[int]:
        """The tflite (NHWC) shape of tensor `index`."""
        return self.graph.Tensors(index).ShapeAsNumpy().tolist()

    def buffer(self, index: int) -> np.ndarray | None:
        """The constant data of tensor `index` (or of the float16 tensor a DEQUANTIZE widened), or None."""
        if index in self.constants:
            return self.constants[index]
        tensor = self.graph.Tensors(index)
        data = self.model.Buffers(tensor.Buffer()).DataAsNumpy()
        if isinstance(data, int) or data.size == 0:
            return None
        dtype = {0: np.float32, 1: np.float16, 2: np.int32}[tensor.Type()]
        return np.frombuffer(data.tobytes(), dtype).reshape(self.shape(index))

    def initialiser(self, name: str, value: np.ndarray) -> str:
        """Adds a constant and returns its name."""
        import onnx.numpy_helper

        self.initialisers.append(onnx.numpy_helper.from_array(np.ascontiguousarray(value), name))
        return name

    def node(self, op: str, inputs: list[str], output: str, activation: int = 0, **attributes) -> None:
        """Adds an ONNX node, then the fused activation if there is one."""
        import onnx.helper

        fused = ACTIVATIONS[activation]
        raw = output + "_pre" if fused else output
        self.nodes.append(onnx.helper.make_node(op, inputs, [raw], name=raw, **attributes))
        if fused:
            self.nodes.append(onnx.helper.make_node(fused, [raw], [output], name=output))

    # -- ops --
    @staticmethod
    def same_pads(size: int, kernel: int, stride: int) -> tuple[int, int]:
        """tflite's SAME padding for one axis: (before, after), the extra pixel after."""
        out = -(-size // stride)
        total = max((out - 1) * stride + kernel - size, 0)
        return total // 2, total - total // 2

    def pads(self, padding: int, input_index: int, kernel: tuple[int, int], strides: tuple[int, int]) -> list[int]:
        """ONNX pads (top, left, bottom, right) for tflite padding (0 SAME, 1 VALID)."""
        if padding == 1:
            return [0, 0, 0, 0]
        _, height, width, _ = self.shape(input_index)
        (top, bottom), (left, right) = (self.same_pads(height, kernel[0], strides[0]),
                                        self.same_pads(width, kernel[1], strides[1]))
        return [top, left, bottom, right]

    def options(self, op, kind):
        """The op's builtin options as a tflite `kind` table."""
        table, options = op.BuiltinOptions(), kind()
        options.Init(table.Bytes, table.Pos)
        return options

    def convert_op(self, op) -> None:
        """Appends the ONNX nodes for one tflite op."""
        tflite = self.tflite
        code = self.model.OperatorCodes(op.OpcodeIndex())
        kind = self.op_names[max(code.BuiltinCode(), code.DeprecatedBuiltinCode())]
        inputs, (output,) = op.InputsAsNumpy().tolist(), op.OutputsAsNumpy().tolist()
        out = self.name(output)
        if kind == "DEQUANTIZE":
            self.constants[output] = self.buffer(inputs[0]).astype(np.float32)
        elif kind in ("CONV_2D", "DEPTHWISE_CONV_2D"):
            weights, bias = self.buffer(inputs[1]), self.buffer(inputs[2])
            depthwise = kind == "DEPTHWISE_CONV_2D"
            options = self.options(op, tflite.DepthwiseConv2DOptions if depthwise else tflite.Conv2DOptions)
            assert options.DilationHFactor() == options.DilationWFactor() == 1
            # tflite conv weights are (O, kH, kW, I); depthwise (1, kH, kW, C): ONNX wants (O, I/group, kH, kW)
            weights = weights.transpose(3, 0, 1, 2) if depthwise else weights.transpose(0, 3, 1, 2)
            if depthwise:
                assert options.DepthMultiplier() == 1
            strides = (options.StrideH(), options.StrideW())
            self.node("Conv", [self.name(inputs[0]), self.initialiser(out + "_w", weights),
                               self.initialiser(out + "_b", bias)], out, options.FusedActivationFunction(),
                      strides=list(strides), kernel_shape=list(weights.shape[2:]),
                      pads=self.pads(options.Padding(), inputs[0], weights.shape[2:], strides),
                      group=weights.shape[0] if depthwise else 1)
        elif kind == "CUSTOM":
            assert op.CustomCode() if hasattr(op, "CustomCode") else True
            padding, stride_w, stride_h = struct.unpack("<3i", op.CustomOptionsAsNumpy().tobytes()[:12])
            assert padding == 1, "only VALID transposed convolutions are in this graph"
            weights = self.buffer(inputs[1]).transpose(3, 0, 1, 2)  # (O, kH, kW, I) -> (I, O, kH, kW)
            self.node("ConvTranspose", [self.name(inputs[0]), self.initialiser(out + "_w", weights),
                                        self.initialiser(out + "_b", self.buffer(inputs[2]))], out,
                      strides=[stride_h, stride_w], kernel_shape=list(weights.shape[2:]))
        elif kind == "AVERAGE_POOL_2D":
            options = self.options(op, tflite.Pool2DOptions)
            kernel, strides = (options.FilterHeight(), options.FilterWidth()), (options.StrideH(), options.StrideW())
            self.node("AveragePool", [self.name(inputs[0])], out, options.FusedActivationFunction(),
                      kernel_shape=list(kernel), strides=list(strides),
                      pads=self.pads(options.Padding(), inputs[0], kernel, strides))
        elif kind in ("ADD", "MUL"):
            assert all(self.buffer(i) is None for i in inputs), "constant operands would need a layout change"
            activation = self.options(op, tflite.AddOptions if kind == "ADD" else tflite.MulOptions)
            self.node(kind.capitalize(), [self.name(i) for i in inputs], out, activation.FusedActivationFunction())
        elif kind == "RESIZE_BILINEAR":
            options = self.options(op, tflite.ResizeBilinearOptions)
            mode = ("align_corners" if options.AlignCorners() else
                    "half_pixel" if options.HalfPixelCenters() else "asymmetric")
            height, width = self.buffer(inputs[1]).tolist()
            channels = self.shape(inputs[0])[3]
            sizes = self.initialiser(out + "_sizes", np.array([1, channels, height, width], np.int64))
            self.node("Resize", [self.name(inputs[0]), "", "", sizes], out, mode="linear",
                      coordinate_transformation_mode=mode)
        elif kind in ("HARD_SWISH", "RELU", "LOGISTIC"):
            self.node({"HARD_SWISH": "HardSwish", "RELU": "Relu", "LOGISTIC": "Sigmoid"}[kind],
                      [self.name(inputs[0])], out)
        else:
            raise SystemExit(f"op {kind} is not in this converter")

    def convert(self):
        """The whole graph as an onnx.ModelProto (NCHW input and output)."""
        import onnx
        import onnx.helper

        for i in range(self.graph.OperatorsLength()):
            self.convert_op(self.graph.Operators(i))
        (source,), (target,) = self.graph.InputsAsNumpy().tolist(), self.graph.OutputsAsNumpy().tolist()
        _, height, width, channels = self.shape(source)
        _, out_height, out_width, out_channels = self.shape(target)
        graph = onnx.helper.make_graph(
            self.nodes, "selfie_segmentation",
            [onnx.helper.make_tensor_value_info(self.name(source), onnx.TensorProto.FLOAT,
                                                [1, channels, height, width])],
            [onnx.helper.make_tensor_value_info(self.name(target), onnx.TensorProto.FLOAT,
                                                [1, out_channels, out_height, out_width])],
            sorted(self.initialisers, key=lambda tensor: tensor.name))
        return onnx.helper.make_model(graph, opset_imports=[onnx.helper.make_opsetid("", OPSET)], ir_version=8,
                                      producer_name="convert_selfie_model.py", producer_version="1")


def main() -> None:
    """Convert, stamp the metadata, check and save."""
    import onnx
    import onnxruntime
    import tflite

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tflite", type=Path, required=True)
    parser.add_argument("--out", type=Path, default=ROOT / "blender_addon" / "models")
    args = parser.parse_args()
    data = args.tflite.read_bytes()
    if hashlib.sha256(data).hexdigest() != SHA256:
        raise SystemExit(f"{args.tflite}: not the selfie_segmentation.tflite of mediapipe 0.10.21 (sha256 differs)")
    model = Converter(tflite.Model.GetRootAsModel(data, 0), tflite).convert()
    for key, value in METADATA.items():
        entry = model.metadata_props.add()
        entry.key, entry.value = key, value.format(tflite=tflite.__version__ if hasattr(tflite, "__version__")
                                                   else "2.18.0", onnx=onnx.__version__)
    onnx.checker.check_model(model, full_check=True)
    target = args.out / "person_segmenter.onnx"
    onnx.save(model, str(target))
    session = onnxruntime.InferenceSession(str(target), providers=["CPUExecutionProvider"])
    grey = session.run(None, {session.get_inputs()[0].name: np.full((1, 3, 256, 256), 0.5, np.float32)})[0]
    print(f"{target}: {target.stat().st_size} bytes, {len(model.graph.node)} nodes, sha256 "
          f"{hashlib.sha256(target.read_bytes()).hexdigest()}; grey input -> mean person {grey.mean():.4f}")


if __name__ == "__main__":
    main()
