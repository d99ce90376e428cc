"""`vto eval` end to end on a tiny encoder: finite figures, baselines, tables, plots and the contact sheet."""

import json

import numpy as np
import pytest

pytestmark = [pytest.mark.blender, pytest.mark.torch, pytest.mark.slow]
pytest.importorskip("bpy")
pytest.importorskip("torch")

from blender_addon.evaluate import buckets, parameter_errors  # noqa: E402
from training.config import EncoderConfig, resolve_config  # noqa: E402
from training.export import export_encoder  # noqa: E402
from training.train_encoder import train_encoder  # noqa: E402
from vto_core import cli  # noqa: E402
from vto_core.imageio import read_image  # noqa: E402
from vto_core.specs import get_spec  # noqa: E402

TINY = ["width=8", "n_layers=2", "batch_size=16", "perceptual=ssim_l1", "log_every=50", "lr=0.003", "loss=graphics",
        "pool_size=1"]


@pytest.fixture(scope="module")
def tiny_encoder(colour_dataset, tmp_path_factory):
    folder = tmp_path_factory.mktemp("eval-model")
    config = resolve_config(EncoderConfig, None, TINY + ["steps=600"])
    run = train_encoder(str(colour_dataset), None, str(folder / "encoder"), config)
    export_encoder(str(run.path), str(folder / "encoder.onnx"))
    return folder / "encoder.onnx"


def test_eval_writes_every_output_with_finite_figures(tiny_encoder, tmp_path, capsys):
    out = tmp_path / "eval"
    assert cli.run(["eval", "--model", str(tiny_encoder), "--n", "3", "--res", "16", "--samples", "2",
                    "--refine", "render:5", "--out", str(out)]) == 0
    printed = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    results = json.loads((out / "results.json").read_text())
    summary = results["summary"]
    assert set(summary) == {"encoder", "mean preset", "nearest preset", "encoder + render search 5"}
    assert set(summary) == set(printed) - {"out"}
    for method in summary.values():
        assert np.isfinite([method["psnr_mean"], method["ssim_mean"]]).all()
        assert set(method["param_error"]) == {"red", "green", "blue"}
        assert all(0 <= e <= 1 for e in method["param_error"].values())
    assert len(results["looks"]) == 3
    assert "| encoder |" in (out / "results.md").read_text()
    sheet, _ = read_image(out / "sheet.png")
    assert sheet.shape == (3 * 16, 4 * 16, 3)  # reference | truth | encoder | nearest preset, a row per look
    for plot in ("psnr.png", "errors.png"):
        assert (out / plot).stat().st_size > 1000


def test_eval_refuses_a_missing_or_foreign_model(tmp_path, capsys):
    assert cli.run(["eval", "--model", str(tmp_path / "none.onnx"), "--out", str(tmp_path / "e")]) == 2
    (tmp_path / "junk.onnx").write_bytes(b"not a model")
    assert cli.run(["eval", "--model", str(tmp_path / "junk.onnx"), "--out", str(tmp_path / "e")]) == 2
    assert not (tmp_path / "e").exists()
    assert "no encoder model" in capsys.readouterr().err


def test_hue_errors_wrap_and_buckets_name_dark_glossy_and_extreme_looks():
    hair = get_spec("hair", "hue,blend")
    assert parameter_errors(hair, np.array([0.98, 0.5]), np.array([0.02, 0.6])) == pytest.approx([0.04, 0.1])
    lipstick = get_spec("lipstick")
    values = lipstick.full_values({"red": 30, "green": 10, "blue": 10, "gloss": 5.0})
    assert buckets(lipstick, values, lipstick.normalise(lipstick.vector(values))) == ["dark", "high gloss",
                                                                                       "range extreme"]
    plain = lipstick.full_values({})
    assert buckets(lipstick, plain, np.full(lipstick.size, 0.5)) == ["other"]


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    from blender_addon.commands import render
    from vto_core.imageio import write_image

    path = tmp_path_factory.mktemp("match") / "reference.png"
    write_image(path, render("lipstick", {"red": 200.0, "green": 30.0, "blue": 60.0}, 3, 16, 2), bits=16)
    return path


def test_match_without_refinement_is_the_encoders_estimate(tiny_encoder, reference, tmp_path, capsys):
    from vto_core.inference import EncoderSession

    out = tmp_path / "params.json"
    assert cli.run(["match", "--model", str(tiny_encoder), "--image", str(reference), "--out-params", str(out)]) == 0
    written = json.loads(out.read_text())["params"]
    expected = EncoderSession(tiny_encoder).predict(read_image(reference)[0])[0]
    assert written == pytest.approx(expected)
    assert cli.run(["match", "--model", str(tiny_encoder), "--image", str(reference), "--refine", "render:4",
                    "--out-params", str(tmp_path / "p2.json")]) == 0
    assert "no source for the reference" in capsys.readouterr().err  # refinement needs the source: it says so
    assert json.loads((tmp_path / "p2.json").read_text())["params"] == pytest.approx(expected)


def test_render_refinement_keeps_its_budget_range_and_never_worsens(tiny_encoder, reference):
    from blender_addon.match import match

    result = match(str(tiny_encoder), str(reference), source="3", refine="render:9", res=16, samples=2)
    assert result["refined"] and result["renders"] <= 9
    assert result["loss"] <= result["loss_start"]
    spec = get_spec("lipstick", "red,green,blue")
    for name in spec.modelled:
        assert spec.by_name[name].low <= result["params"][name] <= spec.by_name[name].high


@pytest.mark.parametrize("argv, message", [
    (["--image", "{missing}"], "no image at"),
    (["--image", "{text}"], "cannot read image"),
    (["--image", "{ref}", "--refine", "render:0"], "--refine takes none or render:B"),
    (["--image", "{ref}", "--model", "{text}"], "cannot load|not a VTO encoder"),
])
def test_match_bad_input_is_one_line_and_writes_nothing(argv, message, tiny_encoder, reference, tmp_path, capsys):
    (tmp_path / "notes.txt").write_text("not an image")
    subs = {"{missing}": str(tmp_path / "none.png"), "{text}": str(tmp_path / "notes.txt"), "{ref}": str(reference)}
    args = ["match", "--model", str(tiny_encoder), "--out-params", str(tmp_path / "out.json")]
    args += [subs.get(a, a) for a in argv]
    assert cli.run(args) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and __import__("re").search(message, err), err
    assert not (tmp_path / "out.json").exists()
