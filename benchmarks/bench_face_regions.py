"""How well Find Face on Mesh's regions match outlines drawn by hand on each test head's front render, and what the
shipped face model itself reads there.

    python -m benchmarks.bench_face_regions

Per head of data/heads: Find Face on Mesh, the attributes seen from the camera of the head's front render
(heads.region_scores: the lips' IoU at weight 0.5, vto_lid at the inner points of each lash line and brow, weights
far outside the outlines), and the face model's own lips polygon read on that very render (the front render the
outlines were drawn on): the most a region cast from its landmarks could reach. The MakeHuman head again with its
own lips vertex group (`--group lips=mpfb_lips`). Writes benchmarks/results/face_regions.md.
"""

from __future__ import annotations

import numpy as np

from benchmarks.common import write_table
from benchmarks.heads import EYES, HEADS, NAMES, filled, front_camera, front_shot, open_head, outline, region_scores

GOALS = ("lips IoU ≥ 0.8, vto_lid ≤ 0.1 at the lash line and ≥ 0.9 at the brow, nothing outside the outlines "
         "> 0.05")
GROUPS = {"makehuman": {"lips": "mpfb_lips"}}  # heads whose mesh says where a region is


def own_lips_iou(name: str) -> float:
    """IoU of the face model's lips polygon, read on the head's front render, with the hand outline."""
    from blender_addon.shipped import photo_reader
    from vto_core.imageio import read_image
    from vto_core.products import LIPSTICK

    image = read_image(str(HEADS / f"{name}_front.png"))[0][..., :3].astype(np.float32)
    landmarks = photo_reader().face_of(np.ascontiguousarray(image)).landmarks
    size = image.shape[0]
    read = filled(landmarks[list(LIPSTICK.face_region.loops[0])], size) & \
        ~filled(landmarks[list(LIPSTICK.face_region.loops[1])], size)
    lines = outline(name)
    drawn = filled(lines["lips"], size) & ~filled(lines["mouth"], size)
    return float((read & drawn).sum() / (read | drawn).sum())


def scores_of(name: str, groups=None) -> dict[str, float]:
    import bpy

    from blender_addon.matching.face_on_mesh import attributes_seen, camera_view, find_face
    from vto_core.products import EYESHADOW, LIPSTICK

    obj = open_head(name)
    find_face(obj, None, groups)
    seen = attributes_seen(obj, camera_view(front_camera(name), front_shot(name)["resolution"][0]),
                           (LIPSTICK.face_region.attribute, EYESHADOW.face_region.attribute, "vto_lid"))
    bpy.data.batch_remove([o for o in bpy.data.objects if o.type in ("MESH", "CAMERA")])
    return region_scores(outline(name), seen)


def main() -> None:
    rows = []
    runs = [(name, None) for name in NAMES] + list(GROUPS.items())
    for name, groups in runs:
        scores = scores_of(name, groups)
        label = name + (" (" + ", ".join(f"{k}={v}" for k, v in groups.items()) + ")" if groups else "")
        rows.append([label, f"{scores['lips_iou']:.2f}", f"{own_lips_iou(name):.2f}" if groups is None else "",
                     f"{scores['lips_outside']:.2f}"]
                    + [f"{scores[f'{eye}_{part}']:.2f}" for eye in EYES for part in ("lash", "brow")]
                    + [f"{scores['lids_below']:.2f}"])
    write_table("face_regions", "Find Face on Mesh against hand outlines",
                ["head", "lips IoU", "face model's own lips IoU", "lips far outside", "right lash", "right brow",
                 "left lash", "left brow", "lids below the eyes"], rows,
                f"The issue's goals: {GOALS}. \"Far outside\" and \"below\": the largest weight more than 20 px (of "
                "512) past the outline's box or below the lash lines. \"The face model's own\": its lips polygon on "
                "the front render itself, the ceiling of a region cast from its landmarks.")


if __name__ == "__main__":
    main()
