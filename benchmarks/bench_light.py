"""Does the estimate stay put when the photo's light changes? The product, not the light.

    python -m benchmarks.bench_light [--part renders,photos,hair] [--qualities fast,better,best] [--looks 4]
    python -m benchmarks.bench_light --calibrate

Renders: one look on one default source under several lights (the default scene's own, drawn from other source
seeds; white balances of 3,000 and 7,500 K and +-1 EV, as a camera left at daylight balance would record them:
per-channel gains on the linear render, which is linear in the light). Each goes through `vto match`'s own path
(the lips given as a mask). Figure: CIEDE2000 between the apparent colour (on default sources 0-7,
blender_addon.matching.photo_fit.apparent_colour) of the estimate under each light and under the source's own light.
Photos: the public-domain portraits of benchmarks/photos, each re-lit by a global white-balance shift (3,200 K and
7,500 K, linear RGB) and by +-0.7 EV; the figure is the CIEDE2000 of each estimate's apparent colour to the
estimate on the photo as it is. Beside the shipped qualities: the encoder on the photo as it is and the colour fit
that was Fast before (the light left in), the figures of the issue this answers. Hair: the same for each portrait's
first hand-cut hair patch (the light read from the face of the whole photo), on default hair regions 0-7.
--calibrate: the default scene's skins (vto_core.photo.photo_light.SKIN_LOG_MEAN, SKIN_LOG_COV) from 96 sources.
Writes benchmarks/results/light.md (renders) and the first sections of real_photos.md (photos, hair).
"""

from __future__ import annotations

import argparse
import json
import shlex
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from benchmarks.bench_real_photos import MODELS, PHOTOS, delta_e, load_photo
from benchmarks.common import table, write_section

CALIBRATION_SOURCES = range(910000, 910096)
RENDER_SOURCE_BASE = 920000  # the looks' sources; their other lights are the draws of the next seeds
SCENE_LIGHTS = 5  # the default scene's lights besides the source's own
RENDER_SHIFTS = {"3,000 K": (3000.0, 0.0), "7,500 K": (7500.0, 0.0), "+1 EV": (6504.0, 1.0), "-1 EV": (6504.0, -1.0)}
PHOTO_SHIFTS = {"3,200 K": (3200.0, 0.0), "7,500 K": (7500.0, 0.0), "+0.7 EV": (6504.0, 0.7),
                "-0.7 EV": (6504.0, -0.7)}
BEFORE = ("encoder, light left in", "colour fit, light left in (Fast before)")


def calibrate() -> str:
    """The mean and covariance of log linear skin RGB beside the lips over CALIBRATION_SOURCES (bare lips, 64 px)."""
    from blender_addon.renderers.product_lipstick import render_lipstick
    from blender_addon.renderers.scene_lips import lips_mask
    from vto_core.appearance import skin_colour

    skins = np.array([skin_colour(render_lipstick({"opacity": 0.0}, seed, 64, 16, 0), lips_mask(seed, 64))
                      for seed in CALIBRATION_SOURCES])
    logs = np.log(skins)
    return (f"SKIN_LOG_MEAN = np.array({np.round(logs.mean(0), 4).tolist()})\n"
            f"SKIN_LOG_COV = np.array({np.round(np.cov(logs.T), 4).tolist()})")


def lips_estimates(path: Path, mask: Path | None, qualities: list[str]) -> dict[str, dict]:
    """method -> all parameter values for the photo at `path` (its lips mask at `mask`, or found): the shipped
    qualities through blender_addon.matching.match.match, and the two readings with the photo's light left in."""
    from blender_addon.matching.match import match
    from blender_addon.matching.colour_fit import fit_colour
    from blender_addon.matching.photo_fit import photo_values
    from blender_addon.matching.reference import read_reference
    from vto_core.inference import EncoderSession

    model = str(MODELS / "lipstick_encoder.onnx")
    session = EncoderSession(model)
    spec = session.spec
    as_is = read_reference("lipstick", {"image_path": str(path), "mask_path": str(mask) if mask else "",
                                        "neutral_light": False})
    encoder = session.predict(as_is.image)[0]
    fitted = fit_colour(spec, as_is.region, {k: encoder[k] for k in spec.modelled})[0]
    found = {BEFORE[0]: encoder, BEFORE[1]: spec.full_values(photo_values(spec, fitted))}
    for quality in qualities:
        found[quality] = match(model, str(path), quality=quality, mask_path=str(mask) if mask else None)["params"]
    return found


