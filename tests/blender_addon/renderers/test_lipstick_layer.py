"""The "VTO Lipstick" makeup layer: energy conservation, colour fidelity, gloss saturation, sparkles, no-UV meshes."""

import numpy as np
import pytest

pytestmark = pytest.mark.blender
bpy = pytest.importorskip("bpy")

from blender_addon.renderers.product_lipstick import render_lipstick  # noqa: E402
from blender_addon.renderers.scene_furnace import (FURNACE_SCENE, furnace_scene, render_furnace,  # noqa: E402
                                                   seen_colour)
from blender_addon.renderers.cycles import render_passes  # noqa: E402
from vto_core.colour import linear_to_srgb, srgb_to_linear  # noqa: E402
from vto_core.presets import load_presets  # noqa: E402

BRIGHTEST = {"opacity": 1.0, "red": 255.0, "green": 255.0, "blue": 255.0, "gloss": 1e30, "gloss_roughness": 0.0,
             "reflection": 1.0, "metallic": 1.0, "sheen": 1.0, "sparkle_density": 1.0, "sparkle_size": 1.0,
             "sparkle_intensity": 1.0}


@pytest.mark.slow
def test_makeup_layer_reflects_no_more_light_than_arrives():
    """White furnace: with everything at its brightest, the sphere is no brighter than the world around it."""
    linear, sphere = render_furnace(BRIGHTEST)
    assert sphere.sum() > 200
    assert np.isfinite(linear).all()
    mean = linear[sphere].mean()
    assert mean <= 1.02, f"mean radiance {mean:.3f} of a white world's 1.0: the layer adds energy"
    assert mean > 0.7, f"mean radiance {mean:.3f}: a white, glossy layer in a white world should look nearly white"


@pytest.mark.slow
def test_the_set_colour_is_the_colour_seen():
    """In the furnace an opaque makeup shows its set colour plus a small white specular share s, and no other tint.

    A dielectric always reflects some white (Fresnel); seen = set * (1 - s) + s in linear light, fitted per render.
    """
    rgb = np.array([190.0, 20.0, 35.0])
    for gloss, most_white in ((0.0, 0.12), (4.0, 0.35)):  # a coat of F0 0.24 averages ~28 % over the sphere
        linear, sphere = render_furnace({"opacity": 1.0, "red": rgb[0], "green": rgb[1], "blue": rgb[2],
                                          "gloss": gloss, "gloss_roughness": 0.3, "reflection": 0.0}, samples=32)
        seen, white, residual = seen_colour(linear, sphere, rgb)
        assert 0 <= white <= most_white, f"gloss {gloss}: white share {white:.3f} (seen {linear_to_srgb(seen) * 255})"
        assert residual < 0.02, f"gloss {gloss}: colour off the set one by {residual:.3f} beyond the white share"


def test_gloss_saturates_smoothly():
    low, high, huge = (render_lipstick({"opacity": 1.0, "gloss": g}, 1, 24, 4) for g in (0.0, 8.0, 1e30))
    assert np.isfinite(huge).all()
    assert np.abs(high - huge).mean() < np.abs(high - low).mean() / 3, "gloss past 8 should change little"


def test_lip_line_needs_a_uv_map_and_does_nothing_without_one():
    with_line = render_lipstick({"opacity": 1.0, "lip_line": 1.0}, 1, 32, 4)
    without = render_lipstick({"opacity": 1.0, "lip_line": 0.0}, 1, 32, 4)
    assert np.abs(with_line - without).mean() > 0.001  # the default lips have a UV map: the contour darkens
    scene = furnace_scene()
    mesh = bpy.data.objects[FURNACE_SCENE].data
    saved = [layer.name for layer in mesh.uv_layers]
    for name in saved:
        mesh.uv_layers.remove(mesh.uv_layers[name])
    try:
        plain, sphere = render_furnace({"opacity": 1.0, "red": 200.0, "lip_line": 0.0}, samples=4)
        lined, _ = render_furnace({"opacity": 1.0, "red": 200.0, "lip_line": 1.0}, samples=4)
    finally:
        for name in saved:
            mesh.uv_layers.new(name=name)
    assert np.abs(plain[sphere] - lined[sphere]).max() < 1e-6, "without a UV map Lip Line must not darken the mesh"
    assert scene is not None


def test_sparkle_flakes_are_pixels_at_training_size():
    """At 64 px, fully dense flakes change a visible share of the lip pixels (they were a fifth of a pixel)."""
    base = {"opacity": 1.0, "red": 120.0, "green": 20.0, "blue": 40.0, "sparkle_intensity": 1.0, "sparkle_size": 1.0}
    none = render_lipstick({**base, "sparkle_density": 0.0}, 1, 64, 8)
    dense = render_lipstick({**base, "sparkle_density": 1.0}, 1, 64, 8)
    changed = np.abs(dense - none).max(axis=-1) > 0.1
    assert changed.mean() > 0.04, f"only {changed.mean():.3f} of the pixels show flakes"


@pytest.mark.parametrize("name", ["Classic Red", "Midnight Vinyl", "Cherry Gloss"])
def test_glossy_presets_keep_their_colour(name):
    """Under the studio HDRIs the lips' median colour keeps the preset's hue (no white wash)."""
    from blender_addon.renderers.scene_lips import LIPS_PASS_INDEX, build_lips_scene

    values = load_presets("lipstick")[name]
    image = render_lipstick(values, 1, 48, 8)
    passes = render_passes(build_lips_scene())
    lips = np.abs(passes["IndexOB"][..., 0] - LIPS_PASS_INDEX) < 0.5
    seen = np.median(image[lips], axis=0) * 255
    target = np.array([values["red"], values["green"], values["blue"]])
    assert int(np.argmax(seen)) == int(np.argmax(target)), f"{name}: set {target}, seen {seen.round()}"
    assert seen.max() < 235, f"{name}: lips washed towards white {seen.round()}"
    assert srgb_to_linear(seen / 255).min() >= 0
