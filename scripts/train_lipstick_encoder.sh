#!/usr/bin/env bash
# The shipped lipstick encoder (blender_addon/models/lipstick_encoder.onnx), as it was made: render the data,
# train (graphics loss: the paper's MIG baseline; no imitator yet), export, evaluate on fresh looks.
# CPU: about 25 min of rendering and 15 min of training on 2 cores; add --device cuda to the train line on a GPU.
set -euo pipefail
cd "$(dirname "$0")/.."
VTO=.venv/bin/vto
$VTO dataset lipstick --out out/data/lip64 --n 3000 --seed 101
$VTO train encoder --data out/data/lip64 --out out/runs/lipstick_encoder --set loss=graphics \
    --set steps="${STEPS:-6000}" --set lr=0.001 --set log_every=100 --set checkpoint_every=500
$VTO export --encoder out/runs/lipstick_encoder --out blender_addon/models/lipstick_encoder.onnx
$VTO eval --model blender_addon/models/lipstick_encoder.onnx --n 48 --refine render:25 --out out/eval/lipstick
