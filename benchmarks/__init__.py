"""Benchmarks: each script measures, prints a table and writes it to benchmarks/results/."""
