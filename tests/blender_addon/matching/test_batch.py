"""`vto batch` with the shipped lipstick encoder on 5 tiny renders of 2 presets plus unusable files."""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

pytestmark = [pytest.mark.blender, pytest.mark.slow]
pytest.importorskip("bpy")

from blender_addon.matching.batch import (BLANK, circular_median, csv_grouping, group_products,  # noqa: E402
                                          median_values)
from vto_core import cli  # noqa: E402
from vto_core.imageio import read_image, write_image  # noqa: E402
from vto_core.inference import EncoderSession  # noqa: E402
from vto_core.params_io import parse_params  # noqa: E402
from vto_core.presets import load_presets  # noqa: E402
from vto_core.products import LIPSTICK, get_spec  # noqa: E402

MODEL = str(Path(__file__).resolve().parents[3] / "blender_addon" / "models" / "lipstick_encoder.onnx")
RES, SAMPLES = 32, 4
PHOTOS = {"classic-red_s1": ("Classic Red", 1), "classic-red_s2": ("Classic Red", 2),
          "classic-red_s3": ("Classic Red", 3),
          "bare-nude_s1": ("Bare Nude", 1), "bare-nude_s4": ("Bare Nude", 4), "stray": ("Bare Nude", 5)}
GROUP_BY = r"^(.+)_s\d+$"
BAD = {"broken.png": "cannot read image", "tiny.png": "at least 8x8", "notes.txt": "cannot read image",
       "stray.png": "no product"}


@pytest.fixture(scope="module")
def photos(tmp_path_factory):
    """6 renders (2 presets, several sources; 'stray' matches no product) and 3 unusable files: a corrupt PNG, a 1x1
    image, a text file."""
    from blender_addon.renderers.products import render

    folder = tmp_path_factory.mktemp("batch-photos")
    presets = load_presets("lipstick")
    for stem, (preset, source) in PHOTOS.items():
        write_image(folder / f"{stem}.png", render("lipstick", presets[preset], source, RES, SAMPLES), bits=16)
    (folder / "broken.png").write_bytes(b"\x89PNG\r\n\x1a\n" + b"\x00garbage" * 10)
    write_image(folder / "tiny.png", np.full((1, 1, 3), 0.5, np.float32))
    (folder / "notes.txt").write_text("not a photo\n")
    return folder


def batch_args(photos, out, *extra):
    return ["batch", "--model", MODEL, "--images", str(photos), "--out", str(out), "--group-by", GROUP_BY,
            "--res", str(RES), "--samples", str(SAMPLES), "--quiet", *extra]


@pytest.fixture(scope="module")
def batch_out(photos, tmp_path_factory):
    """OUT of one `vto batch` run over the photos."""
    out = tmp_path_factory.mktemp("batch-out") / "out"
    assert cli.run(batch_args(photos, out)) == 0
    return out


def photo_estimate(session, renderer: str, path: Path) -> dict:
    """What the panel's Fast gives a photo: its lips (or hair) read, the encoder, the colour imitator's fit."""
    from blender_addon.matching.batch import batch_reference, fast_values

    reference = batch_reference(renderer, path)
    return fast_values(session.spec, reference, session.predict_views([reference.images])[0])


def test_presets_are_the_medians_of_the_per_image_estimates(photos, batch_out):
    session = EncoderSession(MODEL)
    written = load_presets("lipstick", batch_out / "presets.json")
    assert sorted(written) == ["bare-nude", "classic-red"]
    for product in written:
        estimates = [photo_estimate(session, "lipstick", photos / f"{stem}.png") for stem in PHOTOS
                     if stem.startswith(product)]
        expected = {k: float(np.median([e[k] for e in estimates])) for k in estimates[0]}
        assert written[product] == pytest.approx(expected, abs=1e-9)
    csv_lines = (batch_out / "presets.csv").read_text().splitlines()
    assert csv_lines[0].split(",") == ["name", *get_spec("lipstick").by_name] and len(csv_lines) == 3