def spread(apparent: dict[str, dict[str, np.ndarray]], reference: str) -> dict[str, dict[str, float]]:
    """method -> shift name -> CIEDE2000 of the apparent mean colour under the shift to that under `reference`."""
    methods = next(iter(apparent.values())).keys()
    return {method: {shift: delta_e(apparent[reference][method], apparent[shift][method])
                     for shift in apparent if shift != reference} for method in methods}


def run_renders(looks: int, qualities: list[str], work: Path) -> tuple[list, dict]:
    """Per look (sampled at seed 31), its estimates under each light: (rows, method -> all CIEDE2000s)."""
    from blender_addon.renderers.product_lipstick import render_lipstick
    from blender_addon.matching.photo_fit import apparent_colour
    from blender_addon.renderers.scene_lips import lips_mask
    from vto_core.imageio import write_image
    from vto_core.photo.photo_light import kelvin_gains, relit
    from vto_core.presets import load_presets, preset_matrix
    from vto_core.sampling import ParamSampler
    from vto_core.products import get_spec

    spec = get_spec("lipstick")
    sampler = ParamSampler(spec, preset_matrix(spec, load_presets("lipstick")), 0.5, 31)
    rows, pooled = [], {}
    for look in range(looks):
        values = spec.values(spec.denormalise(sampler.sample_unit(look)))
        source = RENDER_SOURCE_BASE + 16 * look
        mask = work / f"look{look}_mask.png"
        write_image(mask, np.repeat(lips_mask(source, 64)[..., None].astype(np.float32), 3, axis=2))
        lights = {"own light": render_lipstick(values, source, 64, 16, 0)}
        for k in range(1, SCENE_LIGHTS + 1):
            lights[f"scene light {k}"] = render_lipstick(values, source, 64, 16, 0, light_seed=source + k)
        for name, (kelvin, ev) in RENDER_SHIFTS.items():
            lights[name] = relit(lights["own light"], kelvin_gains(kelvin, ev))
        apparent = {}
        for name, image in lights.items():
            path = work / f"look{look}_{name.replace(' ', '_').replace(',', '')}.png"
            write_image(path, image)
            apparent[name] = {method: apparent_colour("lipstick", found)["mean"]
                              for method, found in lips_estimates(path, mask, qualities).items()}
        for method, errors in spread(apparent, "own light").items():
            pooled.setdefault(method, []).extend(errors.values())
            rows.append([look, method] + [f"{errors[name]:.1f}" for name in list(lights)[1:]])
        print(f"look {look} done", file=sys.stderr, flush=True)
    return rows, pooled


def hair_estimates(path: Path, patch, qualities: list[str]) -> dict[str, dict]:
    """method -> all parameter values for the hair patch (x, y, w, h) of the photo at `path`: the shipped qualities,
    and Fast with the photo's light left in."""
    from blender_addon.matching.match import match

    model = str(MODELS / "hair_encoder.onnx")
    found = {"Fast, light left in": match(model, str(path), crop=patch, neutral_light=False)["params"]}
    for quality in qualities:
        found[quality] = match(model, str(path), quality=quality, crop=patch)["params"]
    return found


def relit_files(record: dict, work: Path) -> dict[str, Path]:
    """The portrait of `record` as it is and under each of PHOTO_SHIFTS, written to `work`: light name -> file."""
    from vto_core.imageio import write_image
    from vto_core.photo.photo_light import kelvin_gains, relit

    photo = load_photo(record, PHOTOS.parent)
    stem = Path(record["file"]).stem.replace(":", "_").replace("/", "_")
    files = {}
    for name, (kelvin, ev) in {"as it is": (6504.0, 0.0), **PHOTO_SHIFTS}.items():
        files[name] = work / f"{stem}_{name.replace(' ', '_').replace(',', '')}.png"
        write_image(files[name], photo if name == "as it is" else relit(photo, kelvin_gains(kelvin, ev)))
    return files


