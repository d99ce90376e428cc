"""Stage 1 (blender -b): install the extension zip from disk, save the preferences, save a .blend whose Cube has a
VTO Lipstick material, whose plane "Lid" has a VTO Eye Shadow material and whose compositor has the VTO hair groups (all
made by the add-on's own operators)."""
import json
import sys

import bpy

zip_path, blend_out = sys.argv[sys.argv.index("--") + 1:][:2]
result = {"python": sys.version.split()[0], "blender": bpy.app.version_string}
result["install"] = sorted(bpy.ops.extensions.package_install_files(filepath=zip_path, repo="user_default",
                                                                    enable_on_install=True))
import onnxruntime  # noqa: E402  (from the extension's own site-packages, installed from the cp313 wheel)

result["onnxruntime"] = [onnxruntime.__version__, onnxruntime.__file__]
result["site"] = bpy.utils.user_resource("EXTENSIONS", path=".local")
result["enabled"] = "bl_ext.user_default.vto_match" in bpy.context.preferences.addons
bpy.ops.wm.save_userpref()
scene = bpy.context.scene
scene.render.engine = "CYCLES"  # EEVEE compiles material previews on llvmpipe for ~90 s, blocking the window
cube = bpy.data.objects["Cube"]
bpy.context.view_layer.objects.active = cube
cube.select_set(True)
result["add_material"] = sorted(bpy.ops.vto.add_lipstick_material())
bpy.ops.mesh.primitive_plane_add(location=(0.0, 3.0, 0.0))
bpy.context.object.name = "Lid"
result["add_eyeshadow"] = sorted(bpy.ops.vto.add_material(product="eyeshadow"))
bpy.context.view_layer.objects.active = cube
result["add_hair"] = sorted(bpy.ops.vto.add_hair_compositor())
bpy.ops.wm.save_as_mainfile(filepath=blend_out)
print("RESULT stage1 " + json.dumps(result))
