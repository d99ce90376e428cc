"""Dataset generation: determinism, kill-and-resume, shards, sensitivity renders, bad arguments."""

import hashlib
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

pytestmark = pytest.mark.blender
bpy = pytest.importorskip("bpy")

from blender_addon.datasets.commands import cmd_dataset  # noqa: E402
from blender_addon.renderers.product_lipstick import render_lipstick  # noqa: E402
from vto_core import cli  # noqa: E402
from vto_core.dataset import DatasetReader, shard_from_env, shard_range  # noqa: E402
from vto_core.errors import VtoError  # noqa: E402
from vto_core.products import get_spec  # noqa: E402

TINY = ["--res", "16", "--samples", "2", "--params", "red,gloss", "--seed", "5", "--quiet"]


def tree_hashes(root: Path) -> dict[str, str]:
    """Relative path -> sha256 of every file under root."""
    return {str(p.relative_to(root)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(root.rglob("*")) if p.is_file()}


def make(out, n, *extra):
    assert cmd_dataset(["lipstick", "--out", str(out), "--n", str(n), *TINY, *extra]) == 0


def test_two_runs_give_identical_files_and_the_loader_reads_them(tmp_path):
    make(tmp_path / "a", 3, "--sensitivity")
    make(tmp_path / "b", 3, "--sensitivity")
    assert tree_hashes(tmp_path / "a") == tree_hashes(tmp_path / "b")
    reader = DatasetReader(tmp_path / "a")
    assert len(reader) == 3 and reader.spec.modelled == ("red", "gloss")
    sample = reader[1]
    assert sample.source.shape == sample.render.shape == (16, 16, 3)
    assert sample.sensitivity.shape == (2, 16, 16, 3) and sample.sensitivity_unit.shape == (2, 2)
    assert np.allclose(get_spec("lipstick", "red,gloss").normalise(sample.raw), sample.unit, atol=1e-6)
    assert sample.record["values"]["sparkle_density"] == 0.0, "unmodelled parameters stay at their defaults"
    manifest = json.loads((tmp_path / "a" / "manifest.json").read_text())
    assert manifest["blender_version"] == bpy.app.version_string and manifest["params"] == ["red", "gloss"]


def test_sensitivity_renders_differ_only_through_parameter_j(tmp_path):
    make(tmp_path / "d", 1, "--sensitivity")
    sample = DatasetReader(tmp_path / "d")[0]
    spec = get_spec("lipstick", "red,gloss")
    for j in range(spec.size):
        moved = np.nonzero(~np.isclose(sample.sensitivity_unit[j], sample.unit))[0].tolist()
        assert moved == [j]
        # the file is exactly R(X, g'_j): re-render g'_j from the recorded vector
        values = spec.values(spec.denormalise(sample.sensitivity_unit[j]))
        rerender = render_lipstick(values, sample.record["source"], 16, 2, sample.record["cycles_seed"])
        assert np.abs(rerender - sample.sensitivity[j]).max() < 1.0 / 65535 + 1e-6
        if abs(sample.sensitivity_unit[j][j] - sample.unit[j]) > 0.05:  # a redraw can land next to the value
            assert np.abs(sample.sensitivity[j] - sample.render).max() > 1e-3
    assert max(np.abs(s - sample.render).max() for s in sample.sensitivity) > 1e-3


def test_shards_equal_one_run(tmp_path):
    make(tmp_path / "whole", 5)
    for i in range(3):
        make(tmp_path / "sharded", 5, "--shard", f"{i}/3")
    assert tree_hashes(tmp_path / "whole") == tree_hashes(tmp_path / "sharded")


def test_rerun_renders_only_missing_samples(tmp_path):
    make(tmp_path / "r", 3)
    samples = tmp_path / "r" / "samples"
    kept = (samples / "0000000" / "render.png").stat().st_mtime_ns
    removed = tree_hashes(samples / "0000001")
    import shutil

    shutil.rmtree(samples / "0000001")
    make(tmp_path / "r", 3)
    assert (samples / "0000000" / "render.png").stat().st_mtime_ns == kept
    assert tree_hashes(samples / "0000001") == removed


def kill_midway(out, argv: list[str], n: int) -> None:
    """Start `vto dataset ARGV --out OUT` in its own process and SIGKILL it once 2 of its n samples are done."""
    command = [sys.executable, "-m", "vto_core.cli", "dataset", *argv, "--out", str(out)]
    process = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.time() + 120
    while time.time() < deadline and len(list((out / "samples").glob("0*"))) < 2:
        time.sleep(0.05)
    os.kill(process.pid, signal.SIGKILL)
    process.wait()
    done_before = len(list((out / "samples").glob("0*")))
    assert 2 <= done_before < n, "the kill must land mid-run for this test to mean anything"


def test_kill_and_resume_yields_the_uninterrupted_files(tmp_path):
    n = 8
    make(tmp_path / "clean", n)
    kill_midway(tmp_path / "killed", ["lipstick", "--n", str(n), *TINY], n)
    make(tmp_path / "killed", n)
    assert tree_hashes(tmp_path / "clean") == tree_hashes(tmp_path / "killed")


def test_a_shard_started_beside_a_running_one_leaves_its_samples_alone(tmp_path):
    """Shards start at any time on one folder (a cluster's array, a killed shard run again): one starting clears only
    its own half-written samples, and a write probe of another's in the folder does not stop it."""
    out = tmp_path / "sharded"
    make(out, 2, "--shard", "0/2")  # the folder as a first shard leaves it
    (out / ".vto-write-probe").mkdir()  # another run's probe, made under the name every run once used
    writing = out / "samples" / ".tmp-0000003-99999"  # shard 1/2 of 4 looks, writing sample 3 right now
    writing.mkdir()
    make(out, 4, "--shard", "0/2")
    assert writing.is_dir()


def test_killed_and_resumed_hair_dataset_equals_an_uninterrupted_one(tmp_path):
    n, tiny = 6, ["--res", "16", "--samples", "2", "--params", "hue,shine", "--seed", "5", "--quiet"]
    assert cmd_dataset(["hair", "--out", str(tmp_path / "clean"), "--n", str(n), *tiny]) == 0
    kill_midway(tmp_path / "killed", ["hair", "--n", str(n), *tiny], n)
    assert cmd_dataset(["hair", "--out", str(tmp_path / "killed"), "--n", str(n), *tiny]) == 0
    assert tree_hashes(tmp_path / "clean") == tree_hashes(tmp_path / "killed")


def test_eyeshadow_dataset_resumes_after_a_kill_and_shards_to_the_same_files(tmp_path):
    """The default eye scene repeats as the lips' does: 2 shards give one run's bytes, and so does a run killed and
    resumed in another process (an eyeball made by bmesh, whose faces come in another order in each process,
    differed there in the last bit: scene_lips.uv_sphere)."""
    n, tiny = 6, ["--res", "16", "--samples", "2", "--seed", "8", "--quiet"]
    assert cmd_dataset(["eyeshadow", "--out", str(tmp_path / "clean"), "--n", str(n), *tiny]) == 0
    for i in range(2):
        assert cmd_dataset(["eyeshadow", "--out", str(tmp_path / "sharded"), "--n", str(n), *tiny,
                            "--shard", f"{i}/2"]) == 0
    assert tree_hashes(tmp_path / "clean") == tree_hashes(tmp_path / "sharded")
    kill_midway(tmp_path / "killed", ["eyeshadow", "--n", str(n), *tiny], n)
    assert cmd_dataset(["eyeshadow", "--out", str(tmp_path / "killed"), "--n", str(n), *tiny]) == 0
    assert tree_hashes(tmp_path / "clean") == tree_hashes(tmp_path / "killed")


@pytest.mark.parametrize("stop", [signal.SIGTERM, signal.SIGKILL])
def test_workers_stop_when_their_run_is_killed(tmp_path, stop):
    """`kill` (SIGTERM) ends the workers with the run; after kill -9 each worker sees it is orphaned and stops, so a
    run started again on the folder is not rendered beside."""
    out, n = tmp_path / "killed", 3000
    command = [sys.executable, "-m", "vto_core.cli", "dataset", "lipstick", "--n", str(n), *TINY, "--out", str(out),
               "--workers", "2", "--restart-every", str(n)]
    process = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.time() + 120
    while time.time() < deadline and len(list((out / "samples").glob("0*"))) < 4:
        time.sleep(0.05)
    os.kill(process.pid, stop)
    assert process.wait(timeout=30) != 0
    time.sleep(3)  # a sample in flight may still land
    settled = len(list((out / "samples").glob("0*")))
    time.sleep(3)
    assert len(list((out / "samples").glob("0*"))) == settled < n


def test_two_workers_make_the_same_files(tmp_path):
    make(tmp_path / "one", 4)
    make(tmp_path / "two", 4, "--workers", "2")
    assert tree_hashes(tmp_path / "one") == tree_hashes(tmp_path / "two")


@pytest.mark.parametrize("argv, message", [
    (["--n", "0"], "--n must be at least 1"),
    (["--n", "4", "--shard", "3/2"], "need 0 <= i < K"),
    (["--n", "4", "--params", "red,shimmer"], "unknown lipstick parameter"),
    (["--n", "4", "--workers", "0"], "--workers must be at least 1"),
    (["--n", "4", "--res", "4"], "--res must be in [8, 4096]"),
    (["--n", "4", "--uniform-ratio", "1.5"], "--uniform-ratio must be in [0, 1]"),
    (["--n", "4", "--source-folder", "/no/such/folder"], "is not a folder"),
    (["--n", "4", "--params", "red,gloss", "--vary", "red"], "--vary takes unmodelled lipstick inputs"),
    (["--n", "4", "--vary", "shimmer"], "--vary takes unmodelled lipstick inputs"),
    (["--n", "4", "--preset-kernel", "0.7"], "--preset-kernel must be in [0, 0.5]"),
    (["--n", "4", "--without-presets", "Classic Red,No Such Shade"], "no lipstick preset named No Such Shade"),
    (["--n", "4", "--params", "red,gloss", "--uniform-lightness"], "--uniform-lightness moves the colour"),
    (["--n", "4", "--params", "red,gloss", "--uniform-params", "red,shimmer"], "--uniform-params: shimmer is not"),
    (["--n", "4", "--uniform-params", "red", "--uniform-ratio", "1"], "--uniform-params mixes uniform and preset"),
])
def test_bad_arguments_are_clear_errors_and_write_nothing(tmp_path, capsys, argv, message):
    out = tmp_path / "bad"
    assert cli.run(["dataset", "lipstick", "--out", str(out), "--res", "16", "--samples", "1", *argv]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0]
    assert not out.exists()


def test_unwritable_output_is_a_clear_error(tmp_path, capsys):
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    assert cli.run(["dataset", "lipstick", "--out", str(blocker / "ds"), "--n", "2", "--res", "16"]) == 2
    assert "cannot write to" in capsys.readouterr().err


def test_changed_settings_in_an_existing_folder_are_refused(tmp_path):
    make(tmp_path / "m", 2)
    with pytest.raises(VtoError, match="other settings"):
        cmd_dataset(["lipstick", "--out", str(tmp_path / "m"), "--n", "2", *TINY[:-1], "--res", "24"])


def test_a_larger_n_grows_the_dataset_and_a_smaller_one_is_refused(tmp_path):
    make(tmp_path / "grown", 2)
    before = tree_hashes(tmp_path / "grown")
    make(tmp_path / "grown", 3)
    make(tmp_path / "whole", 3)
    grown = tree_hashes(tmp_path / "grown")
    assert all(grown[k] == v for k, v in before.items() if k != "manifest.json")  # finished samples untouched
    assert grown == tree_hashes(tmp_path / "whole")
    with pytest.raises(VtoError, match="not shrink"):
        make(tmp_path / "grown", 2)
    assert json.loads((tmp_path / "grown" / "manifest.json").read_text())["n"] == 3


def test_scheduler_environment_selects_the_shard():
    assert shard_from_env({"SLURM_ARRAY_TASK_ID": "2", "SLURM_ARRAY_TASK_COUNT": "4"}) == (2, 4)
    assert shard_from_env({"SLURM_ARRAY_TASK_ID": "3", "SLURM_ARRAY_TASK_COUNT": "3", "SLURM_ARRAY_TASK_MIN": "1"}) == (2, 3)
    assert shard_from_env({"JOB_COMPLETION_INDEX": "1", "VTO_SHARD_COUNT": "2"}) == (1, 2)
    assert shard_from_env({}) == (0, 1)
    with pytest.raises(VtoError, match="VTO_SHARD_COUNT"):
        shard_from_env({"JOB_COMPLETION_INDEX": "1"})
    assert [list(shard_range(10, (i, 3))) for i in range(3)] == [[0, 1, 2], [3, 4, 5], [6, 7, 8, 9]]


def test_hair_dataset_from_a_photo_folder(tmp_path):
    from blender_addon.renderers.hair import render_hair_source
    from vto_core.imageio import write_image

    photos = tmp_path / "photos"
    photos.mkdir()
    for seed in (1, 2):
        source = render_hair_source(seed, 16, 2)
        write_image(photos / f"p{seed}.png", source.rgb, bits=16)
        write_image(photos / f"p{seed}_mask.png", source.mask)
    out = tmp_path / "hair"
    assert cmd_dataset(["hair", "--out", str(out), "--n", "3", "--res", "16", "--source-folder", str(photos),
                        "--params", "hue,intensity", "--sensitivity", "--quiet"]) == 0
    reader = DatasetReader(out)
    for position in range(3):
        sample = reader[position]
        photo = photos / f"p{1 + sample.record['source'] % 2}.png"
        from vto_core.imageio import read_image

        assert np.abs(sample.source - read_image(photo)[0]).max() < 1e-4
        assert sample.mask is not None and sample.mask.max() == 1.0
        assert sample.sensitivity.shape == (2, 16, 16, 3)


def test_no_source_skips_the_x_render_and_keeps_every_other_byte(tmp_path, capsys):
    """--no-source: the same renders and parameters as a full dataset, no source.png, one render fewer a look."""
    make(tmp_path / "full", 3)
    make(tmp_path / "lean", 3, "--no-source")
    full, lean = tree_hashes(tmp_path / "full"), tree_hashes(tmp_path / "lean")
    assert {k: v for k, v in full.items() if not k.endswith("source.png") and k != "manifest.json"} == \
        {k: v for k, v in lean.items() if k != "manifest.json"}
    assert not any(k.endswith("source.png") for k in lean) and sum(k.endswith("source.png") for k in full) == 3
    reader = DatasetReader(tmp_path / "lean")
    assert reader.manifest["source_images"] is False and not reader.has_sources and reader[0].source is None
    assert "source_images" not in DatasetReader(tmp_path / "full").manifest  # datasets made before still resume
    assert cli.run(["dataset", "lipstick", "--out", str(tmp_path / "bad"), "--n", "2", "--no-source",
                    "--sensitivity", *TINY]) == 2
    assert "--sensitivity renders are for the imitator" in capsys.readouterr().err


def test_no_source_counts_one_render_a_lipstick_look():
    from blender_addon.datasets.dataset import DatasetJob, renders_per_sample

    assert renders_per_sample(DatasetJob("lipstick", "x", 1)) == 2
    assert renders_per_sample(DatasetJob("lipstick", "x", 1, source_images=False)) == 1


def test_preset_kernels_draw_about_the_presets_left_in_and_are_recorded(tmp_path):
    """--preset-kernel with --without-presets: each look near a preset left in (uniform ratio 0), the settings in the
    manifest; a dataset without them keeps the manifest it had."""
    from vto_core.presets import load_presets

    make(tmp_path / "plain", 2)
    make(tmp_path / "kernels", 4, "--uniform-ratio", "0", "--preset-kernel", "0.01", "--without-presets",
         "Goth Black Matte")
    plain, kernels = DatasetReader(tmp_path / "plain"), DatasetReader(tmp_path / "kernels")
    assert "preset_kernel" not in plain.manifest and "without_presets" not in plain.manifest
    assert kernels.manifest["preset_kernel"] == 0.01 and kernels.manifest["without_presets"] == ["Goth Black Matte"]
    presets = load_presets("lipstick")
    for i in range(4):
        values = json.loads((kernels.root / "samples" / f"{i:07d}" / "params.json").read_text())["values"]
        nearest = min(presets, key=lambda name: abs(presets[name]["red"] - values["red"]) / 255
                      + abs(presets[name]["gloss"] - values["gloss"]))
        assert nearest != "Goth Black Matte" and abs(presets[nearest]["red"] - values["red"]) < 0.05 * 255


def test_uniform_lightness_is_recorded_and_moves_only_the_uniform_colours(tmp_path):
    """--uniform-lightness, all draws uniform: the looks' colours differ from a plain run's, their other values do
    not; the manifest records it (a dataset without it keeps the manifest it had)."""
    colour = ["--params", "red,green,blue,gloss", "--uniform-ratio", "1"]
    make(tmp_path / "plain", 3, *colour)
    make(tmp_path / "even", 3, *colour, "--uniform-lightness")
    plain, even = DatasetReader(tmp_path / "plain"), DatasetReader(tmp_path / "even")
    assert "uniform_lightness" not in plain.manifest and even.manifest["uniform_lightness"] is True
    for i in range(3):
        a, b = (json.loads((r.root / "samples" / f"{i:07d}" / "params.json").read_text())["values"]
                for r in (plain, even))
        assert any(abs(a[c] - b[c]) > 1.0 for c in ("red", "green", "blue"))
        assert all(a[k] == b[k] for k in a if k not in ("red", "green", "blue"))


def test_uniform_params_are_recorded_and_leave_the_spread_parameters_as_they_were(tmp_path):
    """--uniform-params red, nearly all draws uniform: each look's red is a plain run's, its gloss a preset draw's;
    the manifest records the parameters (a dataset without them keeps the manifest it had)."""
    from vto_core.presets import load_presets

    settings = ["--uniform-ratio", "0.999999", "--preset-kernel", "0.01"]
    make(tmp_path / "plain", 3, *settings)
    make(tmp_path / "red", 3, *settings, "--uniform-params", "red")
    plain, red = DatasetReader(tmp_path / "plain"), DatasetReader(tmp_path / "red")
    assert "uniform_params" not in plain.manifest and red.manifest["uniform_params"] == ["red"]
    glosses = {round(values["gloss"], 2) for values in load_presets("lipstick").values()}
    for i in range(3):
        a, b = (json.loads((r.root / "samples" / f"{i:07d}" / "params.json").read_text())["values"]
                for r in (plain, red))
        assert a["red"] == b["red"] and a["gloss"] != b["gloss"]
        assert min(abs(b["gloss"] - g) for g in glosses) < 0.05


def test_vary_draws_an_unmodelled_input_per_look_and_keeps_the_sampled_ones(tmp_path):
    """--vary gloss_roughness: each look its own roughness over [0, 1], the modelled values as without it."""
    make(tmp_path / "plain", 4)
    make(tmp_path / "varied", 4, "--vary", "gloss_roughness")
    plain, varied = DatasetReader(tmp_path / "plain"), DatasetReader(tmp_path / "varied")
    assert varied.manifest["vary"] == ["gloss_roughness"] and "vary" not in plain.manifest
    roughness = []
    for i in range(4):
        before = json.loads((plain.root / "samples" / f"{i:07d}" / "params.json").read_text())
        after = json.loads((varied.root / "samples" / f"{i:07d}" / "params.json").read_text())
        assert after["unit"] == before["unit"] and after["source"] == before["source"]
        assert before["values"]["gloss_roughness"] == 0.3
        roughness.append(after["values"]["gloss_roughness"])
    assert all(0.0 <= r <= 1.0 for r in roughness) and len(set(roughness)) == 4
    assert any(not np.array_equal(plain[i].render, varied[i].render) for i in range(4))  # the coat shows it
    make(tmp_path / "again", 4, "--vary", "gloss_roughness")  # a pure function of (seed, index)
    assert tree_hashes(tmp_path / "again") == tree_hashes(tmp_path / "varied")


def test_looks_share_a_cached_hair_source_and_stay_a_function_of_seed_and_index(tmp_path):
    argv = ["hair", "--n", "4", "--res", "16", "--samples", "2", "--seed", "9", "--looks-per-source", "2", "--quiet"]
    assert cmd_dataset([*argv, "--out", str(tmp_path / "a")]) == 0
    reader = DatasetReader(tmp_path / "a")
    sources = [reader[i].record["source"] for i in range(4)]
    assert sources[0] == sources[1] != sources[2] == sources[3]
    assert np.array_equal(reader[0].source, reader[1].source) and not np.array_equal(reader[0].render,
                                                                                    reader[1].render)
    assert len(list((tmp_path / "a" / "source_cache").glob("*.npz"))) == 2
    assert cmd_dataset([*argv, "--out", str(tmp_path / "b"), "--shard", "1/2"]) == 0  # samples 2, 3 alone
    assert cmd_dataset([*argv, "--out", str(tmp_path / "b"), "--shard", "0/2"]) == 0
    samples = {k: v for k, v in tree_hashes(tmp_path / "a").items() if k.startswith("samples")}
    assert samples == {k: v for k, v in tree_hashes(tmp_path / "b").items() if k.startswith("samples")}
    assert json.loads((tmp_path / "a" / "manifest.json").read_text())["looks_per_source"] == 2


def test_looks_per_source_is_for_the_default_hair_scene_only(tmp_path, capsys):
    assert cli.run(["dataset", "lipstick", "--out", str(tmp_path / "x"), "--n", "2", "--looks-per-source", "2",
                    "--quiet"]) == 2
    assert "default hair scene only" in capsys.readouterr().err and not (tmp_path / "x").exists()
