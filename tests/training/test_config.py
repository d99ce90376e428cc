"""Training settings: typed --set values, presets, epochs, the lr schedule and the progress bar (no data needed)."""

import io
import json

import pytest

pytestmark = pytest.mark.torch
pytest.importorskip("torch")

from training.config import PRESETS, EncoderConfig, ImitatorConfig, resolve_config, with_epochs  # noqa: E402
from training.run import learning_rate, progress  # noqa: E402
from vto_core.errors import VtoError  # noqa: E402


@pytest.mark.parametrize("text, value", [("false", False), ("False", False), ("0", False), ("no", False),
                                         ("true", True), ("1", True), ("on", True)])
def test_set_gives_a_real_bool(text, value):
    assert resolve_config(ImitatorConfig, None, [f"use_gan={text}"]).use_gan is value


def test_set_converts_to_each_field_type():
    config = resolve_config(EncoderConfig, None, ["steps=12", "lr=0.01", "loss=graphics", "schedule=cosine"])
    assert (config.steps, config.lr, config.loss, config.schedule) == (12, 0.01, "graphics", "cosine")
    assert type(config.steps) is int and type(config.lr) is float


@pytest.mark.parametrize("setting, message", [
    ("use_gan=maybe", "not a boolean: maybe"),
    ("steps=2.5", "--set steps=2.5: invalid literal for int"),
    ("steps=0", "steps must be at least 1, got 0"),
    ("log_every=0", "log_every must be at least 1, got 0"),
    ("checkpoint_every=-3", "checkpoint_every must be at least 1, got -3"),
    ("batch_size=0", "batch_size must be at least 1"),
    ("critic_steps=0", "critic_steps must be at least 1"),
    ("epochs=-1", "epochs must be at least 0"),
    ("lr=0", "lr must be positive and finite, got 0.0"),
    ("lr=-1e-3", "lr must be positive and finite"),
    ("lr=inf", "lr must be positive and finite"),
    ("lr=nan", "lr must be positive and finite"),
    ("beta1=1", "beta1 must be in"),
    ("lambda_sens=-1", "lambda_sens must be at least 0"),
    ("schedule=linear", "schedule must be one of constant, cosine, got 'linear'"),
    ("perceptual=lpips", "perceptual must be one of auto, vgg, ssim_l1"),
    ("bogus=1", "unknown setting 'bogus' for ImitatorConfig"),
    ("steps", "--set takes key=value, got 'steps'"),
])
def test_bad_settings_are_one_line_errors(setting, message):
    with pytest.raises(VtoError, match=message.replace("(", r"\(").replace(".", r"\.").replace("+", r"\+")) as error:
        resolve_config(ImitatorConfig, None, [setting])
    assert "\n" not in str(error.value)


def test_encoder_only_settings_are_unknown_to_the_imitator_and_back():
    with pytest.raises(VtoError, match="unknown setting 'loss' for ImitatorConfig"):
        resolve_config(ImitatorConfig, None, ["loss=graphics"])
    with pytest.raises(VtoError, match="unknown setting 'use_gan' for EncoderConfig"):
        resolve_config(EncoderConfig, None, ["use_gan=false"])
    with pytest.raises(VtoError, match="loss must be one of graphics, rendering, both"):
        resolve_config(EncoderConfig, None, ["loss=pixels"])
    with pytest.raises(VtoError, match="graphics_error must be one of squared, absolute, got 'huber'"):
        resolve_config(EncoderConfig, None, ["graphics_error=huber"])


@pytest.mark.parametrize("content, message", [
    ({"use_gan": "false"}, "'use_gan' must be a bool"),
    ({"steps": 2.5}, "'steps' must be an int"),
    ({"lr": True}, "'lr' must be a float"),
    ({"log_every": 0}, "log_every must be at least 1"),
    ({"nonsense": 1}, "unknown setting"),
    ([1, 2], "must hold one JSON object"),
])
def test_config_files_are_type_checked(content, message, tmp_path):
    path = tmp_path / "config.json"
    path.write_text(json.dumps(content))
    with pytest.raises(VtoError, match=message):
        resolve_config(ImitatorConfig, str(path))


def test_set_overrides_a_file_which_overrides_the_defaults(tmp_path):
    path = tmp_path / "config.json"
    path.write_text(json.dumps({"lr": 0.01, "steps": 7}))
    config = resolve_config(EncoderConfig, str(path), ["steps=9"])
    assert (config.lr, config.steps, config.batch_size) == (0.01, 9, 16)
    with pytest.raises(VtoError, match="no config file at .*missing.json"):
        resolve_config(EncoderConfig, str(tmp_path / "missing.json"))


def test_defaults_and_the_paper_preset_are_the_papers_optimiser():
    default = EncoderConfig()
    assert (default.lr, default.batch_size, default.schedule, default.warmup_steps) == (5e-5, 16, "constant", 0)
    paper = resolve_config(ImitatorConfig, "paper")
    assert (paper.lr, paper.batch_size, paper.schedule, paper.epochs) == (5e-5, 16, "constant", 300)
    assert set(PRESETS) == {"paper", "cpu"}
    assert resolve_config(EncoderConfig, "cpu", ["lr=0.003"]).lr == 0.003  # --set still wins
    with pytest.raises(VtoError, match="preset 'cpu' is measured for EncoderConfig only"):
        resolve_config(ImitatorConfig, "cpu")


def test_epochs_set_the_steps_from_the_training_split():
    assert with_epochs(EncoderConfig(steps=5), 1000).steps == 5  # epochs 0: steps as given
    assert with_epochs(EncoderConfig(epochs=300), 15000).steps == 281250  # the paper: 300 x 15,000 / 16
    assert with_epochs(EncoderConfig(epochs=2, batch_size=16), 10).steps == 2  # batch capped at the split


def test_learning_rate_schedules():
    constant = EncoderConfig(steps=100, lr=1e-3)
    assert [learning_rate(constant, s) for s in (0, 50, 99)] == [1e-3] * 3
    cosine = EncoderConfig(steps=100, lr=1e-3, schedule="cosine", warmup_steps=9)
    rates = [learning_rate(cosine, s) for s in range(100)]
    assert rates[:9] == pytest.approx([1e-4 * (s + 1) for s in range(9)])  # linear warm-up to lr
    assert rates[9] == pytest.approx(1e-3)
    assert all(later <= earlier for earlier, later in zip(rates[9:], rates[10:]))
    assert 0 < rates[-1] < 1e-6


class _Terminal(io.StringIO):
    def isatty(self):
        return True


def test_progress_bar_only_on_a_terminal():
    log = io.StringIO()  # a SLURM or CI log
    with progress(10, 0, stream=log) as bar:
        bar.update(10)
    assert log.getvalue() == ""
    terminal = _Terminal()
    with progress(10, 4, stream=terminal) as bar:
        bar.update(6)
    assert "10/10" in terminal.getvalue() and "\r" in terminal.getvalue()
    quiet = _Terminal()
    with progress(10, 0, enabled=False, stream=quiet) as bar:  # ranks other than 0
        bar.update(10)
    assert quiet.getvalue() == ""
