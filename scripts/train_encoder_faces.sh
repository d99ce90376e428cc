#!/usr/bin/env bash
# The shipped lipstick encoder's last stage: the procedural encoder (scripts/train_encoder.sh lipstick) fine-tuned on
# real faces with the products drawn on (`vto dataset lipstick --photos data/faces`: the train split of data/faces,
# never its held-out or evaluation faces) mixed with fresh default-scene looks, so it keeps reading renders.
#   scripts/train_encoder_faces.sh   -> blender_addon/models/lipstick_encoder.onnx (overwritten)
# Graphics loss plus the colour loss through the colour imitator (what the estimate shows on the default lips against
# what the truth shows: blender_addon/models/colour_imitator.md), the views of the procedural run, cosine lr from 3e-4.
# Then 4,000 more steps reading the input box-filtered over 3 x 3 pixels (input_filter=3): the first convolution
# strides by 2, and without the filter a lips crop turned with the head read another colour (lipstick_encoder.md).
# CPU: about 60 min of rendering for 7,700 face looks (one process) and 25 for 3,500 default looks, then 25 + 15 min
# of training on one thread. Environment: FACE_LOOKS, DEFAULT_LOOKS, STEPS, FILTER_STEPS.
set -euo pipefail
cd "$(dirname "$0")/.."
VTO=.venv/bin/vto
START=${START:-blender_addon/models/lipstick_encoder.onnx}
mkdir -p out && cp "$START" out/lipstick_encoder_procedural.onnx
$VTO dataset lipstick --out out/data/faces61 --n "${FACE_LOOKS:-7707}" --seed 61 --photos data/faces --no-source
$VTO dataset lipstick --out out/data/lip64d --n "${DEFAULT_LOOKS:-3517}" --seed 53 --no-source --vary gloss_roughness
SETTINGS=(--set loss=graphics --set augment=true --set photo_views=true --set mouth_views=true --set blocks=1
       --set batch_norm=true --set lr=0.0003 --set schedule=cosine --set warmup_steps=50
       --set colour_imitator=blender_addon/models/lipstick_colour.onnx --set lambda_colour=1.0 --set log_every=250
       --set checkpoint_every=1000)
$VTO train encoder --data out/data/lip64d out/data/faces61 --out out/runs/lipstick_encoder_faces "${SETTINGS[@]}" \
    --set steps="${STEPS:-6000}" --set init=out/lipstick_encoder_procedural.onnx
$VTO export --encoder out/runs/lipstick_encoder_faces --out out/lipstick_encoder_faces.onnx
$VTO train encoder --data out/data/lip64d out/data/faces61 --out out/runs/lipstick_encoder_filtered "${SETTINGS[@]}" \
    --set steps="${FILTER_STEPS:-4000}" --set init=out/lipstick_encoder_faces.onnx --set input_filter=3
$VTO export --encoder out/runs/lipstick_encoder_filtered --out blender_addon/models/lipstick_encoder.onnx
python -m benchmarks.bench_photo_sources --compare out/lipstick_encoder_procedural.onnx
