"""The default hair scene, as docs/hair_scene.png shows it: whole heads (the portrait view) and the hair regions the
encoder reads (the default source), for sources 0-3.

    .venv/bin/python scripts/hair_scene_sheet.py [--before docs/hair_scene_before.png] [--out docs/hair_scene.png]

--before: a row rendered by the earlier scene (a shell of 3,000 thick strands; render_hair_source(s, 256, 32) for
s = 0-3 at commit 2f47b79), put on top for comparison.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from blender_addon.renderers.hair import render_hair_source
from vto_core.imageio import read_image, resize, write_image

SIZE = 256


def main() -> None:
    """Render the rows and write the sheet."""
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--before", default=None)
    parser.add_argument("--out", default="docs/hair_scene.png")
    args = parser.parse_args()
    heads = np.concatenate([render_hair_source(s, SIZE, 32, view="portrait").rgb for s in range(4)], axis=1)
    regions = np.concatenate([resize(render_hair_source(s, 128, 32).rgb, SIZE, SIZE) for s in range(4)], axis=1)
    rows = [heads, regions]
    if args.before:
        rows.insert(0, read_image(Path(args.before))[0][..., :3])
    write_image(args.out, np.concatenate(rows, axis=0))
    print(args.out)


if __name__ == "__main__":
    main()