def test_report_lists_the_unusable_files_and_the_products(batch_out):
    report = json.loads((batch_out / "report.json").read_text())
    reasons = {row["image"]: row["reason"] for row in report["skipped"]}
    assert set(reasons) == set(BAD) and all(BAD[name] in reasons[name] for name in BAD)
    assert report["products"] == {"classic-red": ["classic-red_s1.png", "classic-red_s2.png", "classic-red_s3.png"],
                                  "bare-nude": ["bare-nude_s1.png", "bare-nude_s4.png"]}
    assert report["estimated"] == 6 and report["cached"] == 0
    assert sorted(p.name for p in (batch_out / "estimates").iterdir()) == sorted(f"{s}.png.json" for s in PHOTOS)


def test_contact_sheet_has_one_row_per_product(batch_out):
    sheet, _ = read_image(batch_out / "sheet.png")
    assert sheet.shape == (2 * RES, 3 * RES, 3) and sheet.std() > 0.01  # photo | try-on | render
    report = json.loads((batch_out / "report.json").read_text())
    assert report["sheet_columns"] == ["photo", "try-on", "render"]
    # close-ups of lips (renders): no face to try the preset on, so the try-on column is the grey blank
    assert sorted(report["sheet_no_tryon"]) == ["bare-nude", "classic-red"]
    assert all(reason.startswith("no face found") for reason in report["sheet_no_tryon"].values())
    assert np.all(np.abs(sheet[:, RES:2 * RES] - BLANK) < 1 / 255)


def test_contact_sheet_tries_the_preset_on_a_portraits_lips_and_leaves_a_grey_blank_without_a_face(photos, tmp_path):
    """A portrait's row: its photo around the lips | the preset tried on them (the same pixels off the lips); a close-up
    of lips (no face) in the same batch: the grey blank, and the batch still writes its sheet."""
    import skimage.data

    from blender_addon.renderers.tryon import around_region, find_lips
    from vto_core.photo.framing import view_cut
    from vto_core.photo.tryon import feathered

    folder, res = tmp_path / "photos", 64
    folder.mkdir()
    portrait = skimage.data.astronaut().astype(np.float32) / 255  # 512 px: lips 48 px wide, wide enough to try on
    write_image(folder / "a_portrait.png", portrait)
    (folder / "b_closeup.png").write_bytes((photos / "classic-red_s1.png").read_bytes())
    out = tmp_path / "out"
    assert cli.run(["batch", "--model", MODEL, "--images", str(folder), "--out", str(out), "--res", str(res),
                    "--samples", str(SAMPLES), "--quiet"]) == 0
    report = json.loads((out / "report.json").read_text())
    assert report["sheet_rows"] == ["a_portrait", "b_closeup"] and list(report["sheet_no_tryon"]) == ["b_closeup"]
    sheet, _ = read_image(out / "sheet.png")
    assert sheet.shape == (2 * res, 3 * res, 3)
    photo, worn = sheet[:res, :res], sheet[:res, res:2 * res]
    lips = find_lips(portrait, LIPSTICK)
    view = around_region(lips, res)
    assert np.abs(photo - view_cut(portrait, view, res)).max() < 1 / 255  # the photo framed as the previews frame it
    reach = view_cut(feathered(lips.mask), view, res)[..., 0] > 0  # where the try-on may draw
    inside = view_cut(lips.mask, view, res)[..., 0] > 0.5
    changed = np.abs(worn - photo).max(axis=-1) > 1.5 / 255
    assert not changed[~reach].any()  # off the lips: the photo's pixels
    assert changed[inside].mean() > 0.5 and np.abs(worn - photo)[inside].mean() > 0.02  # on them: the preset
    assert np.all(np.abs(sheet[res:, res:2 * res] - BLANK) < 1 / 255)  # no face: the grey blank


