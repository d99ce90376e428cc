#!/usr/bin/env bash
# The shipped encoders, as they were made: render the data, train, export, evaluate on fresh looks.
#   scripts/train_encoder.sh lipstick|hair|eyeshadow   -> blender_addon/models/<renderer>_encoder.onnx
# Graphics loss (the paper's MIG baseline: no imitator at 64 px yet) with mirrored/shifted views, cosine lr.
# Hair: regions of the default strands scene (what an artist gives: hair, not a head), 16 looks sharing each source
# render (the stage costs ~7 ms a look, the strands ~1 s), the swatch and shine only (a photo fixes intensity and
# blend), photo views; two datasets of 20,000 looks (1,250 sources each) trained on as one, each rendered by one
# process (two would both render each shared source; the two datasets ran side by side instead).
# CPU: about an hour of rendering per dataset (2 cores) and 10-50 minutes of training; add --device cuda to the
# train line on a GPU. Environment: N (looks), STEPS (optimiser steps), WORKERS (render processes).
# Lipstick renders the default lips scene under its default (portrait) lighting, without the source X (--no-source:
# the graphics loss does not read it), twice: with the coat's Gloss Roughness drawn per look (--vary; the presets use
# 0.05-1) and at its default 0.3, and trains on both as one (held out: each one's last 10 %), a deeper net (a 3x3
# convolution and BatchNorm a level) with photo and mouth views (benchmarks/results/lighting.md, "network";
# presets.md, "roughness").
# Eye shadow renders the default eye scene (portrait lighting, --no-source) once, trains the lipstick's network from
# scratch reading its input box-filtered (input_filter=3, as the lips encoder ends), with photo views; Fast does not fit
# a colour imitator, so none is trained.
set -euo pipefail
cd "$(dirname "$0")/.."
VTO=.venv/bin/vto
RENDERER=${1:?usage: scripts/train_encoder.sh lipstick|hair|eyeshadow}
case $RENDERER in
  lipstick) DATA=out/data/lip64w SEED=51 LOOKS=24000 STEPS_USED=30000 DATA_ARGS=--no-source
            VARIED=out/data/lip64r VARIED_ARGS="--seed 52 --no-source --vary gloss_roughness"
            TRAIN_ARGS="--set photo_views=true --set mouth_views=true --set blocks=1 --set batch_norm=true" WORKERS_USED=2 ;;
  hair) DATA=out/data/hairreg_401 SEED=401 LOOKS=20000 STEPS_USED=12000 DATA_ARGS="--looks-per-source 16"
        VARIED=out/data/hairreg_402 VARIED_ARGS="--seed 402 --looks-per-source 16"
        TRAIN_ARGS="--set photo_views=true --set blocks=1 --set batch_norm=true" WORKERS_USED=1 ;;
  eyeshadow) DATA=out/data/eye64a SEED=81 LOOKS=6000 STEPS_USED=6000 DATA_ARGS=--no-source VARIED="" VARIED_ARGS=""
             TRAIN_ARGS="--set photo_views=true --set blocks=1 --set batch_norm=true --set input_filter=3" WORKERS_USED=1
             REFINE=render:25,photo:fast ;;
  *) echo "usage: scripts/train_encoder.sh lipstick|hair|eyeshadow" >&2; exit 2 ;;
esac
$VTO dataset "$RENDERER" --out "$DATA" --n "${N:-$LOOKS}" --seed "$SEED" --workers "${WORKERS:-$WORKERS_USED}" $DATA_ARGS
if [ -n "$VARIED" ]; then
  $VTO dataset "$RENDERER" --out "$VARIED" --n "${N:-$LOOKS}" --workers "${WORKERS:-$WORKERS_USED}" $VARIED_ARGS
fi
$VTO train encoder --data $VARIED "$DATA" --out "out/runs/${RENDERER}_encoder" --set loss=graphics --set augment=true \
    $TRAIN_ARGS --set steps="${STEPS:-$STEPS_USED}" --set lr=0.001 --set schedule=cosine --set warmup_steps=100 \
    --set log_every=250 --set checkpoint_every=1000
$VTO export --encoder "out/runs/${RENDERER}_encoder" --out "blender_addon/models/${RENDERER}_encoder.onnx"
# The colour imitator Fast fits a photo's colour through (blender_addon/models/colour_imitator.md): lipstick from
# 4,000 looks with their lips masks, hair from the encoder's own looks (they hold their hair masks).
if [ "$RENDERER" = eyeshadow ]; then
  COLOUR_DATA=""
elif [ "$RENDERER" = lipstick ]; then
  $VTO dataset lipstick --out out/data/lipstats --n 4000 --seed 611 --no-source --masks --workers "${WORKERS:-2}"
  COLOUR_DATA=out/data/lipstats COLOUR_STEPS=6000
else
  COLOUR_DATA="$VARIED $DATA" COLOUR_STEPS=8000
fi
[ -z "$COLOUR_DATA" ] || $VTO train colour --data $COLOUR_DATA --out "blender_addon/models/${RENDERER}_colour.onnx" --set steps=$COLOUR_STEPS
$VTO eval --model "blender_addon/models/${RENDERER}_encoder.onnx" --n 48 --seed 9001 \
    --refine "${REFINE:-render:25,photo:fast,photo:better,photo:best}" --out "out/eval/$RENDERER"
