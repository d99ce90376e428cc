"""`vto eval` end to end on a tiny encoder and imitator: every method, finite figures, tables, plots, contact sheet."""

import contextlib
import io
import json
from pathlib import Path

import numpy as np
import pytest

pytestmark = [pytest.mark.blender, pytest.mark.torch, pytest.mark.slow]
pytest.importorskip("bpy")
pytest.importorskip("torch")

from pipeline.cli import cmd_eval  # noqa: E402
from training.config import EncoderConfig, ImitatorConfig, resolve_config  # noqa: E402
from pipeline.evaluate import (buckets, colour_errors, is_dark, parameter_errors, raw_errors,  # noqa: E402
                               standard_error, summarise)
from training.export import export_encoder  # noqa: E402
from training.train_encoder import train_encoder  # noqa: E402
from training.train_imitator import train_imitator  # noqa: E402
from vto_core.errors import VtoError  # noqa: E402
from vto_core.imageio import read_image  # noqa: E402
from vto_core.metrics import psnr  # noqa: E402
from vto_core.presets import load_presets  # noqa: E402
from vto_core.products import get_spec  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
RES, SAMPLES, N = 16, 2, 2
METHODS = {"mean preset", "nearest preset", "encoder", "encoder + imitator 3", "encoder + render search 5",
           "render search 5 from the mean preset", "same encoder"}
SPEC = get_spec("lipstick", "opacity,red,green,blue")


@pytest.fixture(scope="module")
def models(lipstick_dataset, tmp_path_factory):
    """A tiny encoder (.onnx) and imitator run on the 24-sample dataset: (encoder, imitator)."""
    folder = tmp_path_factory.mktemp("eval-models")
    common = ["perceptual=ssim_l1", "batch_size=8", "lr=0.003", "log_every=20"]
    run = train_encoder(str(lipstick_dataset), None, str(folder / "encoder"), resolve_config(
        EncoderConfig, None, common + ["width=8", "n_layers=2", "pool_size=1", "loss=graphics", "steps=40"]))
    export_encoder(str(run.path), str(folder / "encoder.onnx"))
    train_imitator(str(lipstick_dataset), str(folder / "imitator"), resolve_config(
        ImitatorConfig, None, common + ["width=8", "n_down=1", "n_res=1", "critic_width=8", "critic_layers=2",
                                        "use_gan=false", "steps=20"]))
    return str(folder / "encoder.onnx"), str(folder / "imitator")


@pytest.fixture(scope="module")
def evaluated(models, tmp_path_factory):
    """One `vto eval` run with every kind of method: (out folder, the printed JSON line)."""
    out = tmp_path_factory.mktemp("eval") / "results"
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        assert cmd_eval(["--model", models[0], "--imitator", models[1], "--n", str(N), "--res", str(RES), "--samples",
                         str(SAMPLES), "--refine", "imitator:3,render:5", "--search-from-mean", "5", "--quiet",
                         "--compare", f"same encoder={models[0]}", "--out", str(out)]) == 0
    return out, json.loads(printed.getvalue().strip().splitlines()[-1])


def test_every_method_has_finite_figures_and_the_baselines_are_there(evaluated):
    out, printed = evaluated
    results = json.loads((out / "results.json").read_text())
    summary = results["summary"]
    assert set(summary) == METHODS and set(printed) - {"out"} == METHODS
    for name, method in summary.items():
        assert np.isfinite([*method["psnr"], *method["ssim"], method["ms_per_reference"]]).all(), name
        assert method["perceptual"] is None or np.isfinite(method["perceptual"]).all()
        assert set(method["param_error"]) == set(SPEC.modelled)
        assert all(0 <= e <= 1 for e in method["param_error"].values())
        rows = [look["methods"][name] for look in results["looks"]]
        assert method["psnr"][0] == pytest.approx(np.mean([r["psnr"] for r in rows]))
        assert all(SPEC.by_name[k].low <= v <= SPEC.by_name[k].high for r in rows for k, v in r["estimate"].items())
    assert summary["mean preset"]["gain_over_mean_preset_db"] == 0 and summary["mean preset"]["ms_per_reference"] == 0
    assert all(summary[m]["ms_per_reference"] > 0 for m in METHODS - {"mean preset"})
    # the nearest preset renders 36 presets on A: it costs more than 5 renders of a search from the mean preset
    assert summary["nearest preset"]["ms_per_reference"] > summary["render search 5 from the mean preset"][
        "ms_per_reference"]
    presets = load_presets("lipstick")
    for look in results["looks"]:
        assert look["nearest_preset"] in presets and look["source_a"] != look["source_b"]
        nearest = SPEC.full_values(presets[look["nearest_preset"]])
        assert look["methods"]["nearest preset"]["estimate"] == pytest.approx({k: nearest[k] for k in SPEC.modelled})
        assert look["buckets"]
    assert len({look["source_a"] for look in results["looks"]} | {look["source_b"] for look in results["looks"]}) == 2 * N