def test_asset_library_has_one_marked_material_per_product_with_preview_and_catalog(batch_out):
    script = """
import bpy, json, sys
import numpy as np
bpy.ops.wm.open_mainfile(filepath=sys.argv[-1])
rows = {}
for m in bpy.data.materials:
    size = tuple(m.preview.image_size) if m.preview else (0, 0)
    pixels = np.zeros(size[0] * size[1] * 4, np.float32)
    if m.preview:
        m.preview.image_pixels_float.foreach_get(pixels)
    group = m.node_tree.nodes["VTO Lipstick"]
    rows[m.name] = {"asset": m.asset_data is not None, "catalog": m.asset_data.catalog_id,
                    "tags": [t.name for t in m.asset_data.tags], "size": size, "std": float(pixels.std()),
                    "red": group.inputs["Red"].default_value, "linked": group.inputs["Lips"].is_linked
                    and m.node_tree.nodes["Material Output"].inputs["Surface"].is_linked}
print("ROWS" + json.dumps(rows))
"""
    done = subprocess.run([sys.executable, "-c", script, str(batch_out / "assets.blend")], capture_output=True,
                          text=True, timeout=120)
    rows = json.loads(next(line[4:] for line in done.stdout.splitlines() if line.startswith("ROWS")))
    catalogs = [line for line in (batch_out / "blender_assets.cats.txt").read_text().splitlines()
                if line and not line.startswith(("#", "VERSION"))]
    assert len(catalogs) == 1 and "VERSION 1" in (batch_out / "blender_assets.cats.txt").read_text()
    presets = load_presets("lipstick", batch_out / "presets.json")
    assert sorted(rows) == sorted(presets)
    for name, row in rows.items():
        assert row["asset"] and row["catalog"] == catalogs[0].split(":")[0] and row["linked"]
        assert {"lipstick", name} <= set(row["tags"]) and tuple(row["size"]) == (RES, RES) and row["std"] > 0.01
        assert row["red"] == pytest.approx(presets[name]["red"], abs=1e-3)
    assert not list(batch_out.glob(".tmp-*"))


def test_a_rerun_reuses_the_cached_estimates(photos, batch_out, capsys):
    before = {p.name: p.stat().st_mtime_ns for p in (batch_out / "estimates").iterdir()}
    presets = (batch_out / "presets.json").read_text()
    assert cli.run(batch_args(photos, batch_out)) == 0
    captured = capsys.readouterr()
    printed = json.loads(captured.out.strip().splitlines()[-1])
    assert printed["cached"] == 6 and printed["estimated"] == 6 and printed["skipped"] == 4
    assert {p.name: p.stat().st_mtime_ns for p in (batch_out / "estimates").iterdir()} == before
    assert (batch_out / "presets.json").read_text() == presets
    assert sum(line.startswith("vto batch: skipped ") for line in captured.err.splitlines()) == 4
    assert "\r" not in captured.err


def test_render_takes_an_output_preset(batch_out, tmp_path, capsys):
    image = tmp_path / "red.png"
    preset = f"preset:classic-red@{batch_out / 'presets.json'}"
    render_args = ["render", "lipstick", "--params", preset, "--res", "16", "--samples", "2", "--out", str(image)]
    assert cli.run(render_args) == 0
    assert read_image(image)[0].shape == (16, 16, 3)
    assert parse_params(preset, "lipstick") == load_presets("lipstick", batch_out / "presets.json")["classic-red"]
    assert cli.run(["render", "lipstick", "--params", f"preset:nope@{batch_out / 'presets.json'}", "--out",
                    str(image)]) == 2


@pytest.mark.parametrize("case", ["missing dir", "empty dir", "bad regex", "bad csv", "missing model",
                                  "both groupings"])
