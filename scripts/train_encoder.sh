#!/usr/bin/env bash
# The shipped encoders, as they were made: render the data, train, export, evaluate on fresh looks.
#   scripts/train_encoder.sh PRODUCT   -> blender_addon/models/<product>_encoder.onnx
# Each product's recipe (data, seeds, network, colour imitator) is its declaration's (vto_core/products.py, Recipe:
# `python -m vto_core.products PRODUCT` prints it), its reasons beside it. Graphics loss (the paper's MIG baseline: no
# imitator at 64 px yet) with mirrored/shifted views, cosine lr.
# CPU: about an hour of rendering per dataset (2 cores) and 10-50 minutes of training; add --device cuda to the
# train line on a GPU. Environment: N (looks), STEPS (optimiser steps), WORKERS (render processes); DRY_RUN=1 prints
# the vto commands instead of running them.
set -euo pipefail
cd "$(dirname "$0")/.."
if [ -n "${DRY_RUN:-}" ]; then VTO="echo vto"; else VTO=.venv/bin/vto; fi
RENDERER=${1:-}
USER_STEPS=${STEPS:-} USER_WORKERS=${WORKERS:-}  # the recipe sets STEPS and WORKERS: the environment's values win
if ! RECIPE=$(.venv/bin/python -m vto_core.products "$RENDERER" 2>/dev/null); then
  echo "usage: scripts/train_encoder.sh $(.venv/bin/python -c 'from vto_core.products import PRODUCTS
print("|".join(name for name, product in PRODUCTS.items() if product.recipe))')" >&2
  exit 2
fi
eval "$RECIPE"  # DATA SEED LOOKS STEPS WORKERS TRAIN_ARGS DATA_ARGS VARIED VARIED_ARGS REFINE COLOUR COLOUR_ARGS ...
STEPS=${USER_STEPS:-$STEPS} WORKERS=${USER_WORKERS:-$WORKERS}
$VTO dataset "$RENDERER" --out "$DATA" --n "${N:-$LOOKS}" --seed "$SEED" --workers "$WORKERS" $DATA_ARGS
if [ -n "$VARIED" ]; then
  $VTO dataset "$RENDERER" --out "$VARIED" --n "${N:-$LOOKS}" --workers "$WORKERS" $VARIED_ARGS
fi
$VTO train encoder --data $VARIED "$DATA" --out "out/runs/${RENDERER}_encoder" --set loss=graphics --set augment=true \
    $TRAIN_ARGS --set steps="$STEPS" --set lr=0.001 --set schedule=cosine --set warmup_steps=100 \
    --set log_every=250 --set checkpoint_every=1000
$VTO export --encoder "out/runs/${RENDERER}_encoder" --out "blender_addon/models/${RENDERER}_encoder.onnx"
# The colour imitator Fast fits a photo's colour through (blender_addon/models/colour_imitator.md), from the recipe's
# COLOUR: none; "own" data (a dataset of COLOUR_ARGS, its folder their --out); or the encoder's "datasets".
case $COLOUR in
  none) COLOUR_DATA="" ;;
  own) [[ $COLOUR_ARGS =~ --out\ ([^ ]+) ]] || { echo "$RENDERER: its recipe's COLOUR_ARGS has no --out" >&2; exit 2; }
       COLOUR_DATA=${BASH_REMATCH[1]}
       $VTO dataset "$RENDERER" $COLOUR_ARGS --workers "$WORKERS" ;;
  datasets) COLOUR_DATA="$VARIED $DATA" ;;
  *) echo "$RENDERER: its recipe's COLOUR is '$COLOUR', not none, own or datasets" >&2; exit 2 ;;
esac
[ -z "$COLOUR_DATA" ] || $VTO train colour --data $COLOUR_DATA --out "blender_addon/models/${RENDERER}_colour.onnx" --set steps=$COLOUR_STEPS
$VTO eval --model "blender_addon/models/${RENDERER}_encoder.onnx" --n 48 --seed 9001 \
    --refine "$REFINE" --out "out/eval/$RENDERER"
