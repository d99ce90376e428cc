"""`vto match` on a tiny encoder and imitator: the estimate, refinement by render search and imitator, bad inputs."""

import json
import re
import sys
from pathlib import Path

import numpy as np
import pytest

pytestmark = [pytest.mark.blender, pytest.mark.torch, pytest.mark.slow]
pytest.importorskip("bpy")
pytest.importorskip("torch")

from blender_addon.matching.match import NO_SOURCE, SourceRenderer, match, own_source  # noqa: E402
from blender_addon.matching.refine import into_box, refine_by_render  # noqa: E402
from vto_core import cli  # noqa: E402
from vto_core.errors import VtoError  # noqa: E402
from vto_core.imageio import read_image, write_image  # noqa: E402
from vto_core.inference import EncoderSession  # noqa: E402
from vto_core.metrics import mse  # noqa: E402
from vto_core.params_io import parse_params  # noqa: E402
from vto_core.products import HAIR, LIPSTICK, get_spec  # noqa: E402

PARAMS = "opacity,red,green,blue"
SPEC = get_spec("lipstick", PARAMS)
RES, SAMPLES, SOURCE = 16, 2, 3


@pytest.fixture(scope="module")
def models(tmp_path_factory):
    """A tiny encoder (.onnx) and imitator run, trained for a few steps on 6 real renders: (encoder, imitator)."""
    from blender_addon.datasets.commands import cmd_dataset
    from training.config import EncoderConfig, ImitatorConfig, resolve_config
    from training.export import export_encoder
    from training.train_encoder import train_encoder
    from training.train_imitator import train_imitator

    folder = tmp_path_factory.mktemp("match-models")
    assert cmd_dataset(["lipstick", "--out", str(folder / "data"), "--n", "6", "--seed", "5", "--res", str(RES),
                        "--samples", str(SAMPLES), "--params", PARAMS, "--quiet"]) == 0
    common = ["perceptual=ssim_l1", "batch_size=6", "val_fraction=0", "lr=0.003"]
    run = train_encoder(str(folder / "data"), None, str(folder / "encoder"), resolve_config(
        EncoderConfig, None, common + ["width=8", "n_layers=2", "pool_size=1", "loss=graphics", "steps=10"]))
    export_encoder(str(run.path), str(folder / "encoder.onnx"))
    train_imitator(str(folder / "data"), str(folder / "imitator"), resolve_config(
        ImitatorConfig, None, common + ["width=8", "n_down=1", "n_res=1", "critic_width=8", "critic_layers=2",
                                        "use_gan=false", "use_sensitivity=false", "steps=10"]))
    return str(folder / "encoder.onnx"), str(folder / "imitator")


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """A red lipstick rendered on default-scene source 3 (Cycles seed 0), saved as a 16-bit PNG."""
    from blender_addon.renderers.products import render

    path = tmp_path_factory.mktemp("match-reference") / "reference.png"
    write_image(path, render("lipstick", {"opacity": 0.9, "red": 200.0, "green": 30.0, "blue": 60.0}, SOURCE, RES,
                             SAMPLES, 0), bits=16)
    return str(path)


def unit_renderer(on_source):
    return lambda unit: on_source(SPEC.values(SPEC.denormalise(unit)))


def in_range(values: dict) -> bool:
    return all(SPEC.by_name[k].low <= values[k] <= SPEC.by_name[k].high for k in SPEC.modelled)


def test_match_writes_the_encoders_estimate_in_the_presets_format(models, reference, tmp_path, capsys):
    encoder, _ = models
    out = tmp_path / "params.json"
    assert cli.run(["match", "--model", encoder, "--image", reference, "--whole-image", "--out-params", str(out)]) == 0
    printed = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    expected = EncoderSession(encoder).predict(read_image(reference)[0])[0]
    written = parse_params(str(out), "lipstick")  # what `vto render --params FILE` reads
    assert written == pytest.approx(expected) and printed["params"] == pytest.approx(expected)
    assert set(written) == set(get_spec("lipstick").by_name) and printed["refined"] is False
    assert get_spec("lipstick").check_values(written) == pytest.approx(written)  # every value inside its range


