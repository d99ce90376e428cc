"""The test heads of data/heads (made by others; see its README): appended into the open session, and the camera of
each one's front render, on which its outlines were drawn by hand."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

HEADS = Path(__file__).resolve().parents[1] / "data" / "heads"
NAMES = ("makehuman", "lee_perry_smith", "blender_sculpt")


def open_head(name: str, scene=None):
    """The head's largest mesh object, its file's objects appended into `scene` (default: the context's). The file
    is appended, never opened: what the session holds stays."""
    import bpy

    with bpy.data.libraries.load(str(HEADS / f"{name}.blend")) as (source, target):
        target.objects = list(source.objects)
    scene = scene or bpy.context.scene
    for obj in target.objects:
        scene.collection.objects.link(obj)
    return max((o for o in target.objects if o.type == "MESH"), key=lambda o: len(o.data.vertices))


def front_shot(name: str) -> dict:
    """The head's front render's camera: location, rotation_euler, lens, sensor_width, resolution."""
    return json.loads((HEADS / f"{name}_front.json").read_text())


def front_camera(name: str, scene=None):
    """A camera object where the head's front render was taken, linked into `scene` (default: the context's)."""
    import bpy

    shot = front_shot(name)
    camera = bpy.data.objects.new("Front Camera", bpy.data.cameras.new("Front Camera"))
    camera.data.lens, camera.data.sensor_width = shot["lens"], shot["sensor_width"]
    camera.location, camera.rotation_euler = shot["location"], shot["rotation_euler"]
    (scene or bpy.context.scene).collection.objects.link(camera)
    bpy.context.view_layer.update()
    return camera


def outline(name: str) -> dict:
    """The hand outlines of the head's front render (data/heads/README.md): lips, mouth, each eye's lash and brow."""
    return json.loads((HEADS / f"{name}_outline.json").read_text())


MARGIN_PX = 20  # how far past a hand outline a region may still weigh something (the face model's slack)
EYES = ("right_eye", "left_eye")


def filled(points, size: int) -> np.ndarray:
    """A polygon (K, 2) px -> its (size, size) bool mask (all False for fewer than 3 points)."""
    from vto_core.photo.face_reader import polygon_mask

    points = np.asarray(points, np.float64)
    return polygon_mask(points, 0, 0, size, size) > 0.5 if len(points) >= 3 else np.zeros((size, size), bool)


def lid_zone(eye: dict, size: int) -> np.ndarray:
    """An eye's upper-lid zone of the outlines, from the lash line up to the brow: (size, size) bool."""
    return filled(np.concatenate([np.asarray(eye["lash"], float), np.asarray(eye["brow"], float)[::-1]]), size)


def region_scores(outlines: dict, seen: np.ndarray) -> dict[str, float]:
    """How the regions found match the hand outlines, from `seen` (size, size, 3): the lips' weight, the lids' weight
    and vto_lid, as the front camera sees them. The lips: IoU of weight > 0.5 with the outline (less the mouth), and
    the largest weight more than MARGIN_PX outside the outline's box. Per eye: the median vto_lid at the inner points
    of its lash line and of its brow. The lids: the largest weight more than MARGIN_PX below the lash lines."""
    size = seen.shape[0]
    lips = filled(outlines["lips"], size)
    drawn, found = lips & ~filled(outlines["mouth"], size), seen[..., 0] > 0.5
    rows, cols = np.nonzero(lips)
    box = np.zeros_like(lips)
    box[max(rows.min() - MARGIN_PX, 0):rows.max() + MARGIN_PX + 1,
        max(cols.min() - MARGIN_PX, 0):cols.max() + MARGIN_PX + 1] = True
    scores = {"lips_iou": float((drawn & found).sum() / max((drawn | found).sum(), 1)),
              "lips_outside": float(seen[..., 0][~box].max())}
    for eye in EYES:
        for part in ("lash", "brow"):
            points = np.asarray(outlines[eye][part], np.float64)[1:-1]  # the corners are both lash and brow
            at = np.clip(points.astype(int), 0, size - 1)
            scores[f"{eye}_{part}"] = float(np.median(seen[at[:, 1], at[:, 0], 2]))
    lowest = max(float(np.asarray(outlines[eye]["lash"])[:, 1].max()) for eye in EYES)
    scores["lids_below"] = float(seen[int(lowest) + MARGIN_PX:, :, 1].max())
    return scores
