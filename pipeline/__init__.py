"""The pipeline layer: what needs both the renderer (blender_addon, bpy) and the learning (training, torch).

It holds the paper's transfer evaluation (`vto eval`), the demo and its report (`vto demo`), and imitator refinement
for `vto match --refine imitator:K`. Imports go downward only: pipeline may import blender_addon, training and
vto_core; blender_addon and training import neither each other nor pipeline; vto_core imports none of them
(tests/test_layers.py checks this).
"""
