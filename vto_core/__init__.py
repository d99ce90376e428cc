"""Numpy core of the VTO add-on: specs, sampling, colour maths, image IO; free of bpy and torch."""

__version__ = "0.1.0"
