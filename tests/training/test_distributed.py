"""Two CPU processes (gloo) under torchrun train like one: the documented command, DDP, sharded data, rank-0 files."""

import json
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = [pytest.mark.torch, pytest.mark.blender, pytest.mark.slow]
torch = pytest.importorskip("torch")
pytest.importorskip("bpy")

from training.config import EncoderConfig, resolve_config  # noqa: E402
from training.networks import build  # noqa: E402
from training.run import RunFolder  # noqa: E402
from training.train_encoder import load_frozen_imitator, train_encoder  # noqa: E402
from vto_core.products import get_spec  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
TWO = [sys.executable, "-m", "torch.distributed.run", "--standalone", "--nproc_per_node", "2"]
# 24 samples, a quarter held out: 18 to train, so both shards are whole and batch 16 splits 8 + 8.
ENCODER = ["width=8", "n_layers=2", "loss=graphics", "lr=0.003", "steps=6", "log_every=2", "checkpoint_every=3",
           "val_fraction=0.25"]


def torchrun(*argv) -> subprocess.CompletedProcess:
    done = subprocess.run([*TWO, *map(str, argv)], cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-3000:]
    return done


def test_two_processes_train_the_encoder_as_one_does(lipstick_dataset, tmp_path):
    out = tmp_path / "two"
    done = torchrun("-m", "vto_core.cli", "train", "encoder", "--data", lipstick_dataset, "--out", out,
                    *sum((["--set", s] for s in ENCODER), []))
    assert "\r" not in done.stderr  # no progress bar in a log
    log = RunFolder(out).read_log()
    assert [row["step"] for row in log] == [2, 4, 6]  # one writer: rank 0
    assert log[-1]["val_param_mse"] < log[0]["val_param_mse"]
    assert json.loads(done.stdout.strip().splitlines()[-1])["step"] == 6
    checkpoint = RunFolder(out).load_checkpoint(required=True)
    assert checkpoint["step"] == 6 and checkpoint["data_position"] == 6 * 16
    encoder = build("encoder", checkpoint["model_args"])
    encoder.load_state_dict(checkpoint["model"])
    assert torch.isfinite(encoder(torch.rand(2, 3, 16, 16))).all()
    # DDP averages the two half-batch gradients and the shards together are the one-process batch: same weights
    config = resolve_config(EncoderConfig, None, ENCODER)
    one = train_encoder(str(lipstick_dataset), None, str(tmp_path / "one"), config)
    single = one.load_checkpoint()["model"]
    assert all(torch.allclose(checkpoint["model"][k], single[k], atol=1e-5) for k in single)
    assert log[-1]["graphics"] == pytest.approx(one.read_log()[-1]["graphics"], rel=1e-4)


def test_two_process_imitator_with_critic_and_penalty_stays_in_step(lipstick_dataset, tmp_path):
    torchrun(ROOT / "tests" / "training" / "ddp_worker.py", lipstick_dataset, tmp_path,
             "width=8", "n_down=1", "n_res=1", "critic_width=8", "critic_layers=2", "perceptual=ssim_l1",
             "lr=0.002", "steps=4", "log_every=2", "val_fraction=0.25")
    ranks = [torch.load(tmp_path / f"rank{r}.pt") for r in (0, 1)]
    for net in ("imitator", "critic"):
        trained = [rank[net] for rank in ranks]
        assert all(torch.allclose(trained[0][k], trained[1][k], atol=1e-6) for k in trained[0]), net
        assert any(not torch.allclose(trained[0][k], ranks[0][f"{net}_initial"][k]) for k in trained[0]), net
    log = RunFolder(tmp_path / "run").read_log()
    assert [row["step"] for row in log] == [2, 4] and all(torch.isfinite(torch.tensor(row["total"])) for row in log)
    imitator = load_frozen_imitator(str(tmp_path / "run"), get_spec("lipstick", "opacity,red,green,blue"), "cpu",
                                    [16, 16])
    saved = imitator.state_dict()
    assert all(torch.equal(saved[k], ranks[0]["imitator"][k]) for k in saved)
