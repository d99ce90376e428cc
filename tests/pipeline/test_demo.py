"""`vto demo --size smoke`: the whole pipeline to an ONNX encoder and a self-contained report; stages are reused."""

import base64
import contextlib
import io
import json
import re

import numpy as np
import pytest

from pipeline.demo import Stages

SMOKE_PARAMS = ("opacity", "red", "green", "blue")


@pytest.fixture(scope="module")
def smoke(tmp_path_factory):
    """One `vto demo --size smoke` run: (out folder, the page path it printed last)."""
    pytest.importorskip("bpy")
    pytest.importorskip("torch")
    from vto_core.cli import run

    out = tmp_path_factory.mktemp("demo") / "out"
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        assert run(["demo", "--size", "smoke", "--out", str(out)]) == 0
    return out, printed.getvalue().strip().splitlines()[-1]


def metrics(page: str) -> dict[str, float]:
    """The report's metrics table: method -> mean transfer PSNR."""
    table = re.search(r'<table id="metrics">(.*?)</table>', page, re.S).group(1)
    return {name: float(value) for name, value in re.findall(r"<tr><td>([^<]+)</td><td>([-\d.]+) ±", table)}


@pytest.mark.slow
@pytest.mark.blender
@pytest.mark.torch
def test_smoke_demo_makes_an_encoder_and_a_self_contained_report(smoke):
    from vto_core.imageio import read_image
    from vto_core.inference import EncoderSession

    out, printed = smoke
    page_path = out / "report" / "index.html"
    assert printed == str(page_path) and page_path.is_file()
    assert EncoderSession(out / "encoder.onnx").spec.modelled == SMOKE_PARAMS
    page = page_path.read_text()
    sources = re.findall(r'<img[^>]* src="([^"]+)"', page)
    assert len(sources) >= 5  # contact sheet, two loss curves, PSNR and error plots
    for number, source in enumerate(sources):
        assert source.startswith("data:image/png;base64,"), source[:60]  # embedded, nothing beside the page
        png = out / f"decoded_{number}.png"
        png.write_bytes(base64.b64decode(source.split(",", 1)[1], validate=True))
        image = read_image(png)[0]
        assert image.ndim == 3 and image.shape[0] >= 16 and np.isfinite(image).all()
    psnr = metrics(page)
    assert {"encoder", "mean preset", "nearest preset"} <= set(psnr)
    results = json.loads((out / "eval" / "results.json").read_text())
    assert psnr["encoder"] == pytest.approx(results["summary"]["encoder"]["psnr"][0], abs=0.01)
    assert psnr["encoder"] > psnr["mean preset"] + 1.0, psnr  # measured: +2.5 dB on the 12 held-out looks
    encoder = results["summary"]["encoder"]
    assert (f"<td>{encoder['gain_over_mean_preset_db']:+.2f} ± {encoder['gain_standard_error_db']:.2f}</td>"
            in page)  # the gain and its standard error over the looks
    assert 'id="timings"' in page and page.count(">this run</td>") == 6


@pytest.mark.slow
@pytest.mark.blender
@pytest.mark.torch
def test_a_rerun_reuses_every_finished_stage(smoke):
    from vto_core.cli import run

    out, page = smoke
    stamps = {p.name: p.read_text() for p in (out / "stamps").glob("*.json")}
    with contextlib.redirect_stdout(io.StringIO()):
        assert run(["demo", "--size", "smoke", "--out", str(out)]) == 0
    assert {p.name: p.read_text() for p in (out / "stamps").glob("*.json")} == stamps
    summary = json.loads((out / "report" / "summary.json").read_text())
    assert len(summary["timings"]) == 6 and all(t["reused"] for t in summary["timings"])


@pytest.mark.slow
@pytest.mark.blender
@pytest.mark.torch
def test_the_hair_demo_makes_a_hair_encoder_that_beats_the_mean_preset(tmp_path):
    from vto_core.cli import run
    from vto_core.inference import EncoderSession

    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        assert run(["demo", "--renderer", "hair", "--size", "smoke", "--out", str(tmp_path)]) == 0
    assert printed.getvalue().strip().splitlines()[-1] == str(tmp_path / "report" / "index.html")
    assert EncoderSession(tmp_path / "encoder.onnx").spec.renderer == "hair"
    psnr = metrics((tmp_path / "report" / "index.html").read_text())
    assert psnr["encoder"] > psnr["mean preset"] + 1.0, psnr  # measured: +7.0 dB on the 12 held-out looks


def test_stages_skip_same_settings_redo_changed_ones_and_resume_unfinished(tmp_path):
    output, calls = tmp_path / "made", []

    def work():
        calls.append(output.exists())  # whether the output was there when the stage started
        output.mkdir(exist_ok=True)
        (output / "part").write_text(str(len(calls)))

    Stages(tmp_path, 1).run("s", "stage", {"n": 1}, [output], work)
    Stages(tmp_path, 1).run("s", "stage", {"n": 1}, [output], work)
    assert calls == [False]  # finished with the same settings: reused
    Stages(tmp_path, 1).run("s", "stage", {"n": 2}, [output], work)
    assert calls == [False, False]  # changed settings: the old output was removed first
    stamp = tmp_path / "stamps" / "s.json"
    stamp.write_text(json.dumps({**json.loads(stamp.read_text()), "finished": False}))
    stages = Stages(tmp_path, 1)
    stages.run("s", "stage", {"n": 2}, [output], work)
    assert calls == [False, False, True]  # unfinished with the same settings: resumed on what is there
    assert stages.timings[0]["reused"] is False and json.loads(stamp.read_text())["finished"]


def test_every_stage_is_stamped_with_the_spec_so_a_changed_spec_remakes_it(monkeypatch, tmp_path):
    import pipeline.demo_report
    from pipeline import demo
    from vto_core.products import get_spec

    class Stop(Exception):
        pass

    def stop(*args, **kwargs):
        raise Stop

    settings = {}
    monkeypatch.setattr(demo.Stages, "run", lambda self, name, title, made, outputs, work: settings.update({name: made}))
    monkeypatch.setattr(pipeline.demo_report, "write_report", stop)
    with pytest.raises(Stop):
        demo.run_demo("lipstick", "smoke", tmp_path)
    spec = get_spec("lipstick", demo.SIZES["smoke"].params("lipstick")).to_dict()
    assert list(settings) == ["data_imitator", "data_encoder", "imitator", "encoder", "export", "eval"]
    assert all(made["spec"] == spec for name, made in settings.items() if name != "eval")
    assert settings["eval"]["trained"]["spec"] == spec