def test_bad_input_is_one_line_exit_2_and_writes_nothing(case, photos, tmp_path, capsys):
    out, csv_path = tmp_path / "out", tmp_path / "groups.csv"
    csv_path.write_text("file,name\na.png,x\n")
    (tmp_path / "empty").mkdir()
    args = {"missing dir": ["--images", str(tmp_path / "nowhere")], "empty dir": ["--images", str(tmp_path / "empty")],
            "bad regex": ["--group-by", "(unclosed"], "bad csv": ["--groups", str(csv_path)],
            "missing model": ["--model", str(tmp_path / "none.onnx")],
            "both groupings": ["--group-by", "x", "--groups", str(csv_path)]}[case]
    base = {"--model": MODEL, "--images": str(photos), "--out": str(out)}
    for key in args[::2]:
        base.pop(key, None)
    argv = ["batch", *[x for pair in base.items() for x in pair], *args, "--quiet"]
    assert cli.run(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("vto batch: error: ")
    assert not out.exists()


def test_groups_csv_and_circular_median(tmp_path):
    csv_path = tmp_path / "groups.csv"
    csv_path.write_text("image,product\na.png,Red\nb,Red\nc.jpg,Nude\n")
    images = [tmp_path / name for name in ("a.png", "b.png", "c.jpg", "d.png")]
    products, unclaimed = group_products(images, csv_grouping(str(csv_path)))
    assert products == {"Red": images[:2], "Nude": images[2:3]} and [u["image"] for u in unclaimed] == ["d.png"]
    assert circular_median([0.95, 0.02, 0.05], 0.0, 1.0) == 0.02  # not the linear median 0.05
    spec = get_spec("hair")
    rows = [spec.full_values({"hue": h, "gamma": g}) for h, g in ((0.9, 1.0), (0.05, 2.0), (0.98, 3.0))]
    medians = median_values(spec, rows)
    assert medians["hue"] == 0.98 and medians["gamma"] == 2.0


def tiny_hair_encoder(path: Path) -> str:
    """An ONNX 'encoder' of the hair spec: sigmoid(mean colour @ W + b), 16 px input, with the vto metadata."""
    import onnx
    from onnx import TensorProto, helper, numpy_helper

    spec = get_spec("hair")
    rng = np.random.default_rng(0)
    weights = numpy_helper.from_array(rng.normal(0, 4, (3, spec.size)).astype(np.float32), "W")
    bias = numpy_helper.from_array(rng.normal(0, 1, spec.size).astype(np.float32), "b")
    graph = helper.make_graph(
        [helper.make_node("GlobalAveragePool", ["image"], ["pooled"]),
         helper.make_node("Flatten", ["pooled"], ["flat"]),
         helper.make_node("MatMul", ["flat", "W"], ["mixed"]), helper.make_node("Add", ["mixed", "b"], ["shifted"]),
         helper.make_node("Sigmoid", ["shifted"], ["params_unit"])], "tiny",
        [helper.make_tensor_value_info("image", TensorProto.FLOAT, ["N", 3, 16, 16])],
        [helper.make_tensor_value_info("params_unit", TensorProto.FLOAT, ["N", spec.size])], [weights, bias])
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)])
    model.ir_version = 8
    helper.set_model_props(model, {"vto.spec": spec.to_json(), "vto.input_size": "16x16", "vto.renderer": "hair"})
    onnx.save(model, path)
    return str(path)


def test_hair_batch_takes_circular_medians_and_skips_the_asset_library(tmp_path):
    from vto_core.products import HAIR
    from blender_addon.renderers.hair import render_hair_source, run_hair_stage

    photos, presets = tmp_path / "photos", load_presets("hair")
    photos.mkdir()
    for stem, (preset, seed) in {"copper_a": ("Copper Red", 1), "copper_b": ("Copper Red", 2),
                                 "teal_a": ("Teal Fashion", 1)}.items():
        source = render_hair_source(seed, RES, SAMPLES)
        write_image(photos / f"{stem}.png", run_hair_stage(source, presets[preset]), bits=16)
        if stem == "copper_a":  # a photo with its mask: the mask is no photo, and the photo is its product's source
            write_image(photos / f"{stem}_mask.png", source.mask)
    model, out = tiny_hair_encoder(tmp_path / "hair.onnx"), tmp_path / "out"
    assert cli.run(["batch", "--model", model, "--images", str(photos), "--out", str(out), "--group-by", r"^[a-z]+",
                    "--res", str(RES), "--samples", str(SAMPLES), "--quiet"]) == 0
    report = json.loads((out / "report.json").read_text())
    assert report["products"] == {"copper": ["copper_a.png", "copper_b.png"], "teal": ["teal_a.png"]}
    assert report["skipped"] == [] and report["asset_library"] is None
    assert report["asset_library_skipped"] == HAIR.no_library and not (out / "assets.blend").exists()
    session, spec = EncoderSession(model), get_spec("hair")
    estimates = [photo_estimate(session, "hair", photos / name) for name in report["products"]["copper"]]
    assert all((e["intensity"], e["blend"]) == (1.0, -1.0) for e in estimates)  # a photo: full effect
    written = load_presets("hair", out / "presets.json")["copper"]
    assert written["hue"] == circular_median([e["hue"] for e in estimates], 0.0, 1.0)
    assert written == pytest.approx(median_values(spec, estimates))
    assert read_image(out / "sheet.png")[0].shape == (2 * RES, 3 * RES, 3)  # a try-on column, grey for hair
    assert report["sheet_no_tryon"] == {"copper": "hair has no try-on yet", "teal": "hair has no try-on yet"}


