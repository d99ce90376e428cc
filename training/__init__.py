"""Learning the imitator and the encoder with torch: networks, losses, loops, ONNX export, imitator refinement.

Reads datasets through vto_core and never renders: it imports no bpy, no blender_addon and no pipeline
(tests/test_layers.py). What needs the renderer and the networks together lives in pipeline/.
"""
