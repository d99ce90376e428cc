"""Render a scene with Cycles on the CPU and read the pixels back (headless-safe: via an EXR on tmpfs)."""

from __future__ import annotations

import atexit
import contextlib
import os
import shutil
import sys
import tempfile

import bpy
import numpy as np

from vto_core.colour import linear_to_srgb
from vto_core.errors import VtoError

from ..compat import IMAGE_FORMAT_FIELDS, canonical_pass_name, set_exr_output, set_file_format

# tmpfs when there is one: the render round-trips through a file because headless
# Render Results hold no pixels.
_TMP_ROOT = "/dev/shm" if os.path.isdir("/dev/shm") and os.access("/dev/shm", os.W_OK) else None


def configure_cycles(scene: bpy.types.Scene, res: int, samples: int, seed: int = 0) -> None:
    """Cycles CPU, fixed samples and seed, denoised, Standard view: deterministic small renders."""
    if not 8 <= res <= 4096:
        raise VtoError(f"resolution must be in [8, 4096], got {res}")
    if not 1 <= samples <= 65536:
        raise VtoError(f"samples must be in [1, 65536], got {samples}")
    if scene.render.engine != "CYCLES":  # setting it tells every render engine, the preview's too
        scene.render.engine = "CYCLES"
    set_render_quality(scene, samples, seed)
    scene.render.threads_mode = "AUTO"
    scene.render.resolution_x = scene.render.resolution_y = res
    scene.render.resolution_percentage = 100
    scene.render.use_compositing = False
    scene.render.use_sequencer = False
    scene.view_settings.view_transform = "Standard"
    scene.view_settings.look = "None"
    scene.view_settings.exposure = 0.0
    scene.view_settings.gamma = 1.0
    scene.display_settings.display_device = "sRGB"
    settings = scene.render.image_settings
    set_exr_output(settings, multilayer=True)
    settings.color_depth = "32"
    settings.exr_codec = "NONE"


def set_render_quality(scene: bpy.types.Scene, samples: int, seed: int) -> None:
    """The Cycles settings that trade noise for time (measured in benchmarks/results/render.md).

    OpenImageDenoise (RGB + albedo + normal, fast prefilter) at 16 spp gives ~35 dB between seeds at 64 px against
    ~23 dB without it, for ~25 ms more per render (as fast as the renderer before it); it is deterministic for a
    fixed seed, and it lowers block-level noise, which is what decides which parameters an encoder can see. The default scenes' HDRIs
    have their bright spots lifted out into sun lamps (lighting.py), so direct light needs no clamp; indirect
    light is clamped at 1 (display white) against the remaining fireflies. The light tree only costs time
    with a world and a few suns.
    """
    cycles = scene.cycles
    cycles.device = "CPU"
    cycles.samples = samples
    cycles.use_adaptive_sampling = False
    try:
        cycles.denoiser = "OPENIMAGEDENOISE"
        cycles.use_denoising = True
        cycles.denoising_input_passes = "RGB_ALBEDO_NORMAL"
        cycles.denoising_prefilter = "FAST"
    except TypeError:  # a Blender built without OpenImageDenoise (Debian's 4.3): its renders stay noisy
        cycles.use_denoising = False
    cycles.denoising_use_gpu = False
    cycles.seed = seed
    cycles.use_animated_seed = False
    cycles.use_light_tree = False
    cycles.max_bounces = 4
    cycles.diffuse_bounces = 2
    cycles.glossy_bounces = 2
    cycles.transmission_bounces = 2
    cycles.transparent_max_bounces = 2
    cycles.sample_clamp_direct = 0.0
    cycles.sample_clamp_indirect = 1.0


class RenderFiles:
    """A private temp folder for render round-trips, removed on close."""

    def __init__(self):
        self.folder = tempfile.mkdtemp(prefix="vto-render-", dir=_TMP_ROOT)
        self.path = os.path.join(self.folder, "render.exr")

    def close(self) -> None:
        """Delete the folder and what is in it."""
        shutil.rmtree(self.folder, ignore_errors=True)


_files: RenderFiles | None = None


def _render_path() -> str:
    global _files
    if _files is None:
        _files = RenderFiles()
        atexit.register(_files.close)
    return _files.path


def read_exr_layers(path: str) -> dict[str, np.ndarray]:
    """A multilayer EXR -> {pass name: (H, W, C) float32}, top row first."""
    import OpenImageIO as oiio

    image = oiio.ImageInput.open(path)
    if image is None:
        raise VtoError(f"cannot read render output {path}: {oiio.geterror()}")
    parts = []  # one part per pass in multi-part files (Blender 5), one part for all in older ones
    try:
        while image.seek_subimage(len(parts), 0):
            spec = image.spec()
            pixels = image.read_image(len(parts), 0, 0, spec.nchannels, "float")
            if pixels is None:
                raise VtoError(f"cannot read render output {path}")
            parts.append((spec.channelnames, pixels))
    finally:
        image.close()
    layers: dict[str, list[tuple[str, np.ndarray]]] = {}
    for names, pixels in parts:
        for index, name in enumerate(names):
            words = name.split(".")  # ViewLayer.Pass.Channel
            pass_name = canonical_pass_name(words[-2] if len(words) >= 2 else "Combined")
            layers.setdefault(pass_name, []).append((words[-1], pixels[..., index]))
    order = {c: i for i, c in enumerate("RGBAXYZV")}
    return {
        pass_name: np.ascontiguousarray(np.stack([p for _, p in sorted(chans, key=lambda c: order.get(c[0], 99))], -1))
        for pass_name, chans in layers.items()
    }


