"""How the default lips scene's lighting decides the colour an encoder can learn (issue: "Match gives the shade").

The same looks and sources rendered under each lighting (`vto dataset lipstick --seed S --lighting L`), packed with
bench_encoder_scaling's `pack`, then one small CNN trained the same way on each (graphics loss, mirrored/shifted
views, bench_encoder_scaling.train_once) for each training size; --network adds deeper nets, BatchNorm, other
views and other lengths of training, and a colour column for held-out looks with teeth painted in. Reported on
the held-out last --val looks: the median colour error in 8-bit steps (|R|, |G| and |B| errors pooled) on looks
with opacity >= 0.5, and the mean errors of opacity, gloss and reflection as a share of their encoded ranges.

    python -m benchmarks.bench_encoder_scaling pack --data data/lip64_wide --out wide.npz
    python -m benchmarks.bench_encoder_scaling pack --data data/lip64_portrait --out portrait.npz
    python -m benchmarks.bench_lighting --packed wide=wide.npz --packed portrait=portrait.npz --sizes 500,1000
    python -m benchmarks.bench_lighting --packed portrait=p24k.npz --sizes 3000,24000 --section lighting-looks
    python -m benchmarks.bench_lighting --packed portrait=p24k.npz --sizes 22600 --section lighting-network \\
        --network plain=0:0:augment --network bn=1:1:augment --network bn-mouth=1:1:mouth --steps 9000 \\
        --network bn-long=1:1:augment:18000
"""

from __future__ import annotations

import argparse
import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from benchmarks.bench_encoder_scaling import VIEWS, train_once
from benchmarks.common import RESULTS, table, write_section

OPAQUE = 0.5  # colour error is read on looks at least this opaque: a sheer look barely shows its colour


def colour_and_other_errors(errors: np.ndarray, truth: np.ndarray, names: list[str]) -> dict[str, float]:
    """errors, truth: (n, m) unit-range absolute errors and true unit values -> the reported figures."""
    column = {name: i for i, name in enumerate(names)}
    opaque = truth[:, column["opacity"]] >= OPAQUE if "opacity" in column else np.ones(len(truth), bool)
    colour = errors[opaque][:, [column[c] for c in ("red", "green", "blue")]] * 255.0  # R, G, B span [0, 255]
    figures = {"colour_median_255": float(np.median(colour)), "opaque_looks": int(opaque.sum())}
    for name in ("opacity", "gloss", "reflection"):
        if name in column:
            figures[f"{name}_mae"] = float(errors[:, column[name]].mean())
    return figures


@dataclass(frozen=True)
class Network:
    """One encoder set-up to train: extra 3x3 convolutions per level, BatchNorm, the training views (VIEWS) and
    its optimiser steps (0: --steps)."""

    name: str
    blocks: int = 0
    batch_norm: bool = False
    views: str = "augment"
    steps: int = 0

    @classmethod
    def parse(cls, text: str) -> "Network":
        """NAME=BLOCKS:BATCH_NORM:VIEWS[:STEPS], e.g. bn=1:1:photo or bn-long=1:1:photo:18000."""
        try:
            name, rest = text.split("=", 1)
            blocks, batch_norm, views, *steps = rest.split(":")
            if views not in VIEWS:
                raise ValueError(f"views is one of {', '.join(VIEWS)}")
            return cls(name, int(blocks), batch_norm in ("1", "true"), views, int(steps[0]) if steps else 0)
        except (ValueError, IndexError) as exc:
            raise SystemExit(f"--network {text}: expected NAME=BLOCKS:BATCH_NORM:VIEWS[:STEPS] ({exc})") from None


PLAIN = Network("plain")


