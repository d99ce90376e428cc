"""Numpy core of the VTO add-on: specs, sampling, colour maths, image IO; free of bpy and torch.

The bottom layer: it imports none of blender_addon, training or pipeline (tests/test_layers.py).
"""

__version__ = "0.1.0"