@pytest.mark.parametrize("refine", ["render:4", "imitator:2"])
def test_refinement_without_a_source_says_so_and_keeps_the_estimate(refine, models, reference, tmp_path, capsys):
    encoder, imitator = models
    out = tmp_path / "params.json"
    assert cli.run(["match", "--model", encoder, "--image", reference, "--whole-image", "--refine", refine,
                    "--imitator", imitator, "--out-params", str(out)]) == 0
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"vto match: {NO_SOURCE}"]
    expected = EncoderSession(encoder).predict(read_image(reference)[0])[0]
    assert parse_params(str(out), "lipstick") == pytest.approx(expected)


def test_into_box_wraps_hue_and_clips_the_rest():
    unit = into_box(np.array([1.25, -0.25, 1.5, -0.5]), np.array([True, True, False, False]))
    assert unit == pytest.approx([0.25, 0.75, 1.0, 0.0])


@pytest.mark.parametrize("budget", [1, 7])
def test_render_search_spends_its_budget_exactly_stays_in_range_and_never_worsens(budget, reference):
    """Counted renders equal the budget; the result re-renders to its reported objective, no worse than the start."""
    target = read_image(reference)[0]
    on_source = SourceRenderer("lipstick", SOURCE, RES, SAMPLES, 0)
    render_unit = unit_renderer(on_source)
    start = np.ones(SPEC.size)  # white, fully opaque: far from the red reference
    refined = refine_by_render(render_unit, target, start, budget, seed=0)
    assert on_source.renders == refined.renders == budget
    assert ((0 <= refined.unit) & (refined.unit <= 1)).all()
    assert refined.start_loss == pytest.approx(mse(render_unit(start), target))
    assert refined.loss == pytest.approx(mse(render_unit(refined.unit), target))  # one Cycles seed: deterministic
    if budget == 1:
        assert refined.loss == refined.start_loss and refined.unit == pytest.approx(start)
    else:
        assert refined.loss < refined.start_loss  # 6 renders around a white start find something redder


def test_held_dimensions_render_at_their_value_stay_out_of_the_search_and_keep_the_start():
    seen = []
    target = np.array([0.2, 0.7, 0.4])

    def render_unit(unit):
        seen.append(np.array(unit))
        return np.full((4, 4, 3), np.abs(unit - target).sum(), np.float32)

    start = np.array([0.5, 0.5, 0.5])
    refined = refine_by_render(render_unit, np.zeros((4, 4, 3), np.float32), start, 30, held={1: 0.9})
    assert refined.renders == 30 == len(seen)
    assert all(u[1] == 0.9 for u in seen)  # rendered at the held value, never searched
    assert refined.unit[1] == 0.5  # the start's value stands
    assert refined.loss < refined.start_loss and abs(refined.unit[0] - 0.2) < abs(0.5 - 0.2)


def test_match_refines_through_the_renderer_and_the_imitator(models, reference, tmp_path, capsys):
    encoder, imitator = models
    by_render = match(encoder, reference, source=str(SOURCE), refine="render:5", samples=SAMPLES)
    assert by_render["refined"] and by_render["renders"] == 5 and in_range(by_render["params"])
    assert by_render["loss"] <= by_render["loss_start"]
    from_mean = match(encoder, reference, source=str(SOURCE), refine="render:3", samples=SAMPLES, start_at="mean")
    assert from_mean["renders"] == 3 and from_mean["loss"] <= from_mean["loss_start"] != by_render["loss_start"]
    out = tmp_path / "params.json"
    assert cli.run(["match", "--model", encoder, "--image", reference, "--source", str(SOURCE), "--refine",
                    "imitator:4", "--imitator", imitator, "--samples", str(SAMPLES), "--out-params", str(out)]) == 0
    printed = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert printed["refined"] and printed["steps"] == 4 and printed["loss"] <= printed["loss_start"]
    assert parse_params(str(out), "lipstick") == pytest.approx(printed["params"]) and in_range(printed["params"])