def run(packed: list[tuple[str, str]], sizes: list[int], steps: int, val: int, width: int, device: str,
        results: Path, section: str = "lighting-colour", networks: tuple[Network, ...] = (PLAIN,)) -> list[dict]:
    """Train and measure each (lighting, network, size); write `section` of RESULTS/lighting.md; returns the rows as
    dicts. Held-out looks are also read with teeth painted in (training.data.open_mouths)."""
    import torch

    from vto_core.specs import RendererSpec

    rows, found = [], []
    for name, path in packed:
        with np.load(path) as archive:
            spec = RendererSpec.from_dict(json.loads(str(archive["spec"])))
            renders = torch.from_numpy(archive["renders"]).permute(0, 3, 1, 2).contiguous().to(device)
            units = torch.from_numpy(archive["units"]).to(device)
            manifest = json.loads(str(archive["manifest"]))
        wraps = torch.tensor([p.wraps for p in spec.modelled_params], device=device)
        held_out = (renders[-val:], units[-val:])
        truth = units[-val:].cpu().numpy()
        for network in networks:
            network_steps = network.steps or steps
            for size in [n for n in sizes if n <= len(units) - val]:
                figures = train_once((renders, units), held_out, wraps, size, width, network_steps, device,
                                     network.views, network.blocks, network.batch_norm, open_mouth_errors=True)
                open_mouths = colour_and_other_errors(figures.pop("open_mouth_errors"), truth, list(spec.modelled))
                result = {"lighting": name, "network": network.name, "looks": size, "steps": network_steps,
                          **colour_and_other_errors(figures.pop("errors"), truth, list(spec.modelled)),
                          "open_mouth_colour_median_255": open_mouths["colour_median_255"],
                          "seconds": round(figures["seconds"], 1), "res": manifest["res"], "spp": manifest["samples"]}
                print(json.dumps(result), flush=True)
                found.append(result)
                rows.append([name, network.name, size, result["steps"], f"{result['colour_median_255']:.1f}",
                             f"{result['open_mouth_colour_median_255']:.1f}", f"{result.get('opacity_mae', 0):.3f}",
                             f"{result.get('gloss_mae', 0):.3f}", f"{result.get('reflection_mae', 0):.3f}"])
    first = found[0] if found else {"res": "?", "spp": "?"}
    described = "; ".join(f"{n.name}: {n.blocks} extra 3x3 convolution(s) a level, "
                          f"{'BatchNorm' if n.batch_norm else 'no BatchNorm'}, {n.views} views" for n in networks)
    write_section("lighting", section, (
        f"## Colour error against the lips scene's lighting, the network and the looks ({first['res']} px, "
        f"{first['spp']} spp)\n\n"
        f"Same looks and sources under each lighting; one CNN (width {width}, 4 levels) per row, graphics loss, "
        f"batch 16, Adam lr 1e-3 with cosine decay; {described} (views: `benchmarks.bench_encoder_scaling.VIEWS`). "
        f"Held-out: the last {val} looks of each set. Colour: median |error| of R, G and B in 8-bit steps on held-out "
        f"looks with opacity >= {OPAQUE}, as rendered and with teeth painted over the mouth line "
        f"(training.data.open_mouths, the same painter the mouth views train with); the others: mean |error| as a "
        f"share of the encoded range.\n\n"
        + table(["lighting", "network", "training looks", "steps", "colour error /255", "colour, open mouths /255",
                 "opacity", "gloss", "reflection"], rows)
        + "\n\nReproduce: see `python -m benchmarks.bench_lighting --help`."), results=results)
    return found


def main() -> None:
    """python -m benchmarks.bench_lighting --packed NAME=FILE.npz ... [--sizes 500,1000] [--device cuda]."""
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--packed", action="append", required=True, metavar="LIGHTING=FILE.npz")
    parser.add_argument("--sizes", default="1000,3500")
    parser.add_argument("--steps", type=int, default=3000)
    parser.add_argument("--val", type=int, default=300)
    parser.add_argument("--width", type=int, default=32)
    parser.add_argument("--device", default="cpu")
    parser.add_argument("--results", default=str(RESULTS))
    parser.add_argument("--section", default="lighting-colour", help="the section of lighting.md to (re)write")
    parser.add_argument("--network", action="append", type=Network.parse,
                        metavar="NAME=BLOCKS:BATCH_NORM:VIEWS[:STEPS]",
                        help="an encoder set-up to train (repeatable; default: plain=0:0:augment)")
    args = parser.parse_args()
    run([tuple(item.split("=", 1)) for item in args.packed], [int(v) for v in args.sizes.split(",")], args.steps,
        args.val, args.width, args.device, Path(args.results), args.section, tuple(args.network or [PLAIN]))


if __name__ == "__main__":
    main()
