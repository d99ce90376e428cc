"""Dataset generation (paper 5.2, 6.1): sample g, render X, R(X, g) and R(X, g'_j), one atomic folder per sample."""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

import bpy
import numpy as np

import vto_core
from vto_core.dataset import (DEFAULT_RES, DEFAULT_SAMPLES, FORMAT_VERSION, SampleWriter, finished_indices,
                              remove_stale_temporaries, write_manifest)
from vto_core.errors import VtoError
from vto_core.presets import load_presets, preset_matrix
from vto_core.sampling import COLOUR, ParamSampler
from vto_core.products import PRODUCTS, Product, get_product, get_spec, product_list
from vto_core.specs import RendererSpec

from ..renderers.cycles import sample_setting
from ..renderers.products import blender_side, check_lighting

_SOURCE_STREAM = 7
_VARY_STREAM = 8


@dataclass
class DatasetJob:
    """Everything that defines a dataset (shard, workers and restarts only say who renders what)."""

    renderer: str
    out: str
    n: int
    seed: int = 0
    res: int | None = DEFAULT_RES  # None with a user scene: the scene's own
    samples: int | None = DEFAULT_SAMPLES
    params: list[str] | None = None
    sensitivity: bool = False
    uniform_ratio: float = 0.5
    source_folder: str | None = None  # hair: photos with masks instead of the default scene
    scene: str | None = None  # lipstick: render this scene of the open .blend instead of the default
    lighting: str | None = None  # lipstick, default scene: "wide" or "portrait" (scene_lips; None: its default)
    source_images: bool = True  # False: no X written (and for lipstick none rendered): graphics-loss encoder data
    vary: tuple[str, ...] = ()  # unmodelled inputs drawn per look over their ranges: the encoder learns to look past
    looks_per_source: int = 1  # hair, default scene: consecutive looks share one source render (cached on disk)
    masks: bool = False  # lipstick, default scene: also write the lips mask (hair always writes its hair mask)
    photos: str | None = None  # try the looks on these portraits' face regions (photo_looks) instead
    preset_kernel: float = 0.0  # > 0: draw about each preset (sampling.PresetKernels) instead of one normal on them
    without_presets: tuple[str, ...] = ()  # presets the sampler leaves out (a benchmark's products, kept unseen)
    uniform_lightness: bool = False  # the uniform draws' colours spread evenly over CIELAB lightness (sampling)
    uniform_params: tuple[str, ...] = ()  # the only parameters a uniform draw spreads; the rest from a preset draw
    spec: RendererSpec = field(init=False)

    @property
    def product(self) -> Product:
        """The declaration of the job's product."""
        return get_product(self.renderer)

    @property
    def sampled_presets(self) -> dict[str, dict[str, float]]:
        """The product's presets the sampler draws about (all but without_presets)."""
        return {name: values for name, values in load_presets(self.renderer).items()
                if name not in self.without_presets}

    def __post_init__(self):
        if self.n < 1:
            raise VtoError(f"--n must be at least 1, got {self.n}")
        if self.seed < 0:
            raise VtoError(f"--seed must be >= 0, got {self.seed}")
        if self.scene is None:
            self.res = DEFAULT_RES if self.res is None else self.res
            self.samples = DEFAULT_SAMPLES if self.samples is None else self.samples
        if (self.res is not None and not 8 <= self.res <= 4096) or (
                self.samples is not None and not 1 <= self.samples <= 65536):
            raise VtoError(f"--res must be in [8, 4096] and --samples in [1, 65536], got {self.res} and {self.samples}")
        if not 0.0 <= self.uniform_ratio <= 1.0:
            raise VtoError(f"--uniform-ratio must be in [0, 1], got {self.uniform_ratio}")
        if self.source_folder is not None and not Path(self.source_folder).is_dir():
            raise VtoError(f"--source-folder {self.source_folder} is not a folder")
        self.spec = get_spec(self.renderer, self.params)
        product = self.product
        if self.uniform_lightness and not set(COLOUR) <= set(self.spec.modelled):
            raise VtoError(f"--uniform-lightness moves the colour ({', '.join(COLOUR)}): model all three, got "
                           f"{', '.join(self.spec.modelled)}")
        self.uniform_params = tuple(self.uniform_params)
        unknown = sorted(set(self.uniform_params) - set(self.spec.modelled))
        if unknown:
            raise VtoError(f"--uniform-params: {', '.join(unknown)} is not modelled ({', '.join(self.spec.modelled)})")
        if self.uniform_params and not 0.0 < self.uniform_ratio < 1.0:
            raise VtoError(f"--uniform-params mixes uniform and preset draws: --uniform-ratio must be in (0, 1), got "
                           f"{self.uniform_ratio}")
        if not 0.0 <= self.preset_kernel <= 0.5:
            raise VtoError(f"--preset-kernel must be in [0, 0.5], got {self.preset_kernel}")
        self.without_presets = tuple(self.without_presets)
        names = set(load_presets(self.renderer))
        unknown = sorted(set(self.without_presets) - names)
        if unknown:
            raise VtoError(f"--without-presets: no {self.renderer} preset named {', '.join(unknown)}")
        if len(names - set(self.without_presets)) < 2:
            raise VtoError("--without-presets leaves fewer than 2 presets to sample from")
        self.vary = tuple(self.vary)
        for name in self.vary:
            param = self.spec.by_name.get(name)
            if param is None or name in self.spec.modelled or not np.isfinite(param.high):
                raise VtoError(f"--vary takes unmodelled {self.renderer} inputs with a finite range, got '{name}'")
        if self.looks_per_source < 1 or (self.looks_per_source > 1 and (
                not product.kind.shared_sources or self.source_folder is not None)):
            shared = product_list(p for p in PRODUCTS.values() if p.kind.shared_sources)
            raise VtoError(f"--looks-per-source takes a count >= 1, above 1 for the default {shared} scene only, got "
                           f"{self.looks_per_source}")
        if self.masks and (not product.kind.masks or self.scene is not None):
            masked = product_list(p for p in PRODUCTS.values() if p.kind.masks)
            raise VtoError(f"--masks writes the region mask of the default {masked} scene (the others' datasets "
                           "always have theirs)")
        if self.sensitivity and not self.source_images:
            raise VtoError("--sensitivity renders are for the imitator, which needs the source images: drop --no-source")
        if self.photos is not None:
            from .photo_looks import training_faces

            if (not product.kind.photo_datasets or self.scene is not None or self.sensitivity or self.masks
                    or self.lighting is not None):
                tried = ", ".join(p.name for p in PRODUCTS.values() if p.kind.photo_datasets)
                raise VtoError(f"--photos tries {tried} looks on portraits in their own light: not with --blend, "
                               "--lighting, --sensitivity or --masks")
            if not Path(self.photos).is_dir():
                raise VtoError(f"--photos {self.photos} is not a folder")
            training_faces(self.photos)  # refuses a folder with nothing to train on
        check_lighting(product, self.lighting, user_scene=self.scene is not None)
        if product.kind.lightings and self.scene is None:
            from ..renderers.scene_build import DEFAULT_LIGHTING

            self.lighting = self.lighting or DEFAULT_LIGHTING

    def manifest(self) -> dict:
        """What manifest.json records: identical for every shard and rerun of the same dataset."""
        settings = {k: v for k, v in asdict(self).items() if k not in ("out", "spec")}
        settings["params"] = list(self.spec.modelled)
        if self.source_images:  # recorded only when left out, so datasets made before the option still resume
            del settings["source_images"]
        if self.vary:  # likewise recorded only when used
            settings["vary"] = list(self.vary)
        else:
            del settings["vary"]
        if self.looks_per_source == 1:  # likewise
            del settings["looks_per_source"]
        if not self.masks:  # likewise
            del settings["masks"]
        if not self.preset_kernel:  # likewise
            del settings["preset_kernel"]
        if self.without_presets:  # likewise
            settings["without_presets"] = list(self.without_presets)
        else:
            del settings["without_presets"]
        if not self.uniform_lightness:  # likewise
            del settings["uniform_lightness"]
        if self.uniform_params:  # likewise
            settings["uniform_params"] = list(self.uniform_params)
        else:
            del settings["uniform_params"]
        del settings["photos"]
        if self.photos is not None:  # the faces themselves, by name and content: a folder's path says little
            from vto_core.dataset import file_digest

            from .photo_looks import training_faces

            settings["photos"] = {path.name: file_digest(path) for path in training_faces(self.photos)}
            del settings["lighting"]
        images = "16-bit PNG, display sRGB (Standard view transform)"
        if self.scene is not None:  # a user's scene: its own settings where no flag overrode them, its own values
            scene = bpy.data.scenes[self.scene]
            samples_at = sample_setting(scene)
            settings["engine"] = scene.render.engine
            settings["res"] = self.res or [scene.render.resolution_x * scene.render.resolution_percentage // 100,
                                           scene.render.resolution_y * scene.render.resolution_percentage // 100]
            settings["samples"] = self.samples or (getattr(*samples_at) if samples_at else None)
            side = blender_side(self.product)
            settings["fixed_values"] = {k: v for k, v in side.scene_values(scene).items()
                                        if k not in self.spec.modelled}
            settings["linked_inputs"] = side.linked_inputs(scene)
            view = scene.view_settings
            images = (f"16-bit PNG, display {scene.display_settings.display_device} through the scene's view transform "
                      f"'{view.view_transform}', look '{view.look}', exposure {view.exposure:g}, gamma {view.gamma:g}")
        return {
            "format_version": FORMAT_VERSION,
            **settings,
            "spec": self.spec.to_dict(),
            "images": images,
            "blender_version": bpy.app.version_string,
            "vto_version": vto_core.__version__,
        }


def varied_values(job: DatasetJob, index: int) -> dict[str, float]:
    """The job's --vary inputs for sample `index`: each uniform over its range, a pure function of (seed, index)."""
    rng = np.random.default_rng([job.seed, index, _VARY_STREAM])
    return {name: float(rng.uniform(job.spec.by_name[name].low, job.spec.by_name[name].high)) for name in job.vary}


def source_id(seed: int, index: int) -> int:
    """The source X of sample `index`: a seed of the default scene (or a photo number)."""
    return int(np.random.default_rng([seed, index, _SOURCE_STREAM]).integers(2**31 - 1))


class SampleRenderer:
    """Renders samples of one job; scenes are built once and changed in place."""

    def __init__(self, job: DatasetJob):
        self.job = job
        spec = job.spec
        self.sampler = ParamSampler(spec, preset_matrix(spec, job.sampled_presets), job.uniform_ratio, job.seed,
                                    job.preset_kernel, job.uniform_lightness, job.uniform_params)
        self.photos = None
        self.user_scene = None
        self.photo_looks = None
        if job.photos is not None:
            from .photo_looks import PhotoLooks

            self.photo_looks = PhotoLooks(job.photos, job.res, job.samples, job.seed, job.product)
        if job.product.kind.photo_is_own_source and job.source_folder:
            self.photos = blender_side(job.product).photo_sources(job.source_folder)
        if job.product.kind.user_scenes and job.scene:
            self.user_scene = bpy.data.scenes.get(job.scene)
            if self.user_scene is None:
                raise VtoError(f"the open .blend has no scene '{job.scene}'")
            self.own_values = blender_side(job.product).scene_values(self.user_scene)  # unmodelled ones stay
            coverage = job.product.coverage
            if coverage not in self.own_values:
                label = job.spec.by_name[coverage].socket
                raise VtoError(f"the group's {label} input is driven by a link: the bare source ({coverage} 0) cannot "
                               "be rendered")

    def render(self, index: int) -> int:
        """Render and write sample `index`; returns the number of renders R(X, .) it took."""
        job, spec = self.job, self.job.spec
        unit = self.sampler.sample_unit(index)
        variants = [unit] + ([self.sampler.resample_one_unit(index, j) for j in range(spec.size)] if job.sensitivity else [])
        values = [spec.values(spec.denormalise(u)) for u in variants]
        if self.user_scene is not None:  # the artist's values, only the modelled inputs sampled
            values = [{**self.own_values, **{name: v[name] for name in spec.modelled}} for v in values]
        values = [{**v, **varied_values(job, index)} for v in values]  # one scene for every render of a sample
        # One seed for every render of a sample: sensitivity differences share its noise. Looks that share a source
        # share its render too, made with the seed of their group.
        group = index // job.looks_per_source
        source = source_id(job.seed, group)
        cycles_seed = index if job.looks_per_source == 1 else group
        notes = {}
        if self.photo_looks is not None:
            source_image, render, notes = self.photo_looks.look(index, values[0], job.source_images)
            images, extra = [render], {}
        else:
            cache = Path(job.out) / "source_cache" if job.looks_per_source > 1 else None
            options = {"lighting": job.lighting, "scene": self.user_scene, "source_images": job.source_images,
                       "masks": job.masks, "photos": self.photos, "cache": cache}
            source_image, images, extra = blender_side(job.product).dataset_images(
                values, source, job.res, job.samples, cycles_seed, options)
        writer = SampleWriter(Path(job.out), index)
        try:
            if job.source_images:
                writer.image("source", source_image)
            writer.image("render", images[0])
            for j, image in enumerate(images[1:]):
                writer.image(f"sens_{j:02d}", image)
            for name, pixels in extra.items():
                writer.image(name, pixels)
            record = {"index": index, "source": source, "cycles_seed": cycles_seed,
                      "unit": unit.tolist(), "raw": spec.denormalise(unit).tolist(), "values": values[0], **notes}
            if job.sensitivity:
                record["sensitivity_unit"] = [u.tolist() for u in variants[1:]]
            writer.params(record)
            writer.commit()
        except BaseException:
            writer.abort()
            raise
        return len(images) + (source_image is not None and job.product.kind.renders_source)


def prepare_output(job: DatasetJob, indices=None) -> None:
    """Create DIR, check or write its manifest, drop the half-written samples killed runs left of `indices` (None:
    of all; a shard's own, since the other shards may be running)."""
    out = Path(job.out)
    try:
        (out / "samples").mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryFile(dir=out, prefix=".vto-write-probe-"):  # a name of its own: shards start at once
            pass
    except OSError as exc:
        raise VtoError(f"cannot write to {out}: {exc.strerror}") from None
    write_manifest(out, job.manifest())
    remove_stale_temporaries(out, indices)


def progress_bar(samples: int, renders_per_sample: int, quiet: bool = False):
    """A tqdm bar counting renders (renders/s, ETA) on stderr; every 30 s only when stderr is a log, not a terminal."""
    from tqdm import tqdm

    return tqdm(total=samples * renders_per_sample, unit="render", disable=quiet, dynamic_ncols=True,
                mininterval=0.25 if sys.stderr.isatty() else 30.0, desc="dataset")


def renders_per_sample(job: DatasetJob) -> int:
    """R(X, .) renders each sample costs (lipstick also renders X, unless it is left out)."""
    return 1 + (job.spec.size if job.sensitivity else 0) + (job.product.kind.renders_source and job.source_images)


def run_in_process(job: DatasetJob, indices, limit: int | None = None, quiet: bool = False,
                   parent: int | None = None) -> int:
    """Render the unfinished `indices` here, at most `limit` of them; returns how many were made. A worker given its
    `parent`'s pid stops when that process is gone (killed: nothing is left to stop it, and a run started again on
    the folder would render beside it)."""
    todo = [i for i in indices if i not in finished_indices(Path(job.out))]
    if limit is not None:
        todo = todo[:limit]
    renderer = SampleRenderer(job)
    made = 0
    with progress_bar(len(todo), renders_per_sample(job), quiet) as progress:
        for index in todo:
            if parent is not None and os.getppid() != parent:
                break
            progress.update(renderer.render(index))
            made += 1
    return made


@contextlib.contextmanager
def terminate_as_exit():
    """SIGTERM raises SystemExit inside (its default ends the process at once, before a finally can stop workers)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGTERM, lambda signum, frame: sys.exit(128 + signum))
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


def run_workers(job: DatasetJob, indices: range, workers: int, worker_command: list[str], restart_every: int,
                quiet: bool = False) -> int:
    """Render `indices` with `workers` processes of `worker_command`, restarting each after `restart_every` samples."""
    out = Path(job.out)
    wanted = set(indices)
    initially_done = len(wanted & finished_indices(out))
    per_sample = renders_per_sample(job)
    progress = progress_bar(len(wanted) - initially_done, per_sample, quiet)
    running: dict[int, subprocess.Popen] = {}
    try:
        while True:
            finished = wanted & finished_indices(out)
            for w, process in list(running.items()):
                if process.poll() is not None:
                    if process.returncode != 0:
                        raise VtoError(f"dataset worker {w}/{workers} failed with exit status {process.returncode}")
                    running.pop(w)
            for w in range(workers):
                # A worker exits after restart_every samples (memory stays flat); start a fresh one while work is left.
                if w not in running and any(i not in finished for i in worker_indices(indices, (w, workers))):
                    running[w] = subprocess.Popen(worker_command + ["--worker", f"{w}/{workers}", "--limit",
                                                                    str(restart_every), "--quiet"])
            progress.update((len(finished) - initially_done) * per_sample - progress.n)
            if not running:
                break
            time.sleep(0.2)
    finally:
        for process in running.values():
            process.kill()
        progress.close()
    return len(wanted & finished_indices(out)) - initially_done


def worker_indices(indices: range, worker: tuple[int, int]) -> list[int]:
    """The indices worker (w, W) renders: every W-th of the shard, starting at w."""
    w, count = worker
    return [i for i in indices if (i - indices.start) % count == w]

