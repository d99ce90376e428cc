"""Sampled looks rendered headless: `vto dataset`, `vto render` and the .blend asset library of products."""
