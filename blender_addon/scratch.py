"""Scratch data: what a fit renders in the artist's Blender (the default scenes) is removed when it ends."""

from __future__ import annotations

import contextlib

import bpy

# The data-block collections the default scenes and the hair stage's passes create.
COLLECTIONS = ("scenes", "objects", "meshes", "materials", "node_groups", "images", "worlds", "lights", "cameras",
               "hair_curves", "collections", "textures")


def _present() -> dict[str, set[int]]:
    return {name: {block.as_pointer() for block in getattr(bpy.data, name)} for name in COLLECTIONS}


@contextlib.contextmanager
def scratch_data():
    """Remove, on leaving (errors included), every data-block created inside; those that existed stay untouched."""
    before = _present()
    try:
        yield
    finally:
        created = [block for name in COLLECTIONS for block in getattr(bpy.data, name)
                   if block.as_pointer() not in before[name]]
        if created:
            bpy.data.batch_remove(created)
