"""Training runs on a small real dataset: losses fall, the encoder beats the mean, resume, NaN stop, export."""

import dataclasses
import json

import numpy as np
import pytest

pytestmark = [pytest.mark.torch, pytest.mark.blender]
torch = pytest.importorskip("torch")
pytest.importorskip("bpy")

from training.config import EncoderConfig, ImitatorConfig, data_record, resolve_config  # noqa: E402
from training.data import held_out_folders, held_out_text, split  # noqa: E402
from training.export import export_encoder  # noqa: E402
from training.run import RunFolder  # noqa: E402
from training.train_encoder import train_encoder  # noqa: E402
from training.train_imitator import train_imitator  # noqa: E402
from vto_core import cli  # noqa: E402
from vto_core.dataset import DatasetReader, DatasetUnion  # noqa: E402
from vto_core.errors import VtoError  # noqa: E402
from vto_core.inference import EncoderSession  # noqa: E402
from vto_core.products import get_spec  # noqa: E402

TINY_IMITATOR = ["width=8", "n_down=1", "n_res=1", "critic_width=8", "critic_layers=2", "batch_size=8",
                 "perceptual=ssim_l1", "log_every=5", "checkpoint_every=10", "lr=0.002"]
TINY_ENCODER = ["width=8", "n_layers=2", "batch_size=16", "perceptual=ssim_l1", "log_every=10", "lr=0.003",
                "val_fraction=0.2"]