def test_a_compared_encoder_is_evaluated_on_the_same_references(evaluated):
    looks = json.loads((evaluated[0] / "results.json").read_text())["looks"]
    for look in looks:
        same, encoder = look["methods"]["same encoder"], look["methods"]["encoder"]
        assert same["estimate"] == encoder["estimate"] and same["psnr"] == encoder["psnr"]


def test_the_comparison_renders_on_source_b_with_the_truths_cycles_seed(evaluated):
    """Re-rendering one look's truth and mean-preset estimate on B reproduces the recorded PSNR."""
    from blender_addon.renderers.products import render

    out, _ = evaluated
    look = json.loads((out / "results.json").read_text())["looks"][1]
    mean = {k: v for k, v in look["methods"]["mean preset"]["estimate"].items()}
    truth = render("lipstick", look["truth"], look["source_b"], RES, SAMPLES, look["cycles_seed"])
    on_b = render("lipstick", mean, look["source_b"], RES, SAMPLES, look["cycles_seed"])
    assert psnr(on_b, truth) == pytest.approx(look["methods"]["mean preset"]["psnr"], abs=0.05)


def test_a_search_seed_offset_moves_what_methods_render_on_a_off_the_references_noise(models, tmp_path):
    """With --search-seed-offset the nearest preset is the closest of the presets rendered on seed + offset."""
    from blender_addon.renderers.products import render
    from vto_core.metrics import mse

    out = tmp_path / "offset"
    assert cmd_eval(["--model", models[0], "--n", "1", "--res", str(RES), "--samples", str(SAMPLES),
                     "--search-seed-offset", "1000", "--quiet", "--out", str(out)]) == 0
    look = json.loads((out / "results.json").read_text())["looks"][0]
    reference = render("lipstick", look["truth"], look["source_a"], RES, SAMPLES, look["cycles_seed"])

    def distances(seed):
        return {name: mse(render("lipstick", SPEC.full_values(values), look["source_a"], RES, SAMPLES, seed),
                          reference) for name, values in load_presets("lipstick").items()}

    on_other_seed = distances(look["cycles_seed"] + 1000)
    assert look["nearest_preset"] == min(on_other_seed, key=on_other_seed.get)
    assert on_other_seed != distances(look["cycles_seed"])  # the offset did change what was compared
    assert "Cycles seed + 1000" in (out / "results.md").read_text()


def test_tables_plots_and_contact_sheet_are_written(evaluated):
    out, _ = evaluated
    text = (out / "results.md").read_text()
    for method in METHODS:
        assert f"| {method} |" in text
    assert "PSNR by bucket" in text and "| opacity |" in text and "Median absolute parameter error" in text
    summary = json.loads((out / "results.json").read_text())["summary"]
    encoder = summary["encoder"]
    assert f"| {encoder['gain_over_mean_preset_db']:+.2f} ± {encoder['gain_standard_error_db']:.2f} |" in text
    colour = summary["encoder"]["colour_error_median"]
    assert colour["all"] == pytest.approx(colour_errors(SPEC, json.loads((out / "results.json").read_text())["looks"],
                                                        "encoder")["all"])
    assert f"| all ({N}) | " + " | ".join(f"{summary[m]['colour_error_median']['all']:.1f}" for m in summary) in text
    sheet, _ = read_image(out / "sheet.png")
    assert sheet.shape == (N * RES, (2 + len(METHODS)) * RES, 3)  # reference A | truth B | each method on B
    assert np.isfinite(sheet).all() and sheet.std() > 0.01
    for plot in ("psnr.png", "errors.png"):
        image, _ = read_image(out / plot)
        assert image.shape[0] > 200 and image.shape[1] > 300 and image.std() > 0.01


@pytest.mark.parametrize("argv, message", [
    (["--model", "{tmp}/none.onnx"], "no encoder model"),
    (["--model", "{tmp}/junk.onnx"], "cannot load"),
    (["--refine", "render:x"], "--refine takes none, imitator:K"),
    (["--refine", "imitator:3"], "needs --imitator RUN"),
    (["--refine", "imitator:3", "--imitator", "{tmp}/no-run"], "no imitator run folder"),
    (["--n", "0"], "--n must be at least 1"),
    (["--search-from-mean", "many"], "--search-from-mean takes render budgets"),
    (["--compare", "no-equals-sign"], "--compare takes NAME=MODEL"),
    (["--compare", "encoder={model}"], "names must be unique and differ from the built-in"),
    (["--compare", "other={tmp}/junk.onnx"], "cannot load"),
    (["--compare", "hair={root}/blender_addon/models/hair_encoder.onnx"], "estimates other values or input size"),
])
def test_bad_input_is_one_line_and_writes_nothing(argv, message, models, tmp_path):
    (tmp_path / "junk.onnx").write_bytes(b"not a model")
    args = {"--model": models[0], "--out": str(tmp_path / "out"), "--n": "1", "--res": str(RES), "--samples": "1"}
    args.update(zip(argv[::2], (a.replace("{tmp}", str(tmp_path)).replace("{model}", models[0])
                                           .replace("{root}", str(ROOT)) for a in argv[1::2])))
    with pytest.raises(VtoError, match=message) as caught:
        cmd_eval([x for pair in args.items() for x in pair])
    assert "\n" not in str(caught.value)
    assert not (tmp_path / "out").exists() and not (tmp_path / "no-run").exists()


