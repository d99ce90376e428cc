"""The open .blend: opening one for a command, and saving it atomically (a temporary file, then os.replace)."""

from __future__ import annotations

import os
import shutil

import bpy

from vto_core.errors import VtoError


def open_blend(path: str | None) -> None:
    """Open `path` (a .blend) unless it is already the open file; with no path the open file must exist."""
    if path is None:
        if not bpy.data.filepath:
            raise VtoError("give --blend FILE (or run inside Blender with a .blend open)")
        return
    if not os.path.isfile(path):
        raise VtoError(f"no .blend at {path}")
    if os.path.abspath(bpy.data.filepath or "") != os.path.abspath(path):
        bpy.ops.wm.open_mainfile(filepath=path)


def save_blend_atomic(path: str) -> str:
    """Save the open file to `path` atomically: a temporary .blend in the same folder, then os.replace.

    On any failure the temporary file is removed and `path` is left as it was.
    """
    path = os.path.abspath(path)
    folder, name = os.path.split(path)
    if not os.path.isdir(folder):
        raise VtoError(f"cannot save {path}: no folder {folder}")
    temporary = os.path.join(folder, f".{name}.vto-{os.getpid()}.tmp.blend")
    try:
        try:
            done = bpy.ops.wm.save_as_mainfile(filepath=temporary, copy=True, check_existing=False)
        except RuntimeError as exc:
            raise VtoError(f"cannot save {path}: {str(exc).strip().splitlines()[0]}") from None
        if "FINISHED" not in done or not os.path.isfile(temporary):
            raise VtoError(f"cannot save {path}: Blender did not write the file")
        if os.path.isfile(path):
            shutil.copymode(path, temporary)
        os.replace(temporary, path)
    finally:
        if os.path.exists(temporary):
            os.remove(temporary)
    return path


MESH_FORMATS = {".blend": None, ".obj": "wm.obj_import", ".glb": "import_scene.gltf", ".gltf": "import_scene.gltf",
                ".fbx": "import_scene.fbx"}  # a mesh file's suffix -> the operator that imports it (a .blend opens)


def open_mesh_file(path: str) -> None:
    """Open a .blend, or import an .obj, .glb/.gltf or .fbx into an empty file; VtoError (one line) otherwise."""
    suffix = os.path.splitext(path)[1].lower()
    if suffix not in MESH_FORMATS:
        raise VtoError(f"cannot read {path}: give a {', '.join(MESH_FORMATS)} file")
    if not os.path.isfile(path):
        raise VtoError(f"no file at {path}")
    if MESH_FORMATS[suffix] is None:
        return open_blend(path)
    bpy.ops.wm.read_factory_settings(use_empty=True)
    group, name = MESH_FORMATS[suffix].split(".")
    try:
        getattr(getattr(bpy.ops, group), name)(filepath=os.path.abspath(path))
    except RuntimeError as exc:
        raise VtoError(f"cannot import {path}: {str(exc).strip().splitlines()[-1]}") from None


def mesh_object(name: str | None) -> bpy.types.Object:
    """The open file's object `name`, or with no name its largest mesh (the most vertices)."""
    meshes = [obj for obj in bpy.data.objects if obj.type == "MESH"]
    if name is not None:
        obj = bpy.data.objects.get(name)
        if obj is None:
            raise VtoError(f"no object '{name}' in the file; its meshes: {', '.join(o.name for o in meshes) or 'none'}")
        return obj
    if not meshes:
        raise VtoError("the file holds no mesh")
    return max(meshes, key=lambda obj: len(obj.data.vertices))