def mirror_readings(state: dict, images: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A checkpoint's encoder read on (N, 3, H, W) images and on their left-right mirrors: (direct, mirrored)."""
    from training.networks import build

    encoder = build("encoder", state["model_args"])
    encoder.load_state_dict(state["model"])
    encoder.eval()
    with torch.no_grad():
        return tuple(encoder(torch.from_numpy(x)).numpy() for x in (images, images[..., ::-1].copy()))


def imitator_config(*extra):
    return resolve_config(ImitatorConfig, None, TINY_IMITATOR + list(extra))


@pytest.fixture(scope="module")
def imitator_run(lipstick_dataset, tmp_path_factory):
    out = tmp_path_factory.mktemp("runs") / "imitator"
    train_imitator(str(lipstick_dataset), str(out), imitator_config("steps=60"))
    return out


def test_imitator_loss_falls_on_real_renders(imitator_run):
    log = RunFolder(imitator_run).read_log()
    first, last = log[0], log[-1]
    assert last["step"] == 60
    assert {"imitation", "sensitivity", "adversarial", "critic", "val_l1", "val_sensitivity", "lr"} <= set(last)
    # every term unweighted and as it enters the total (the paper's lambda_1 = 100, lambda_2 = 1000)
    assert last["imitation_weighted"] == pytest.approx(100 * last["imitation"], rel=1e-5)
    assert last["sensitivity_weighted"] == pytest.approx(1000 * last["sensitivity"], rel=1e-5)
    assert last["adversarial_weighted"] == pytest.approx(last["adversarial"], rel=1e-5)
    weighted = sum(last[f"{k}_weighted"] for k in ("imitation", "sensitivity", "adversarial"))
    assert last["total"] == pytest.approx(weighted, rel=1e-4, abs=1e-4)
    assert np.mean([row["imitation"] for row in log[-3:]]) < first["imitation"]
    assert last["val_l1"] < first["val_l1"]
    assert (imitator_run / "losses.png").stat().st_size > 1000
    saved = json.loads((imitator_run / "config.json").read_text())
    assert saved["lambda_sens"] == 1000.0 and saved["spec"]["modelled"] == ["opacity", "red", "green", "blue"]


def test_imitation_only_ablation_needs_no_sensitivity_term(lipstick_dataset, tmp_path):
    run = train_imitator(str(lipstick_dataset), str(tmp_path / "ablation"),
                         imitator_config("steps=5", "use_sensitivity=false", "use_gan=false"))
    last = run.read_log()[-1]
    assert "sensitivity" not in last and "adversarial" not in last and last["total"] == pytest.approx(100 * last["imitation"])


def test_a_run_resumes_from_its_last_checkpoint(lipstick_dataset, tmp_path):
    out = tmp_path / "resume"
    train_imitator(str(lipstick_dataset), str(out), imitator_config("steps=10"))
    first_weights = RunFolder(out).load_checkpoint()["model"]
    saved = json.loads((out / "config.json").read_text())
    del saved["held_out"]  # a run made before runs recorded their held-out folders resumes as well
    (out / "config.json").write_text(json.dumps(saved))
    train_imitator(str(lipstick_dataset), str(out), imitator_config("steps=20"))
    checkpoint = RunFolder(out).load_checkpoint()
    assert checkpoint["step"] == 20
    assert [row["step"] for row in RunFolder(out).read_log()] == [5, 10, 15, 20]
    assert any(not torch.equal(first_weights[k], checkpoint["model"][k]) for k in first_weights)
    with pytest.raises(VtoError, match="other settings"):
        train_imitator(str(lipstick_dataset), str(out), imitator_config("steps=30", "width=16"))


def test_nan_loss_stops_with_a_clear_message(lipstick_dataset, tmp_path, monkeypatch):
    import training.train_imitator as module

    class NanDistance(torch.nn.Module):
        kind = "nan"

        def __init__(self, *args):
            super().__init__()

        def forward(self, x, y):
            return (x - y).sum() * float("nan")

    monkeypatch.setattr(module, "PerceptualDistance", NanDistance)
    with pytest.raises(VtoError, match="training stopped at step 1: loss imitation=nan"):
        train_imitator(str(lipstick_dataset), str(tmp_path / "nan"), imitator_config("steps=5"))


def test_encoder_beats_predicting_the_mean(colour_dataset, tmp_path):
    config = resolve_config(EncoderConfig, None, TINY_ENCODER + ["steps=1500", "loss=graphics", "pool_size=1"])
    run = train_encoder(str(colour_dataset), None, str(tmp_path / "encoder"), config)
    reader = DatasetReader(colour_dataset)
    held_out = 32  # val_fraction 0.2 of 160
    train_g = np.stack([reader[i].unit for i in range(len(reader) - held_out)])
    held_out_g = np.stack([reader[i].unit for i in range(len(reader) - held_out, len(reader))])
    baseline = float(((held_out_g - train_g.mean(0)) ** 2).mean())
    learned = run.read_log()[-1]["val_param_mse"]
    assert learned < 0.7 * baseline, f"encoder {learned:.4f} vs mean baseline {baseline:.4f}"


def test_several_datasets_train_as_one_in_the_order_given(lipstick_dataset, colour_dataset, tmp_path):
    one = DatasetReader(lipstick_dataset)
    union = DatasetUnion([lipstick_dataset, lipstick_dataset])
    assert len(union) == 2 * len(one) == 48
    assert union[23].index == 23 and union[24].index == 0
    np.testing.assert_array_equal(union[30].unit, one[6].unit)
    config = resolve_config(EncoderConfig, None, TINY_ENCODER + ["steps=2", "loss=graphics"])
    run = train_encoder([str(lipstick_dataset)] * 2, None, str(tmp_path / "two"), config)
    recorded = json.loads((run.path / "config.json").read_text())
    assert recorded["data"] == [str(lipstick_dataset)] * 2
    assert recorded["held_out"] == [{"folder": str(lipstick_dataset), "held_out": 5, "of": 24}] * 2  # 0.2 of each
    assert data_record([str(lipstick_dataset)]) == data_record(lipstick_dataset) == str(lipstick_dataset)
    with pytest.raises(VtoError, match="differ in their spec: one training set needs one"):
        train_encoder([str(lipstick_dataset), str(colour_dataset)], None, str(tmp_path / "mixed"), config)
    assert not (tmp_path / "mixed").exists()


def test_each_folder_holds_out_its_own_last_looks_so_every_folder_is_trained_on(lipstick_dataset):
    union = DatasetUnion([lipstick_dataset, lipstick_dataset, lipstick_dataset])  # 3 x 24 looks
    train, held = split(union, 0.4)  # 10 of each
    assert held == [*range(14, 24), *range(38, 48), *range(62, 72)] and len(train) == 42
    assert set(train).isdisjoint(held) and sorted(train + held) == list(range(72))
    assert held_out_folders(union, held) == [{"folder": str(lipstick_dataset), "held_out": 10, "of": 24}] * 3
    assert held_out_text(held_out_folders(union, held)) == (
        "held out for validation (not trained on): " + ", ".join([f"10 of 24 of {lipstick_dataset}"] * 3))
    one = DatasetReader(lipstick_dataset)
    assert split(one, 0.1) == split(one, 0.1, each=False) == (list(range(22)), [22, 23])
    assert held_out_text(held_out_folders(one, split(one, 0.0)[1])).endswith(": none")


def test_the_tail_of_several_folders_takes_whole_folders_and_names_them(lipstick_dataset):
    union = DatasetUnion([lipstick_dataset, lipstick_dataset, lipstick_dataset])
    _, held = split(union, 0.4, each=False)  # 29 looks: the last folder whole, and 5 of the one before
    assert held == list(range(43, 72))
    assert held_out_folders(union, held) == [{"folder": str(lipstick_dataset), "held_out": 5, "of": 24},
                                             {"folder": str(lipstick_dataset), "held_out": 24, "of": 24}]
    assert held_out_text(held_out_folders(union, held)) == (
        f"held out for validation (not trained on): 5 of 24 of {lipstick_dataset}, all 24 of {lipstick_dataset}")


def test_a_run_of_several_folders_made_before_val_split_resumes_only_with_the_tail(lipstick_dataset, tmp_path):
    out = tmp_path / "legacy"
    config = resolve_config(EncoderConfig, None, TINY_ENCODER + ["steps=2", "loss=graphics", "val_split=tail"])
    train_encoder([str(lipstick_dataset)] * 2, None, str(out), config)
    saved = json.loads((out / "config.json").read_text())
    del saved["val_split"], saved["held_out"]
    (out / "config.json").write_text(json.dumps(saved))
    each = resolve_config(EncoderConfig, None, TINY_ENCODER + ["steps=4", "loss=graphics"])
    with pytest.raises(VtoError, match=r"other settings \(val_split\)"):
        train_encoder([str(lipstick_dataset)] * 2, None, str(out), each)
    resumed = train_encoder([str(lipstick_dataset)] * 2, None, str(out), dataclasses.replace(config, steps=4))
    assert RunFolder(resumed.path).load_checkpoint()["step"] == 4


def test_an_absolute_weighted_graphics_loss_trains_and_a_bad_weight_or_name_leaves_no_run_folder(lipstick_dataset, tmp_path):
    settings = TINY_ENCODER + ["steps=3", "loss=graphics", "graphics_error=absolute"]
    config = resolve_config(EncoderConfig, None, settings + ["parameter_weights=red=4,green=4,blue=4"])
    run = train_encoder(str(lipstick_dataset), None, str(tmp_path / "weighted"), config)
    assert run.read_log()[-1]["step"] == 3 and np.isfinite(run.read_log()[-1]["graphics"])
    recorded = json.loads((run.path / "config.json").read_text())
    assert (recorded["graphics_error"], recorded["parameter_weights"]) == ("absolute", "red=4,green=4,blue=4")
    config = resolve_config(EncoderConfig, None, settings + ["parameter_weights=rouge=4"])
    with pytest.raises(VtoError, match="'rouge=4' is not name=weight"):
        train_encoder(str(lipstick_dataset), None, str(tmp_path / "bad"), config)
    assert not (tmp_path / "bad").exists()
    mixed = resolve_config(EncoderConfig, None, TINY_ENCODER + ["steps=3", "loss=graphics",
                                                                "absolute_parameters=red,green,blue"])
    run = train_encoder(str(lipstick_dataset), None, str(tmp_path / "mixed"), mixed)
    assert np.isfinite(run.read_log()[-1]["graphics"])
    assert json.loads((run.path / "config.json").read_text())["absolute_parameters"] == "red,green,blue"
    with pytest.raises(VtoError, match="absolute_parameters: rouge not among opacity, red"):
        train_encoder(str(lipstick_dataset), None, str(tmp_path / "bad_name"),
                      dataclasses.replace(mixed, absolute_parameters="rouge"))
    assert not (tmp_path / "bad_name").exists()


def test_encoder_losses_take_the_graphics_error_they_are_given_and_have_no_default():
    from training.losses import graphics_loss
    from training.networks import Encoder
    from training.train_encoder import encoder_losses

    torch.manual_seed(0)
    encoder = Encoder(2, 8, 2).eval()
    batch = {"render": torch.rand(4, 3, 16, 16), "g": torch.rand(4, 2)}
    config = resolve_config(EncoderConfig, None, ["loss=graphics", "graphics_error=squared"])
    with torch.no_grad():
        g_hat = encoder(batch["render"])
        squared = encoder_losses(encoder, None, None, batch, config, error="squared")[1].item()
        mixed = encoder_losses(encoder, None, None, batch, config, error=[False, True])[1].item()
        assert squared == pytest.approx(graphics_loss(batch["g"], g_hat, None, "squared").item())
        assert mixed == pytest.approx(graphics_loss(batch["g"], g_hat, None, [False, True]).item())
    assert squared != mixed
    with pytest.raises(TypeError, match="error"):  # config.graphics_error alone would drop absolute_parameters
        encoder_losses(encoder, None, None, batch, config)


def test_encoder_with_rendering_loss_trains_through_the_imitator(lipstick_dataset, imitator_run, tmp_path):
    config = resolve_config(EncoderConfig, None, TINY_ENCODER + ["steps=10"])
    last = train_encoder(str(lipstick_dataset), str(imitator_run), str(tmp_path / "both"), config).read_log()[-1]
    assert last["total"] == pytest.approx(last["graphics"] + 20 * last["rendering"], rel=1e-5)
    assert last["rendering_weighted"] == pytest.approx(20 * last["rendering"], rel=1e-5)
    assert last["graphics_weighted"] == last["graphics"]
    with pytest.raises(VtoError, match="needs --imitator"):
        train_encoder(str(lipstick_dataset), None, str(tmp_path / "none"), config)
    assert not (tmp_path / "none").exists()


def test_a_batch_norm_encoder_trains_and_exports_mirror_averaged_with_its_running_statistics(lipstick_dataset,
                                                                                              tmp_path):
    config = resolve_config(EncoderConfig, None, TINY_ENCODER + ["steps=5", "loss=graphics", "blocks=1",
                                                                 "batch_norm=true", "augment=true"])
    run = train_encoder(str(lipstick_dataset), None, str(tmp_path / "bn"), config)
    state = run.load_checkpoint()
    assert state["model_args"]["blocks"] == 1 and state["model_args"]["batch_norm"] == 1
    assert any(k.endswith("running_var") and not torch.all(v == 1) for k, v in state["model"].items())
    assert export_encoder(str(run.path), str(tmp_path / "bn.onnx"))["max_abs_diff"] <= 1e-4
    # trained on mirrored views: the file reads each image and its mirror and averages the two
    import onnx

    metadata = {p.key: p.value for p in onnx.load(str(tmp_path / "bn.onnx")).metadata_props}
    assert metadata["vto.mirror_averaged"] == "true"
    images = np.random.default_rng(1).random((3, 3, 16, 16), dtype=np.float32)
    direct, mirrored = mirror_readings(state, images)
    got = EncoderSession(tmp_path / "bn.onnx").predict_unit_nchw(images)
    assert np.abs(got - 0.5 * (direct + mirrored)).max() <= 1e-4 and np.abs(direct - mirrored).max() > 1e-3
    single = export_encoder(str(run.path), str(tmp_path / "single.onnx"), mirror=False)  # vto export --single-view
    assert single["mirror_averaged"] is False
    assert np.abs(EncoderSession(tmp_path / "single.onnx").predict_unit_nchw(images) - direct).max() <= 1e-4
    # vto export --smooth-input: the same file reading its input box-filtered over 3 x 3 pixels, edges repeated
    smooth = export_encoder(str(run.path), str(tmp_path / "smooth.onnx"), smooth=True)
    assert smooth["input_filter"] == [3] and smooth["max_abs_diff"] <= 1e-4
    metadata = {p.key: p.value for p in onnx.load(str(tmp_path / "smooth.onnx")).metadata_props}
    assert metadata["vto.input_filter"] == "box 3x3, edges repeated"
    padded = np.pad(images, ((0, 0), (0, 0), (1, 1), (1, 1)), mode="edge")
    boxed = sum(padded[:, :, dy:dy + 16, dx:dx + 16] for dy in range(3) for dx in range(3)) / np.float32(9)
    expected = EncoderSession(tmp_path / "bn.onnx").predict_unit_nchw(boxed.astype(np.float32))
    smoothed = EncoderSession(tmp_path / "smooth.onnx").predict_unit_nchw(images)
    assert np.abs(smoothed - expected).max() <= 1e-4 and np.abs(smoothed - got).max() > 1e-3


def test_runs_of_one_spec_export_averaged_into_one_file_and_others_are_refused(lipstick_dataset, colour_dataset,
                                                                             tmp_path):
    runs = []
    for seed in (0, 1):
        config = resolve_config(EncoderConfig, None, TINY_ENCODER + ["steps=5", "loss=graphics", f"seed={seed}"])
        runs.append(str(train_encoder(str(lipstick_dataset), None, str(tmp_path / f"run{seed}"), config).path))
        export_encoder(runs[-1], str(tmp_path / f"run{seed}.onnx"))
    result = export_encoder(runs, str(tmp_path / "both.onnx"))
    assert result["averaged_runs"] == 2 and result["max_abs_diff"] <= 1e-4
    images = np.random.default_rng(2).random((4, 3, 16, 16), dtype=np.float32)
    one, other = (EncoderSession(tmp_path / f"run{seed}.onnx").predict_unit_nchw(images) for seed in (0, 1))
    assert np.abs(one - other).max() > 1e-3  # two seeds: two readings
    np.testing.assert_allclose(EncoderSession(tmp_path / "both.onnx").predict_unit_nchw(images), (one + other) / 2,
                               atol=1e-5)
    config = resolve_config(EncoderConfig, None, TINY_ENCODER + ["steps=2", "loss=graphics"])
    colour = str(train_encoder(str(colour_dataset), None, str(tmp_path / "colour"), config).path)
    with pytest.raises(VtoError, match="has another parameter spec than .*run0: runs averaged into one file need one"):
        export_encoder([runs[0], colour], str(tmp_path / "mixed.onnx"))
    assert not list(tmp_path.glob("*mixed.onnx"))


def test_weights_average_into_one_network_and_a_file_with_itself_is_the_file(lipstick_dataset, tmp_path):
    """--average weights: one network whose every weight is the runs' mean (an exported file may stand in for a run);
    a run averaged with its own export reads as that export, two seeds' soup as neither, another network is refused."""
    import onnx

    from training.export import onnx_tensors

    runs = []
    for seed in (0, 1):
        config = resolve_config(EncoderConfig, None, TINY_ENCODER + ["steps=3", "loss=graphics", f"seed={seed}",
                                                                     "augment=true", "batch_norm=true"])
        runs.append(str(train_encoder(str(lipstick_dataset), None, str(tmp_path / f"run{seed}"), config).path))
        export_encoder(runs[-1], str(tmp_path / f"run{seed}.onnx"))
    images = np.random.default_rng(3).random((4, 3, 16, 16), dtype=np.float32)
    one = EncoderSession(tmp_path / "run0.onnx").predict_unit_nchw(images)
    result = export_encoder([runs[0], str(tmp_path / "run0.onnx")], str(tmp_path / "self.onnx"), average="weights")
    assert result["averaged"] == "weights" and result["mirror_averaged"]
    np.testing.assert_allclose(EncoderSession(tmp_path / "self.onnx").predict_unit_nchw(images), one, atol=1e-5)
    export_encoder([runs[0], str(tmp_path / "run1.onnx")], str(tmp_path / "soup.onnx"), average="weights")
    stored = [onnx_tensors(str(tmp_path / f"{name}.onnx")) for name in ("run0", "run1", "soup")]
    assert len(stored[2]) == len(stored[0])  # one network, not two read side by side
    averaged = [name for name, tensor in stored[2].items() if tensor.is_floating_point()
                and not torch.equal(stored[0][name], stored[1][name])]
    assert averaged
    for name in averaged:
        torch.testing.assert_close(stored[2][name], (stored[0][name] + stored[1][name]) / 2, atol=1e-6, rtol=0)
    metadata = {p.key: p.value for p in onnx.load(str(tmp_path / "soup.onnx")).metadata_props}
    assert metadata["vto.averaged"] == "weights" and metadata["vto.averaged_runs"] == "2"
    wider = resolve_config(EncoderConfig, None, TINY_ENCODER + ["steps=2", "loss=graphics", "width=4"])
    other = str(train_encoder(str(lipstick_dataset), None, str(tmp_path / "wider"), wider).path)
    with pytest.raises(VtoError, match="weights average only over one network"):
        export_encoder([runs[0], other], str(tmp_path / "mixed.onnx"), average="weights")
    with pytest.raises(VtoError, match="needs a run before it"):
        export_encoder([str(tmp_path / "run0.onnx"), runs[0]], str(tmp_path / "mixed.onnx"), average="weights")
    assert not list(tmp_path.glob("*mixed.onnx"))


def test_export_matches_torch_and_refuses_another_spec(lipstick_dataset, tmp_path):
    config = resolve_config(EncoderConfig, None, TINY_ENCODER + ["steps=5", "loss=graphics"])
    run = train_encoder(str(lipstick_dataset), None, str(tmp_path / "encoder"), config)
    result = export_encoder(str(run.path), str(tmp_path / "encoder.onnx"))
    assert result["max_abs_diff"] <= 1e-4
    import onnx

    model = onnx.load(str(tmp_path / "encoder.onnx"))
    onnx.checker.check_model(model)
    metadata = {p.key: p.value for p in model.metadata_props}
    assert metadata["vto.renderer"] == "lipstick" and metadata["vto.input_size"] == "16x16"
    assert metadata["vto.mirror_averaged"] == "false"  # trained without mirrored views: read once
    spec = get_spec("lipstick", "opacity,red,green,blue")
    session = EncoderSession(tmp_path / "encoder.onnx", expected_spec=spec)
    sample = DatasetReader(lipstick_dataset)[0]
    values = session.predict(sample.render)[0]
    assert set(values) == set(get_spec("lipstick").by_name) and all(np.isfinite(list(values.values())))
    # any size, HDR, NaN, black and constant images give finite parameters inside the ranges
    odd = [np.full((40, 24, 3), 50.0, np.float32), np.zeros((16, 16, 3), np.float32),
           np.full((16, 16, 3), 0.5, np.float32), np.where(np.eye(16)[..., None] > 0, np.nan, 0.3).repeat(3, -1)]
    for estimate in session.predict(odd):
        assert all(np.isfinite(v) for v in estimate.values())
        assert all(spec.by_name[k].low <= v <= spec.by_name[k].high for k, v in estimate.items() if k in spec.modelled)
    with pytest.raises(VtoError, match=r"estimates lipstick \[opacity, red, green, blue\], not lipstick \[red\]"):
        EncoderSession(tmp_path / "encoder.onnx", expected_spec=get_spec("lipstick", "red"))
    with pytest.raises(VtoError, match="not a VTO encoder|cannot load"):
        (tmp_path / "junk.onnx").write_bytes(b"not a model")
        EncoderSession(tmp_path / "junk.onnx")


def test_train_cli_smoke_and_errors(lipstick_dataset, tmp_path, capsys):
    out = tmp_path / "cli"
    argv = ["train", "imitator", "--data", str(lipstick_dataset), "--out", str(out), "--set", "steps=2"]
    assert cli.run(argv + sum((["--set", s] for s in TINY_IMITATOR), [])) == 0
    assert json.loads(capsys.readouterr().out.strip().splitlines()[-1])["step"] == 2
    assert cli.run(["train", "imitator", "--data", str(lipstick_dataset), "--out", str(tmp_path / "x"),
                    "--set", "bogus=1"]) == 2
    assert "unknown setting 'bogus'" in capsys.readouterr().err
    if not torch.cuda.is_available():
        assert cli.run(argv + ["--device", "cuda"]) == 2
        assert "no CUDA device" in capsys.readouterr().err
    assert cli.run(["export", "--encoder", str(out), "--out", str(tmp_path / "e.onnx")]) == 2
    assert "export takes an encoder run" in capsys.readouterr().err


def test_missing_data_is_a_clear_error_that_leaves_no_run_folder(tmp_path, capsys):
    out = tmp_path / "run"
    assert cli.run(["train", "imitator", "--data", str(tmp_path / "nothing"), "--out", str(out)]) == 2
    assert "is not a dataset" in capsys.readouterr().err
    assert not out.exists()


def test_a_resumed_run_sees_the_batches_an_unbroken_run_sees(lipstick_dataset, tmp_path):
    """N steps, or N/2 + resume for N/2: the same data order, so the same weights (graphics loss is deterministic)."""
    config = TINY_ENCODER + ["loss=graphics", "checkpoint_every=3"]
    whole = train_encoder(str(lipstick_dataset), None, str(tmp_path / "whole"), resolve_config(EncoderConfig, None,
                                                                                                 config + ["steps=6"]))
    half = tmp_path / "half"
    train_encoder(str(lipstick_dataset), None, str(half), resolve_config(EncoderConfig, None, config + ["steps=3"]))
    resumed = train_encoder(str(lipstick_dataset), None, str(half), resolve_config(EncoderConfig, None,
                                                                                    config + ["steps=6"]))
    a, b = whole.load_checkpoint()["model"], resumed.load_checkpoint()["model"]
    assert all(torch.allclose(a[k], b[k], atol=1e-6) for k in a)
    # the sampler's state is in the checkpoint: samples consumed (19 training samples, so batch 16)
    assert whole.load_checkpoint()["data_position"] == resumed.load_checkpoint()["data_position"] == 6 * 16



def test_batches_resume_and_shard_like_one_unbroken_process(lipstick_dataset):
    """From a saved position the same batches follow; two DistributedSampler shards together are the same batches."""
    from itertools import islice

    from training.data import RenderDataset, training_batches

    dataset = RenderDataset(DatasetReader(lipstick_dataset), list(range(18)))
    ids = lambda batches, count: [batch["g"] for batch in islice(batches, count)]  # noqa: E731
    unbroken = ids(training_batches(dataset, 8, seed=4), 6)  # 48 samples: across two epoch boundaries
    assert [torch.equal(a, b) for a, b in zip(unbroken[3:], ids(training_batches(dataset, 8, 4, position=24), 3))] \
        == [True] * 3
    assert not torch.equal(unbroken[0], ids(training_batches(dataset, 8, seed=5), 1)[0])  # another seed, other order
    ranks = [ids(training_batches(dataset, 8, 4, position=24, rank=r, world_size=2), 3) for r in (0, 1)]
    for step in range(3):  # each rank gets 4 of the 8; together the very samples of the unbroken batch
        together = torch.cat([ranks[0][step], ranks[1][step]])
        assert len(ranks[0][step]) == 4 and sorted(map(tuple, together.tolist())) == \
            sorted(map(tuple, unbroken[3 + step].tolist()))
    with pytest.raises(VtoError, match="batch_size 9 does not split evenly over 2 processes"):
        training_batches(dataset, 9, 4, world_size=2)


def test_epoch_sampler_continues_where_it_stopped():
    from training.data import EpochSampler

    unbroken = list(__import__("itertools").islice(iter(EpochSampler(7, seed=3)), 20))
    resumed = list(__import__("itertools").islice(iter(EpochSampler(7, seed=3, start=9)), 11))
    assert resumed == unbroken[9:] and sorted(unbroken[:7]) == list(range(7)) and unbroken[:7] != unbroken[7:14]


def test_the_encoder_refuses_an_imitator_for_another_spec_or_size(lipstick_dataset, imitator_run, tmp_path):
    from training.train_encoder import load_frozen_imitator

    spec = get_spec("lipstick", "opacity,red,green,blue")
    assert load_frozen_imitator(str(imitator_run), spec, "cpu", [16, 16]) is not None
    with pytest.raises(VtoError, match=r"models \[opacity, red, green, blue\], this dataset \[red\]"):
        load_frozen_imitator(str(imitator_run), get_spec("lipstick", "red"), "cpu", [16, 16])
    with pytest.raises(VtoError, match="imitates the lipstick renderer, not hair"):
        load_frozen_imitator(str(imitator_run), get_spec("hair"), "cpu", [16, 16])
    with pytest.raises(VtoError, match=r"trained on \[16, 16\] images, this dataset has \[64, 64\]"):
        load_frozen_imitator(str(imitator_run), spec, "cpu", [64, 64])


def test_an_encoder_trains_on_a_dataset_without_sources_and_the_imitator_refuses_it(imitator_run, tmp_path):
    from blender_addon.datasets.commands import cmd_dataset

    data = tmp_path / "lean"  # the imitator's spec and size, so only the missing sources can refuse it
    assert cmd_dataset(["lipstick", "--out", str(data), "--n", "12", "--res", "16", "--samples", "1", "--params",
                        "opacity,red,green,blue", "--no-source", "--quiet"]) == 0
    run = train_encoder(str(data), None, str(tmp_path / "encoder"),
                        resolve_config(EncoderConfig, None, TINY_ENCODER + ["steps=20", "loss=graphics"]))
    assert np.isfinite(run.read_log()[-1]["val_param_mse"])
    with pytest.raises(VtoError, match="made with --no-source"):
        train_imitator(str(data), str(tmp_path / "imitator"), imitator_config("steps=2", "use_sensitivity=false"))
    with pytest.raises(VtoError, match="made with --no-source"):
        train_encoder(str(data), str(imitator_run), str(tmp_path / "both"),
                      resolve_config(EncoderConfig, None, TINY_ENCODER + ["steps=2", "loss=rendering"]))
    assert not (tmp_path / "imitator").exists()
    from training.data import RenderDataset
    from vto_core.dataset import DatasetReader

    reader = DatasetReader(str(data))  # one image a look: 12 looks of 16 px RGB float32 fit in exactly that
    assert RenderDataset(reader, list(range(12)), cache_bytes=12 * 16 * 16 * 3 * 4, need_source=False).cache == {}
    assert RenderDataset(reader, list(range(12)), cache_bytes=12 * 16 * 16 * 3 * 4 - 1, need_source=False).cache is None


def test_mouth_views_train_a_lipstick_encoder_and_are_refused_for_hair(lipstick_dataset, tmp_path):
    pytest.importorskip("bpy")
    from blender_addon.datasets.commands import cmd_dataset

    config = resolve_config(EncoderConfig, None, TINY_ENCODER + ["steps=3", "loss=graphics", "mouth_views=true",
                                                                 "photo_views=true", "augment=true"])
    last = train_encoder(str(lipstick_dataset), None, str(tmp_path / "lips"), config).read_log()[-1]
    assert np.isfinite(last["graphics"]) and last["step"] == 3
    hair = tmp_path / "hair"
    assert cmd_dataset(["hair", "--out", str(hair), "--n", "2", "--seed", "3", "--res", "16", "--samples", "2",
                        "--quiet"]) == 0
    with pytest.raises(VtoError, match="mouth_views paints teeth over lips: a hair dataset has none"):
        train_encoder(str(hair), None, str(tmp_path / "hair_run"), config)
    assert not (tmp_path / "hair_run").exists()


def test_a_run_starts_from_an_exported_encoder_and_refuses_another_network(colour_dataset, tmp_path):
    """init=FILE.onnx: step 0 reads as the file does (fine-tuning); a network of another shape is refused."""
    config = resolve_config(EncoderConfig, None, TINY_ENCODER + ["steps=3", "loss=graphics", "augment=true"])
    run = train_encoder(str(colour_dataset), None, str(tmp_path / "first"), config)
    export_encoder(str(run.path), str(tmp_path / "first.onnx"))
    started = resolve_config(EncoderConfig, None, TINY_ENCODER + ["steps=1", "loss=graphics", "lr=1e-12",
                                                                 f"init={tmp_path / 'first.onnx'}"])
    state = train_encoder(str(colour_dataset), None, str(tmp_path / "tuned"), started).load_checkpoint()
    images = np.random.default_rng(2).random((2, 3, 16, 16), dtype=np.float32)
    direct, mirrored = mirror_readings(state, images)
    assert np.abs(EncoderSession(tmp_path / "first.onnx").predict_unit_nchw(images)
                  - 0.5 * (direct + mirrored)).max() <= 1e-4
    wider = resolve_config(EncoderConfig, None, TINY_ENCODER + ["steps=1", "loss=graphics", "width=4",
                                                               f"init={tmp_path / 'first.onnx'}"])
    with pytest.raises(VtoError, match="another network"):
        train_encoder(str(colour_dataset), None, str(tmp_path / "wider"), wider)
    assert not (tmp_path / "wider").exists()


def test_a_colour_loss_without_its_imitator_or_with_another_spec_is_refused_before_a_run_folder(colour_dataset,
                                                                                                tmp_path):
    from pathlib import Path

    shipped = Path(__file__).resolve().parents[2] / "blender_addon" / "models" / "lipstick_colour.onnx"
    for extra, message in ((["lambda_colour=1"], "needs colour_imitator"),
                           (["lambda_colour=1", f"colour_imitator={shipped}"], "not a colour imitator of the data")):
        config = resolve_config(EncoderConfig, None, TINY_ENCODER + ["steps=1", "loss=graphics", *extra])
        with pytest.raises(VtoError, match=message):
            train_encoder(str(colour_dataset), None, str(tmp_path / "run"), config)
        assert not (tmp_path / "run").exists()