def test_hair_batch_finds_the_hair_in_portraits_and_a_mask_beside_a_photo_wins(tmp_path):
    import skimage.data

    from blender_addon.matching.batch import batch_reference

    photos = tmp_path / "photos"
    photos.mkdir()
    portrait = skimage.data.astronaut().astype(np.float32) / 255
    for stem in ("found", "painted"):
        write_image(photos / f"{stem}.png", portrait)
    painted = np.zeros((512, 512), np.float32)
    painted[20:90, 150:230] = 1.0  # her hair patch, painted by hand
    write_image(photos / "painted_mask.png", painted)
    found, masked = (batch_reference("hair", photos / f"{stem}.png") for stem in ("found", "painted"))
    assert found.hair is not None and found.notes[0].startswith("hair found: ")
    assert masked.hair is None and np.array_equal(masked.region[1] > 0.5, painted > 0.5)
    model = str(Path(__file__).resolve().parents[3] / "blender_addon" / "models" / "hair_encoder.onnx")
    out = tmp_path / "out"
    assert cli.run(["batch", "--model", model, "--images", str(photos), "--out", str(out), "--group-by", r"^[a-z]+",
                    "--quiet"]) == 0
    report = json.loads((out / "report.json").read_text())
    assert report["products"] == {"found": ["found.png"], "painted": ["painted.png"]} and report["skipped"] == []
    session = EncoderSession(model)
    presets = load_presets("hair", out / "presets.json")
    assert presets["found"] == pytest.approx(photo_estimate(session, "hair", photos / "found.png"), abs=1e-4)
    assert presets["found"] != pytest.approx(presets["painted"], abs=1e-3)


def test_a_photo_stored_sideways_is_estimated_as_it_is_shown(photos, tmp_path):
    """A phone's JPEG keeps its pixels sideways and says so in its EXIF Orientation: batch reads it upright."""
    folder = tmp_path / "phone"
    folder.mkdir()
    upright = read_image(photos / "classic-red_s1.png")[0]
    write_image(folder / "upright_s1.tif", upright)
    write_image(folder / "sideways_s1.tif", np.rot90(upright, 1), orientation=6)  # as a phone held upright stores it
    out = tmp_path / "out"
    assert cli.run(["batch", "--model", MODEL, "--images", str(folder), "--out", str(out), "--group-by",
                    r"^(.+)_s\d+", "--res", str(RES), "--samples", str(SAMPLES), "--quiet"]) == 0
    written = load_presets("lipstick", out / "presets.json")
    assert written["sideways"] == pytest.approx(written["upright"], abs=1e-6)


LIBRARY_ROWS = """
import bpy, json, sys
bpy.ops.wm.open_mainfile(filepath=sys.argv[-2])
rows = {}
for m in bpy.data.materials:
    group = m.node_tree.nodes[sys.argv[-1]]
    rows[m.name] = {"catalog": m.asset_data.catalog_id, "tags": [t.name for t in m.asset_data.tags],
                    "inputs": {s.name: s.default_value for s in group.inputs if s.type == "VALUE"},
                    "wired": group.inputs[0].is_linked
                    and m.node_tree.nodes["Material Output"].inputs["Surface"].is_linked}
print("ROWS" + json.dumps(rows))
"""


def library_rows(path: Path, group: str) -> dict:
    """Each material of the asset library `path` (read by another Blender): its catalog, tags, `group`'s inputs."""
    done = subprocess.run([sys.executable, "-c", LIBRARY_ROWS, str(path), group], capture_output=True, text=True,
                          timeout=120)
    return json.loads(next(line[4:] for line in done.stdout.splitlines() if line.startswith("ROWS")))


