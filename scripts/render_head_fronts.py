"""Render the front view of each test head in data/heads/: <name>_front.png and its camera in <name>_front.json.

    usage: .venv/bin/python scripts/render_head_fronts.py [NAME ...]   (default: every head in heads.json)

Cycles on the CPU, 16 samples (OpenImageDenoise, seed 0), 512 x 512, Standard view transform; the only light is a
uniform white world of strength 1. The camera is a perspective 85 mm lens on a 36 mm sensor, looking along +Y from
in front of the face, framing it from the forehead to the chin: the frame's height, at the depth of the face's front,
spans the lower FRAME_FRACTION of the chin-to-crown height and a margin. The chin and crown heights are the ones
scripts/import_heads.py stored on the head object.
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import bpy

ROOT = Path(__file__).resolve().parents[1]
HEADS = ROOT / "data" / "heads"
RES = 512
SAMPLES = 16
LENS_MM = 85.0
SENSOR_MM = 36.0
FRAME_FRACTION = 0.76  # chin to about the hairline, as a share of chin to crown
MARGIN = 1.06          # the frame's height over that span


def setup(scene: bpy.types.Scene) -> None:
    scene.render.engine = "CYCLES"
    cycles = scene.cycles
    cycles.device = "CPU"
    cycles.samples = SAMPLES
    cycles.use_adaptive_sampling = False
    cycles.seed = 0
    try:
        cycles.denoiser = "OPENIMAGEDENOISE"
        cycles.use_denoising = True
    except TypeError:
        cycles.use_denoising = False
    scene.render.resolution_x = scene.render.resolution_y = RES
    scene.render.resolution_percentage = 100
    scene.render.film_transparent = False
    scene.render.use_compositing = False
    scene.render.use_sequencer = False
    scene.view_settings.view_transform = "Standard"
    scene.view_settings.look = "None"
    scene.view_settings.exposure = 0.0
    scene.view_settings.gamma = 1.0
    scene.display_settings.display_device = "sRGB"
    settings = scene.render.image_settings
    settings.file_format = "PNG"
    settings.color_mode = "RGB"
    settings.color_depth = "8"

    world = bpy.data.worlds.new("white")
    world.use_nodes = True
    background = world.node_tree.nodes["Background"]
    background.inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)
    background.inputs["Strength"].default_value = 1.0
    scene.world = world


def add_camera(scene: bpy.types.Scene, head: bpy.types.Object) -> bpy.types.Object:
    chin, crown, front = head["chin_z"], head["crown_z"], head["front_y"]
    span = FRAME_FRACTION * (crown - chin) * MARGIN
    cz = chin + FRAME_FRACTION * (crown - chin) / 2
    distance = span * LENS_MM / SENSOR_MM  # from the face's front, so the span fills the frame there
    data = bpy.data.cameras.new("front")
    data.type = "PERSP"
    data.lens = LENS_MM
    data.sensor_width = SENSOR_MM
    data.sensor_fit = "AUTO"
    camera = bpy.data.objects.new("front", data)
    camera.location = (0.0, front - distance, cz)
    camera.rotation_euler = (math.radians(90.0), 0.0, 0.0)  # looking along +Y, +Z up
    scene.collection.objects.link(camera)
    scene.camera = camera
    return camera


def render(name: str) -> None:
    bpy.ops.wm.open_mainfile(filepath=str(HEADS / f"{name}.blend"))
    scene = bpy.context.scene
    head = bpy.data.objects["head"]
    setup(scene)
    camera = add_camera(scene, head)
    scene.render.filepath = str(HEADS / f"{name}_front.png")
    bpy.ops.render.render(write_still=True)
    record = {
        "location": [round(v, 6) for v in camera.location],
        "rotation_euler": [round(v, 6) for v in camera.rotation_euler],
        "lens": LENS_MM,
        "sensor_width": SENSOR_MM,
        "resolution": [RES, RES],
    }
    (HEADS / f"{name}_front.json").write_text(json.dumps(record, indent=2) + "\n")
    print(name, json.dumps(record))


def main(argv: list[str]) -> None:
    names = argv or list(json.loads((HEADS / "heads.json").read_text()))
    for name in names:
        render(name)


if __name__ == "__main__":
    main(sys.argv[1:])