@contextlib.contextmanager
def _quiet_stdout():
    """Silence Blender's per-render progress lines (they are written to fd 1 from C)."""
    sys.stdout.flush()
    saved = os.dup(1)
    devnull = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(devnull, 1)
        yield
    finally:
        os.dup2(saved, 1)
        os.close(saved)
        os.close(devnull)


def render_passes(scene: bpy.types.Scene) -> dict[str, np.ndarray]:
    """Render `scene` (already configured) and return its passes as linear float32 arrays."""
    path = _render_path()
    scene.render.filepath = path
    scene.render.use_file_extension = False
    with bpy.context.temp_override(scene=scene), _quiet_stdout():
        bpy.ops.render.render(write_still=True, scene=scene.name)
    layers = read_exr_layers(path)
    os.remove(path)
    return layers


@contextlib.contextmanager
def _restored(owner, names: tuple[str, ...]):
    """Put the attributes `names` of `owner` back as they were on leaving (the user's scene is not left changed)."""
    saved = {name: getattr(owner, name) for name in names}
    try:
        yield
    finally:
        for name, value in saved.items():
            setattr(owner, name, value)


def render_user_passes(scene: bpy.types.Scene, side: int, samples: int) -> dict[str, np.ndarray]:
    """A user's scene through its own camera, its compositor off, at most `side` px on its long side and `samples`
    samples (never more than its own), not denoised (a Blender built without OpenImageDenoise refuses it): its passes
    as linear float32 arrays. Everything is as it was afterwards."""
    render, settings = scene.render, scene.render.image_settings
    samples_at = sample_setting(scene)
    with _restored(render, ("filepath", "use_file_extension", "resolution_percentage", "use_compositing",
                            "use_sequencer")), \
            _restored(settings, (*IMAGE_FORMAT_FIELDS, "color_depth", "exr_codec")), \
            _restored(scene.cycles, ("use_denoising",)), \
            (_restored(samples_at[0], samples_at[1:]) if samples_at else contextlib.nullcontext()):
        scene.cycles.use_denoising = False
        long_side = max(render.resolution_x, render.resolution_y) * render.resolution_percentage / 100
        render.resolution_percentage = max(1, min(render.resolution_percentage,
                                                  int(render.resolution_percentage * side / max(long_side, 1))))
        render.use_compositing = render.use_sequencer = False
        if samples_at:
            setattr(*samples_at, min(samples, getattr(*samples_at)))
        set_exr_output(settings, multilayer=True)
        settings.color_depth, settings.exr_codec = "32", "NONE"
        return render_passes(scene)


def sample_setting(scene: bpy.types.Scene) -> tuple[object, str] | None:
    """Where `scene`'s render engine keeps its render sample count, (owner, attribute); None for an engine without."""
    engine = scene.render.engine
    if engine == "CYCLES":
        return scene.cycles, "samples"
    if engine.startswith("BLENDER_EEVEE"):
        return scene.eevee, "taa_render_samples"
    return None


def render_user_scene(scene: bpy.types.Scene, res: int | None = None, samples: int | None = None,
                      seed: int | None = None) -> np.ndarray:
    """Render a user's scene with its own settings and colour management: (H, W, 3) display values in [0, 1].

    Only what is given overrides the scene (res: square resolution at 100 %; samples, Cycles or EEVEE; Cycles
    seed), and only for this render. Pixels come back through a 16-bit PNG saved with the scene's view transform
    and look (not an output override), so an AgX or Filmic scene is read as its artist sees it.
    """
    from vto_core.imageio import read_image

    if res is not None and not 8 <= res <= 4096:
        raise VtoError(f"resolution must be in [8, 4096], got {res}")
    if samples is not None and not 1 <= samples <= 65536:
        raise VtoError(f"samples must be in [1, 65536], got {samples}")
    samples_at = sample_setting(scene)
    if samples is not None and samples_at is None:
        raise VtoError(f"scene '{scene.name}' renders with {scene.render.engine}, which has no sample count to set")
    path = os.path.join(os.path.dirname(_render_path()), "user.png")
    render, settings = scene.render, scene.render.image_settings
    with _restored(render, ("filepath", "use_file_extension", "resolution_x", "resolution_y",
                            "resolution_percentage")), \
            _restored(settings, (*IMAGE_FORMAT_FIELDS, "color_depth", "color_mode", "color_management")), \
            _restored(scene.cycles, ("seed", "use_animated_seed")), \
            (_restored(samples_at[0], samples_at[1:]) if samples_at else contextlib.nullcontext()):
        if res is not None:
            render.resolution_x = render.resolution_y = res
            render.resolution_percentage = 100
        if samples is not None:
            setattr(*samples_at, samples)
        if seed is not None:
            scene.cycles.seed, scene.cycles.use_animated_seed = seed, False
        set_file_format(settings, "PNG")
        settings.color_depth, settings.color_mode = "16", "RGB"
        settings.color_management = "FOLLOW_SCENE"
        render.filepath, render.use_file_extension = path, False
        with bpy.context.temp_override(scene=scene), _quiet_stdout():
            bpy.ops.render.render(write_still=True, scene=scene.name)
    rgb, _ = read_image(path)
    os.remove(path)
    return rgb


def to_display(linear_rgb: np.ndarray) -> np.ndarray:
    """Scene-linear RGB (H, W, 3) -> display sRGB in [0,1], exactly what the Standard view transform shows."""
    if np.isnan(linear_rgb).any():
        raise VtoError(f"the render holds {int(np.isnan(linear_rgb).sum())} NaN values")
    return linear_to_srgb(np.clip(linear_rgb, 0.0, 1.0)).astype(np.float32)  # +inf (HDR overflow) shows as white