def assert_library_holds(rows: dict, presets: dict, folder: Path) -> None:
    """One eye-shadow asset material a preset, in the Eye Shadow catalog, its group's inputs the preset's values."""
    from blender_addon.datasets.assets import catalog_id

    spec = get_spec("eyeshadow")
    assert sorted(rows) == sorted(presets) and "Match from photo/Eye Shadow" in (
        folder / "blender_assets.cats.txt").read_text()
    for name, row in rows.items():
        assert row["catalog"] == catalog_id("Match from photo/Eye Shadow") and row["wired"]
        assert {"eyeshadow", name} <= set(row["tags"])
        expected = spec.full_values(presets[name])
        assert {p.name: row["inputs"][p.socket] for p in spec.params} == pytest.approx(expected, abs=1e-4), name


@pytest.mark.torch
def test_eyeshadow_batch_reads_both_eyes_of_portraits_and_writes_its_presets_as_asset_materials(tmp_path,
                                                                                                eyeshadow_encoder):
    """Portraits wearing eye shadow (tried on the astronaut and Grace Hopper) with a tiny trained encoder: both eyes'
    lids found and read, a preset per product, the medians of its photos' estimates, each an asset material, and the
    sheet's try-on column."""
    import matplotlib.cbook
    import skimage.data

    from blender_addon.matching.batch import batch_reference
    from blender_addon.renderers.tryon import tryon_product
    from vto_core.products import EYESHADOW

    faces = {"astronaut": skimage.data.astronaut().astype(np.float32) / 255,
             "hopper": read_image(matplotlib.cbook.get_sample_data("grace_hopper.jpg", asfileobj=False))[0]}
    photos, shades = tmp_path / "photos", load_presets("eyeshadow")
    photos.mkdir()
    for stem, (shade, face) in {"plum_1": ("Plum", "astronaut"), "plum_2": ("Plum", "hopper"),
                                "gold_1": ("Gold Leaf", "astronaut")}.items():
        write_image(photos / f"{stem}.png", tryon_product(EYESHADOW, faces[face], shades[shade], samples=2))
    out = tmp_path / "out"
    assert cli.run(["batch", "--model", eyeshadow_encoder, "--images", str(photos), "--out", str(out), "--group-by",
                    r"^([a-z]+)_", "--res", "16", "--samples", "1", "--quiet"]) == 0
    report = json.loads((out / "report.json").read_text())
    assert report["renderer"] == "eyeshadow" and report["skipped"] == []
    assert report["products"] == {"gold": ["gold_1.png"], "plum": ["plum_1.png", "plum_2.png"]}
    session = EncoderSession(eyeshadow_encoder)
    presets = load_presets("eyeshadow", out / "presets.json")
    for product, names in report["products"].items():
        for name in names:  # both eyes read, each framed as the default eye scene frames one
            reference = batch_reference("eyeshadow", photos / name)
            assert reference.region is not None and len(reference.images) == 2
        estimates = [photo_estimate(session, "eyeshadow", photos / name) for name in names]
        assert presets[product] == pytest.approx(median_values(session.spec, estimates), abs=1e-9)
    assert presets["plum"] != pytest.approx(presets["gold"], abs=1e-3)
    assert EYESHADOW.kind.asset_library and report["asset_library"] == str(out / "assets.blend")
    assert_library_holds(library_rows(out / "assets.blend", "VTO Eye Shadow"), presets, out)
    assert report["sheet_no_tryon"] == {} and report["sheet_columns"] == ["photo", "try-on", "render"]


def test_the_shipped_eyeshadow_presets_become_an_asset_library(tmp_path):
    """write_library of the eye shadow: a material a shipped preset, its inputs the preset's values."""
    from blender_addon.datasets.assets import write_library
    from vto_core.products import EYESHADOW

    presets = load_presets("eyeshadow")
    preview = np.linspace(0, 1, 8 * 8 * 3, dtype=np.float32).reshape(8, 8, 3)
    written = write_library(tmp_path / "eyeshadow.blend", {name: (values, preview, []) for name, values in
                                                           presets.items()}, "the shipped shades", EYESHADOW)
    assert written == {name: name for name in presets}
    assert_library_holds(library_rows(tmp_path / "eyeshadow.blend", "VTO Eye Shadow"), presets, tmp_path)