def run_photos(records: list[dict], qualities: list[str], work: Path, renderer: str) -> tuple[list, dict]:
    """Per portrait, its estimates of the lips (or its first hair patch) re-lit: (rows, method -> [(its CIEDE2000s,
    held out)])."""
    from blender_addon.matching.photo_fit import apparent_colour

    rows, pooled = [], {}
    for record in records:
        if renderer == "hair" and not record.get("hair_patches"):
            continue
        apparent = {}
        for name, path in relit_files(record, work).items():
            found = (lips_estimates(path, None, qualities) if renderer == "lipstick" else
                     hair_estimates(path, tuple(record["hair_patches"][0]), qualities))
            apparent[name] = {method: apparent_colour(renderer, values)["mean"] for method, values in found.items()}
        for method, errors in spread(apparent, "as it is").items():
            pooled.setdefault(method, []).append((list(errors.values()), bool(record.get("held_out"))))
            rows.append([record["subject"], method] + [f"{errors[name]:.1f}" for name in PHOTO_SHIFTS])
        print(f"{record['subject']} done", file=sys.stderr, flush=True)
    return rows, pooled


def summary(pooled: dict[str, list[float]]) -> list[list]:
    """method -> [method, n, median, largest]."""
    return [[method, len(errors), f"{np.median(errors):.1f}", f"{np.max(errors):.1f}"]
            for method, errors in pooled.items()]


def main(argv: list[str] | None = None) -> None:
    """Run the parts asked for and write their sections of light.md."""
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--part", default="renders,photos,hair")
    parser.add_argument("--qualities", default="fast,better,best")
    parser.add_argument("--looks", type=int, default=4)
    parser.add_argument("--photos", type=int, default=0, help="only the first N portraits (default all)")
    parser.add_argument("--calibrate", action="store_true")
    args = parser.parse_args(argv)
    if args.calibrate:
        print(calibrate())
        return
    qualities = [q for q in args.qualities.split(",") if q]
    command = "python -m benchmarks.bench_light " + " ".join(shlex.quote(a) for a in (argv or sys.argv[1:]))
    reproduce = f"Reproduce: `{command.strip()}` ({time.strftime('%Y-%m-%d')})."
    header = ["method", "n", "median ΔE", "largest ΔE"]
    with tempfile.TemporaryDirectory() as scratch:
        work = Path(scratch)
        if "renders" in args.part.split(","):
            rows, pooled = run_renders(args.looks, qualities, work)
            lights = ["scene light " + str(k) for k in range(1, SCENE_LIGHTS + 1)] + list(RENDER_SHIFTS)
            write_section("light", "light-renders", "\n".join([
                "## Renders: one look on one source under other lights", "",
                f"{args.looks} looks (sampled at seed 31), each on its own default source (from {RENDER_SOURCE_BASE}),"
                " under the source's own light and under each light below; CIEDE2000 between the apparent colours "
                "(default sources 0-7) of the estimates under that light and under the source's own.", "",
                table(header, summary(pooled)), "", table(["look", "method", *lights], rows), "", reproduce, ""]))
        for part, renderer, what in (("photos", "lipstick", "lips"), ("hair", "hair", "hair (first patch)")):
            if part not in args.part.split(","):
                continue
            records = [r for r in json.loads(PHOTOS.read_text()) if r.get("lips_box")]
            records = records[:args.photos] if args.photos else records
            rows, pooled = run_photos(records, qualities, work, renderer)
            flat = {method: [e for errors, _ in found for e in errors] for method, found in pooled.items()}
            held = {method: [e for errors, out in found if out for e in errors] for method, found in pooled.items()}
            write_section("real_photos", f"real-photos-light-{renderer}", "\n".join([
                f"## The public-domain portraits re-lit: {what}", "",
                "Each portrait re-lit in linear RGB (von Kries gains from a black body at 6,504 K to 3,200 K and "
                "7,500 K, green kept; +-0.7 EV) and clipped as a camera would; CIEDE2000 between the apparent colour "
                f"(default {'sources' if renderer == 'lipstick' else 'hair regions'} 0-7) of each estimate and of the "
                "estimate on the photo as it is.", "",
                table(header, summary(flat)), "", "The held-out six alone:", "", table(header, summary(held)), "",
                table(["photo", "method", *PHOTO_SHIFTS], rows), "", reproduce, ""]))


if __name__ == "__main__":
    main()