def test_colour_errors_pool_the_channels_over_all_and_over_opaque_looks():
    def look(opacity, errors):
        return {"truth": {"opacity": opacity}, "methods": {"m": {"raw_error": dict(zip(("red", "green", "blue"),
                                                                                           errors))}}}

    rows = [look(0.9, (1, 2, 3)), look(0.5, (4, 5, 6)), look(0.2, (30, 40, 50))]
    # all: median of 1..6, 30, 40, 50 = 5; opacity >= 0.5: median of 1..6 = 3.5
    assert colour_errors(SPEC, rows, "m") == {"all": 5.0, "opaque": 3.5, "opaque_looks": 2}
    assert colour_errors(SPEC, rows[2:], "m") == {"all": 40.0, "opaque": None, "opaque_looks": 0}
    assert colour_errors(get_spec("lipstick", "opacity,red,green"), rows, "m") is None
    assert colour_errors(get_spec("hair"), rows, "m") is None


def test_the_gain_over_the_mean_preset_carries_the_standard_error_of_its_paired_differences():
    def look(mean_preset, encoder):
        def result(value):
            zeros = dict.fromkeys(SPEC.modelled, 0.0)
            return {"psnr": value, "ssim": 0.9, "perceptual": None, "ms": 1.0, "raw_error": zeros, "param_error": zeros}
        return {"buckets": ["other"], "truth": {"opacity": 1.0}, "methods": {"mean preset": result(mean_preset),
                                                                             "encoder": result(encoder)}}

    # differences 6, 8, 10, 12: mean 9, sample std sqrt(20/3), standard error sqrt(20/3) / 2
    rows = [look(30.0, 36.0), look(20.0, 28.0), look(25.0, 35.0), look(40.0, 52.0)]
    summary = summarise(SPEC, rows, ["mean preset", "encoder"])
    assert summary["encoder"]["gain_over_mean_preset_db"] == pytest.approx(9.0)
    assert summary["encoder"]["gain_standard_error_db"] == pytest.approx(np.sqrt(20 / 3) / 2)
    assert summary["mean preset"]["gain_standard_error_db"] == 0.0
    # the looks' own difficulty (PSNR 20-40 here) does not enter: only the spread of the differences
    steady = summarise(SPEC, [look(30.0, 39.0), look(20.0, 29.0)], ["encoder"])
    assert steady["encoder"]["gain_standard_error_db"] == 0.0
    assert standard_error(np.array([5.0])) is None and standard_error(np.array([1.0, 3.0])) == pytest.approx(1.0)


def test_hue_errors_wrap_and_buckets_name_dark_glossy_and_extreme_looks():
    hair = get_spec("hair", "hue,blend")
    assert parameter_errors(hair, np.array([0.98, 0.5]), np.array([0.02, 0.6])) == pytest.approx([0.04, 0.1])
    assert raw_errors(hair, {"hue": 0.95, "blend": 0.0}, {"hue": 0.05, "blend": -0.5}) == pytest.approx([0.1, 0.5])
    lipstick = get_spec("lipstick")
    values = lipstick.full_values({"red": 20, "green": 10, "blue": 10, "gloss": 5.0, "opacity": 0.5})
    found = buckets(lipstick, values, lipstick.normalise(lipstick.vector(values)))
    assert found[:2] == ["dark", "high gloss"] and {"red low", "green low", "blue low"} <= set(found)
    assert "opacity low" not in found and "opacity high" not in found
    assert buckets(lipstick, lipstick.full_values({}), np.full(lipstick.size, 0.5)) == ["other"]
    hue_only = get_spec("hair", "hue")
    assert buckets(hue_only, hue_only.full_values({"hue": 0.99}), np.array([0.99])) == ["other"]  # no ends on a circle
    assert is_dark("hair", get_spec("hair").full_values({"exposure": 0.5, "brightness": -0.3}))
    assert not is_dark("hair", get_spec("hair").full_values({}))
