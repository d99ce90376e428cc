#!/usr/bin/env bash
# The shipped encoders, as they were made: render the data, train, export, evaluate on fresh looks.
#   scripts/train_encoder.sh lipstick|hair      -> blender_addon/models/<renderer>_encoder.onnx
# Graphics loss (the paper's MIG baseline: no imitator at 64 px yet) with mirrored/shifted views, cosine lr.
# CPU: about an hour of rendering per dataset (2 cores) and 10-50 minutes of training; add --device cuda to the
# train line on a GPU. Environment: N (looks), STEPS (optimiser steps), WORKERS (render processes).
# Lipstick renders the default lips scene under its default (portrait) lighting, without the source X (--no-source:
# the graphics loss does not read it), twice: with the coat's Gloss Roughness drawn per look (--vary; the presets use
# 0.05-1) and at its default 0.3, and trains on both as one (held out: the second's tail), a deeper net (a 3x3
# convolution and BatchNorm a level) with photo and mouth views (benchmarks/results/lighting.md, "network";
# presets.md, "roughness").
set -euo pipefail
cd "$(dirname "$0")/.."
VTO=.venv/bin/vto
RENDERER=${1:?usage: scripts/train_encoder.sh lipstick|hair}
case $RENDERER in
  lipstick) DATA=out/data/lip64w SEED=51 LOOKS=24000 STEPS_USED=30000 DATA_ARGS=--no-source
            VARIED=out/data/lip64r VARIED_ARGS="--seed 52 --no-source --vary gloss_roughness"
            TRAIN_ARGS="--set photo_views=true --set mouth_views=true --set blocks=1 --set batch_norm=true" ;;
  hair) DATA=out/data/hair64 SEED=301 LOOKS=5000 STEPS_USED=6000 DATA_ARGS= VARIED= TRAIN_ARGS= ;;
  *) echo "usage: scripts/train_encoder.sh lipstick|hair" >&2; exit 2 ;;
esac
$VTO dataset "$RENDERER" --out "$DATA" --n "${N:-$LOOKS}" --seed "$SEED" --workers "${WORKERS:-2}" $DATA_ARGS
if [ -n "$VARIED" ]; then
  $VTO dataset "$RENDERER" --out "$VARIED" --n "${N:-$LOOKS}" --workers "${WORKERS:-2}" $VARIED_ARGS
fi
$VTO train encoder --data $VARIED "$DATA" --out "out/runs/${RENDERER}_encoder" --set loss=graphics --set augment=true \
    $TRAIN_ARGS --set steps="${STEPS:-$STEPS_USED}" --set lr=0.001 --set schedule=cosine --set warmup_steps=100 \
    --set log_every=250 --set checkpoint_every=1000
$VTO export --encoder "out/runs/${RENDERER}_encoder" --out "blender_addon/models/${RENDERER}_encoder.onnx"
$VTO eval --model "blender_addon/models/${RENDERER}_encoder.onnx" --n 48 --seed 9001 --refine render:25 \
    --out "out/eval/$RENDERER"