def test_imitator_refinement_without_torch_is_one_clear_line(models, reference, tmp_path, capsys, monkeypatch):
    """Inside Blender torch is missing: imitator:K says so, render:B is the way there."""
    encoder, imitator = models
    monkeypatch.setitem(sys.modules, "torch", None)  # `import torch` now raises ImportError, as in Blender
    monkeypatch.delitem(sys.modules, "training.refine", raising=False)
    out = tmp_path / "params.json"
    assert cli.run(["match", "--model", encoder, "--image", reference, "--source", str(SOURCE), "--refine",
                    "imitator:2", "--imitator", imitator, "--out-params", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "needs torch" in err[0] and "render:B" in err[0]
    assert not out.exists()


def test_inside_blender_match_is_the_addons_own_and_imitator_refinement_is_one_line(models, reference, tmp_path,
                                                                                     capsys, monkeypatch):
    """`blender -c vto match` runs the extension's own match command (no pipeline layer there), torch or not."""
    import blender_addon
    import blender_addon.matching.match

    encoder, imitator = models
    monkeypatch.setitem(sys.modules, "bl_ext_vto", blender_addon)  # the extension's package name inside Blender
    monkeypatch.setitem(sys.modules, "bl_ext_vto.match", blender_addon.matching.match)
    monkeypatch.setitem(sys.modules, "pipeline", None)  # not shipped in the extension
    out = tmp_path / "params.json"
    argv = ["match", "--model", encoder, "--image", reference, "--source", str(SOURCE), "--out-params", str(out)]
    assert cli.run([*argv, "--refine", "imitator:2", "--imitator", imitator], addon_package="bl_ext_vto") == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "needs torch" in err[0] and "render:B" in err[0] and not out.exists()
    assert cli.run(argv, addon_package="bl_ext_vto") == 0
    assert parse_params(str(out), "lipstick") == pytest.approx(EncoderSession(encoder).predict(read_image(reference)[0])[0])


def test_a_hair_photo_with_its_mask_is_its_own_source(tmp_path):
    rows = np.linspace(0.1, 0.8, RES, dtype=np.float32)
    photo = np.stack([np.outer(rows, np.ones(RES)), np.full((RES, RES), 0.3), np.outer(np.ones(RES), rows)], -1)
    write_image(tmp_path / "portrait.png", photo, bits=16)
    assert own_source(HAIR, tmp_path / "portrait.png") is None  # no mask yet
    mask = np.zeros((RES, RES), np.float32)
    mask[: RES // 2] = 1.0
    write_image(tmp_path / "portrait_mask.png", mask)
    assert own_source(HAIR, tmp_path / "portrait.png") == str(tmp_path / "portrait.png")
    assert own_source(LIPSTICK, tmp_path / "portrait.png") is None  # a lips photo is never its own source
    on_photo = SourceRenderer("hair", str(tmp_path / "portrait.png"), RES)
    stored = read_image(tmp_path / "portrait.png")[0]
    assert np.abs(on_photo.source_image() - stored).max() < 1e-6
    assert np.abs(on_photo({"intensity": 0.0}) - stored).max() < 2e-3  # no colour change: the photo itself


@pytest.fixture
def bad_files(tmp_path):
    import onnx
    from onnx import TensorProto, helper

    (tmp_path / "notes.txt").write_text("not an image")
    (tmp_path / "junk.onnx").write_bytes(b"not a model")
    value = helper.make_tensor_value_info("x", TensorProto.FLOAT, [1])
    graph = helper.make_graph([helper.make_node("Identity", ["x"], ["y"])], "foreign", [value],
                              [helper.make_tensor_value_info("y", TensorProto.FLOAT, [1])])
    model = helper.make_model(graph, ir_version=10, opset_imports=[helper.make_opsetid("", 18)])
    onnx.save(model, str(tmp_path / "foreign.onnx"))  # a valid model onnxruntime loads, without VTO metadata
    return tmp_path


@pytest.mark.parametrize("argv, message", [
    (["--image", "{tmp}/none.png"], "no image at"),
    (["--image", "{tmp}/notes.txt"], "cannot read image"),
    (["--model", "{tmp}/foreign.onnx"], "not a VTO encoder"),
    (["--model", "{tmp}/junk.onnx"], "cannot load"),
    (["--model", "{tmp}/none.onnx"], "no encoder model"),
    (["--refine", "render:0"], "--refine takes none, imitator:K"),
    (["--refine", "imitator"], "--refine takes none, imitator:K"),
    (["--refine", "imitator:3"], "needs --imitator RUN"),
    (["--refine", "imitator:3", "--source", "3", "--imitator", "{tmp}/no-run"], "no imitator run folder"),
    (["--refine", "render:3", "--source", "lips"], "lipstick sources are seeds"),
    (["--out-params", "{tmp}/missing/out.json"], "no folder"),
    (["--quality", "best", "--refine", "render:3", "--source", "3"], "choose one"),
])
def test_bad_input_is_one_line_and_writes_nothing(argv, message, models, reference, bad_files, capsys):
    args = {"--model": models[0], "--image": reference, "--out-params": str(bad_files / "out.json")}
    args.update(zip(argv[::2], (a.replace("{tmp}", str(bad_files)) for a in argv[1::2])))
    assert cli.run(["match", *[x for pair in args.items() for x in pair]]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and re.search(re.escape(message), err), err
    assert not (bad_files / "out.json").exists() and not (bad_files / "no-run").exists()


@pytest.fixture(scope="module")
def portrait(tmp_path_factory):
    """scikit-image's astronaut (public domain, NASA), whole, as a PNG file."""
    import skimage.data

    path = tmp_path_factory.mktemp("portrait") / "astronaut.png"
    write_image(path, skimage.data.astronaut().astype(np.float32) / 255)
    return path


def test_a_whole_portrait_is_read_at_its_lips(models, portrait, tmp_path, capsys):
    """No crop, no mask: the lips are found and framed; the estimate is the encoder's reading of that frame."""
    from vto_core.photo.framing import region_frame
    from vto_core.products import LIPS

    out = tmp_path / "params.json"
    assert cli.run(["match", "--model", models[0], "--image", str(portrait), "--out-params", str(out)]) == 0
    printed = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    x, y, w, h = printed["lips"]["box"]
    assert printed["lips"]["how"] == "face" and 195 <= x <= 205 and 130 <= y <= 145 and 40 <= w <= 55
    whole = read_image(portrait)[0]
    mask = np.zeros(whole.shape[:2])
    mask[y:y + h, x:x + w] = 1
    fx, fy, fw, fh = region_frame(mask, LIPS.frame_share)
    framed = EncoderSession(models[0]).predict(whole[fy:fy + fh, fx:fx + fw])[0]
    whole_image = EncoderSession(models[0]).predict(whole)[0]
    written = parse_params(str(out), "lipstick")
    assert np.allclose([written[k] for k in SPEC.modelled], [framed[k] for k in SPEC.modelled], atol=0.05 * 255)
    assert not np.allclose([written[k] for k in SPEC.modelled], [whole_image[k] for k in SPEC.modelled], atol=1e-3)


def test_a_whole_portrait_is_read_at_both_eyes_lids_and_covered_eyes_are_refused(portrait, tmp_path, capsys):
    """`vto match` with the shipped eye-shadow encoder: both lids found, the JSON says so, the estimate is the mean of
    the two eyes' readings; the eyes under sunglasses are one line, exit 2, nothing written."""
    from blender_addon.matching.reference import read_reference
    from blender_addon.shipped import MODELS
    from vto_core.products import EYESHADOW

    model = str(MODELS / "eyeshadow_encoder.onnx")
    out = tmp_path / "params.json"
    assert cli.run(["match", "--model", model, "--image", str(portrait), "--out-params", str(out)]) == 0
    printed = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert printed["eyelids"]["how"] == "face" and printed["eyelids"]["views"] == 2 and "lips" not in printed
    reference = read_reference("eyeshadow", {"image_path": str(portrait)})
    expected = EncoderSession(model).predict_views([reference.images])[0]
    written = parse_params(str(out), "eyeshadow")
    assert all(abs(written[k] - expected[k]) < 1e-6 for k in EYESHADOW.spec.modelled)
    whole = read_image(portrait)[0]
    face = read_reference("lipstick", {"image_path": str(portrait)}).found.landmarks
    for region in EYESHADOW.face_regions:  # dark lenses over both eyes
        (x0, y0), (x1, y1) = face[list(region.opening)].min(axis=0) - 8, face[list(region.opening)].max(axis=0) + 8
        whole[int(y0):int(y1), int(x0):int(x1)] = (0.05, 0.05, 0.06)
    write_image(tmp_path / "glasses.png", whole)
    assert cli.run(["match", "--model", model, "--image", str(tmp_path / "glasses.png"), "--out-params",
                    str(tmp_path / "none.json")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "no eyelids found: they are hidden" in err[0] and not (tmp_path / "none.json").exists()


def test_crop_and_mask_work_without_a_material_and_the_photos_light_is_taken_out(models, portrait, tmp_path):
    from vto_core.photo.photo_light import light_of, neutral_photo

    crop = tmp_path / "crop.json"
    assert cli.run(["match", "--model", models[0], "--image", str(portrait), "--crop", "196,117,56,56",
                    "--keep-light", "--out-params", str(crop)]) == 0
    whole = read_image(portrait)[0]
    mask = np.zeros(whole.shape[:2], np.float32)
    mask[137:157, 201:249] = 1.0  # the hand-drawn lips box
    write_image(tmp_path / "mask.png", mask)
    masked, neutral = tmp_path / "mask.json", tmp_path / "neutral.json"
    for out, keep in ((masked, ["--keep-light"]), (neutral, [])):
        assert cli.run(["match", "--model", models[0], "--image", str(portrait), "--mask", str(tmp_path / "mask.png"),
                        *keep, "--out-params", str(out)]) == 0
    session = EncoderSession(models[0])
    assert parse_params(str(crop), "lipstick") == pytest.approx(session.predict(whole[117:173, 196:252])[0])
    assert parse_params(str(masked), "lipstick") == pytest.approx(session.predict(whole[116:178, 194:256])[0])
    read = neutral_photo(whole, light_of(whole, mask))  # the light read from the skin beside the lips
    assert parse_params(str(neutral), "lipstick") == pytest.approx(session.predict(read[116:178, 194:256])[0])
    assert parse_params(str(neutral), "lipstick") != pytest.approx(parse_params(str(masked), "lipstick"))


@pytest.mark.parametrize("picture", ["noise", "blank", "dark"])
def test_a_picture_without_lips_is_one_line_exit_2_and_nothing_written(picture, models, tmp_path, capsys):
    image = {"noise": np.random.default_rng(0).random((300, 400, 3)), "blank": np.ones((300, 400, 3)),
             "dark": np.zeros((300, 400, 3))}[picture]
    write_image(tmp_path / "in.png", image.astype(np.float32))
    out = tmp_path / "params.json"
    assert cli.run(["match", "--model", models[0], "--image", str(tmp_path / "in.png"), "--quality", "best",
                    "--out-params", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "no lips found" in err[0] and not out.exists()


def test_two_faces_use_the_larger_and_say_so(models, portrait, tmp_path, capsys):
    from vto_core.imageio import resize

    whole = read_image(portrait)[0]
    canvas = np.full((560, 1000, 3), 0.5, np.float32)
    canvas[24:536, 20:532] = whole
    canvas[100:420, 560:880] = resize(whole, 320, 320)  # the smaller face, on the right
    write_image(tmp_path / "two.png", canvas)
    assert cli.run(["match", "--model", models[0], "--image", str(tmp_path / "two.png"), "--out-params",
                    str(tmp_path / "p.json")]) == 0
    captured = capsys.readouterr()
    x = json.loads(captured.out.strip().splitlines()[-1])["lips"]["box"][0]
    assert 20 + 190 <= x <= 20 + 215 and "2 faces found: the largest is used" in captured.err


def test_better_on_an_image_taken_whole_has_no_lips_to_fit(models, reference):
    with pytest.raises(VtoError, match="needs to know where they are"):
        match(models[0], reference, quality="better", find_region=False)


def test_match_and_render_search_load_without_torch_or_training():
    """The extension ships without torch: importing these modules must not pull it (or `training`) in."""
    import subprocess

    code = ("import sys, blender_addon.matching.match, blender_addon.matching.refine\n"
            "bad = [m for m in ('torch', 'training') if m in sys.modules]\n"
            "print(','.join(bad)); sys.exit(1 if bad else 0)\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert done.returncode == 0, f"imported {done.stdout.strip()} {done.stderr[-500:]}"


HAIR_MODEL = str(Path(__file__).resolve().parents[3] / "blender_addon" / "models" / "hair_encoder.onnx")


def test_hair_is_found_in_a_whole_portrait(portrait, tmp_path, capsys):
    """No crop, no mask: the hair around her face is found, and read as her hand-cut hair patch is read."""
    found, patch, whole = (tmp_path / f"{name}.json" for name in ("found", "patch", "whole"))
    assert cli.run(["match", "--model", HAIR_MODEL, "--image", str(portrait), "--out-params", str(found)]) == 0
    captured = capsys.readouterr()
    result = json.loads(captured.out.strip().splitlines()[-1])
    x, y, w, h = result["hair"]["box"]
    assert 120 <= x and x + w <= 320 and y <= 30 and y + h <= 200 and result["hair"]["faces"] == 1
    assert "vto match: hair found: " in captured.err
    assert cli.run(["match", "--model", HAIR_MODEL, "--image", str(portrait), "--crop", "150,20,80,70",
                    "--out-params", str(patch)]) == 0
    assert cli.run(["match", "--model", HAIR_MODEL, "--image", str(portrait), "--whole-image",
                    "--out-params", str(whole)]) == 0
    values = {name: np.array(list(parse_params(str(path), "hair").values())) for name, path in
              (("found", found), ("patch", patch), ("whole", whole))}
    assert np.abs(values["found"] - values["patch"]).sum() < np.abs(values["whole"] - values["patch"]).sum()


def test_hair_of_the_larger_of_two_faces_is_found_and_said(portrait, tmp_path, capsys):
    from vto_core.imageio import resize

    whole = read_image(portrait)[0]
    canvas = np.full((560, 1000, 3), 0.5, np.float32)
    canvas[24:536, 20:532] = whole
    canvas[100:420, 560:880] = resize(whole, 320, 320)
    write_image(tmp_path / "two.png", canvas)
    assert cli.run(["match", "--model", HAIR_MODEL, "--image", str(tmp_path / "two.png"), "--out-params",
                    str(tmp_path / "p.json")]) == 0
    captured = capsys.readouterr()
    x, _, w, _ = json.loads(captured.out.strip().splitlines()[-1])["hair"]["box"]
    assert x + w <= 532 and "2 faces found: the largest is used" in captured.err


def test_hair_is_found_in_a_tight_crop(portrait, tmp_path, capsys):
    """A beauty crop, the top of her head out of frame: the hair beside her face is found and read."""
    write_image(tmp_path / "tight.png", read_image(portrait)[0][75:300, 130:330])
    assert cli.run(["match", "--model", HAIR_MODEL, "--image", str(tmp_path / "tight.png"), "--out-params",
                    str(tmp_path / "p.json")]) == 0
    captured = capsys.readouterr()
    x, y, w, h = json.loads(captured.out.strip().splitlines()[-1])["hair"]["box"]
    assert x < 40 and x + w > 160 and y < 20 and "vto match: hair found: " in captured.err  # both sides, the fringe
    assert parse_params(str(tmp_path / "p.json"), "hair")


@pytest.mark.parametrize("picture", ["bald", "hat", "out of frame", "out of frame on every side", "no person",
                                     "noise", "blank"])
def test_a_picture_without_hair_is_one_line_exit_2_and_nothing_written(picture, portrait, tmp_path, capsys):
    from benchmarks.hand_masks import load_records, rasterise

    whole = read_image(portrait)[0]
    hair = rasterise(load_records()["package:skimage.data.astronaut"], 512, 512)
    image = whole.copy()
    if picture == "bald":
        image[hair] = whole[130:150, 200:250].reshape(-1, 3).mean(0)
    elif picture == "hat":
        image[hair] = (0.75, 0.1, 0.1)
    elif picture == "out of frame":
        image = whole[110:]
    elif picture == "out of frame on every side":  # her face from the eyes down, cut inside her cheeks
        image = whole[100:300, 185:265]
    elif picture == "no person":  # an orange landscape, as the desert seen from the ISS
        image = np.linspace(0.3, 0.9, 300)[:, None, None] * np.array([1.0, 0.55, 0.25]) * np.ones((300, 400, 1))
    elif picture == "noise":
        image = np.random.default_rng(0).random((300, 400, 3))
    else:
        image = np.ones((300, 400, 3))
    write_image(tmp_path / "in.png", image.astype(np.float32))
    out = tmp_path / "params.json"
    assert cli.run(["match", "--model", HAIR_MODEL, "--image", str(tmp_path / "in.png"), "--quality", "better",
                    "--out-params", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "no hair found" in err[0] and not out.exists()


@pytest.mark.parametrize("renderer", ["lipstick", "hair"])
def test_a_photo_stored_sideways_as_phones_store_it_reads_as_upright(renderer, models, portrait, tmp_path, capsys):
    """Orientation 6 (the camera held upright, the pixels stored turned 90 degrees anticlockwise) and 3 (upside
    down): the same estimate as the upright file, and the face reads upright."""
    model = models[0] if renderer == "lipstick" else HAIR_MODEL
    whole = read_image(portrait)[0]
    # TIFFs: lossless, so the orientations compare exactly (JPEG's tags read alike, tests/vto_core/test_imageio.py)
    paths = {1: write_image(tmp_path / "upright.tif", whole),
             6: write_image(tmp_path / "sideways.tif", np.rot90(whole, 1), orientation=6),
             3: write_image(tmp_path / "upside_down.tif", whole[::-1, ::-1], orientation=3)}
    values = {}
    for orientation, path in paths.items():
        out = tmp_path / f"{orientation}.json"
        assert cli.run(["match", "--model", model, "--image", str(path), "--out-params", str(out)]) == 0
        printed = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
        assert abs(printed["lips" if renderer == "lipstick" else "hair"]["turn"]) < 5
        values[orientation] = np.array(list(parse_params(str(out), renderer).values()))
    assert np.allclose(values[6], values[1], atol=1e-4) and np.allclose(values[3], values[1], atol=1e-4)


@pytest.mark.parametrize("renderer", ["lipstick", "hair"])
@pytest.mark.parametrize("print_kind", ["black and white", "one channel", "sepia"])
def test_a_photo_without_colour_is_one_line_exit_2_and_nothing_written(renderer, print_kind, models, portrait,
                                                                        tmp_path, capsys):
    whole = read_image(portrait)[0]
    grey = whole @ np.array([0.2126, 0.7152, 0.0722], np.float32)
    image = {"black and white": np.repeat(grey[..., None], 3, axis=2), "one channel": grey,
             "sepia": np.clip(grey[..., None] * np.array([1.07, 0.94, 0.74], np.float32), 0, 1)}[print_kind]
    write_image(tmp_path / "print.jpg", image)
    out = tmp_path / "params.json"
    model = models[0] if renderer == "lipstick" else HAIR_MODEL
    assert cli.run(["match", "--model", model, "--image", str(tmp_path / "print.jpg"), "--out-params", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    kind = "a monochrome (toned) print" if print_kind == "sepia" else "a black-and-white photo"
    assert len(err) == 1 and f"{kind} has no {renderer} colour to read" in err[0] and not out.exists()
