"""`vto train imitator|encoder` and `vto export`: thin argument layers over the training functions."""

from __future__ import annotations

import json

from vto_core.cli import ArgumentParser
from vto_core.errors import VtoError

from .config import ColourConfig, EncoderConfig, ImitatorConfig, resolve_config


def _check_device(device: str) -> None:
    import torch

    if device.startswith("cuda") and not torch.cuda.is_available():
        raise VtoError(f"--device {device}: torch sees no CUDA device on this machine")


def cmd_train(argv: list[str]) -> int:
    """vto train imitator|encoder|colour --data DIR [DIR ...] [--imitator RUN] --out RUN: train on one or more
    datasets (colour: the colour imitator, written straight to --out FILE.onnx)."""
    parser = ArgumentParser(prog="vto train", description="train the imitator, the encoder (paper 5, 6.2) or the "
                                                          "colour imitator (what Fast fits a photo's colour through)")
    parser.add_argument("kind", choices=["imitator", "encoder", "colour"])
    parser.add_argument("--data", required=True, nargs="+", metavar="DIR",
                        help="a `vto dataset` folder, or several of one spec read as one (held out: the last's tail)")
    parser.add_argument("--out", required=True, help="run folder (resumed if it holds a checkpoint); colour: the .onnx")
    parser.add_argument("--imitator", default=None, help="encoder: the imitator run for the rendering loss")
    parser.add_argument("--config", default=None, help="JSON file of settings")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="override one setting")
    parser.add_argument("--device", default=None, help="cpu (default) or cuda")
    args = parser.parse_args(argv)
    overrides = args.set + ([f"device={args.device}"] if args.device else [])
    if args.kind == "colour":
        from .train_colour import train_colour

        print(json.dumps(train_colour(args.data, args.out, resolve_config(ColourConfig, args.config, args.set))))
        return 0
    if args.kind == "imitator":
        from .train_imitator import train_imitator

        config = resolve_config(ImitatorConfig, args.config, overrides)
        _check_device(config.device)
        run = train_imitator(args.data, args.out, config)
    else:
        from .train_encoder import train_encoder

        config = resolve_config(EncoderConfig, args.config, overrides)
        _check_device(config.device)
        run = train_encoder(args.data, args.imitator, args.out, config)
    last = run.read_log()[-1]
    print(json.dumps({"run": str(run.path), "kind": args.kind, **last}))
    return 0


def cmd_export(argv: list[str]) -> int:
    """vto export --encoder RUN [RUN|FILE.onnx ...] [--average outputs|weights] --out encoder.onnx."""
    from .export import export_encoder

    parser = ArgumentParser(prog="vto export", description="export an encoder run to ONNX (checked against torch)")
    parser.add_argument("--encoder", required=True, nargs="+", metavar="RUN",
                        help="encoder run folder; several runs of one spec and size are averaged into one file "
                             "(after the first run, an exported encoder of its network may stand in for a run)")
    parser.add_argument("--average", choices=["outputs", "weights"], default="outputs",
                        help="outputs: read each run and average the readings (n times the time); weights: read once "
                             "through the runs' averaged weights (one network's fine-tunes of one start)")
    parser.add_argument("--out", required=True, help="the .onnx file to write")
    parser.add_argument("--opset", type=int, default=18)
    parser.add_argument("--single-view", action="store_true",
                        help="read each image once, not also its mirror (half the time; by default a run trained on "
                             "mirrored views averages both readings)")
    parser.add_argument("--smooth-input", action="store_true",
                        help="read the image through a 3x3 box filter, steadier against a framing a pixel off, though "
                             "the run was trained without one (training instead: --set input_filter=3)")
    args = parser.parse_args(argv)
    print(json.dumps(export_encoder(args.encoder, args.out, args.opset, mirror=not args.single_view,
                                    smooth=args.smooth_input, average=args.average)))
    return 0
