#!/usr/bin/env bash
# What a user sees, captured from a checkout, so two commits can be compared value for value and byte for byte
# (scripts/parity_compare.py): `vto match` (lips and hair; Fast, Better, Best) on the astronaut and 3 portraits,
# `vto dataset` (4 samples, and 2 with sensitivity renders, of each product), `vto tryon` and `vto render`.
#   usage: bash scripts/parity_capture.sh TREE OUT     (e.g. a `git worktree` of the commit before, and this one)
# PY (default: this checkout's .venv) runs TREE's code: TREE goes first on PYTHONPATH.
set -u
tree=$(cd "$1" && pwd); mkdir -p "$2"; out=$(cd "$2" && pwd)
export PYTHONPATH=$tree
PY=${PY:-$(cd "$(dirname "$0")/.." && pwd)/.venv/bin/python}
cd $tree
VTO="$PY -m vto_core.cli"
$PY -c "import skimage.data, numpy as np; from vto_core.imageio import write_image; write_image('$out/astronaut.png', skimage.data.astronaut().astype(np.float32)/255)" 2>/dev/null || true
imgs="$out/astronaut.png $tree/benchmarks/photos/nasa_kate_rubins.jpg $tree/benchmarks/photos/nasa_john_phillips.jpg $tree/benchmarks/photos/nasa_nicole_stott.jpg"
for product in lipstick hair; do
  for img in $imgs; do
    for q in fast better best; do
      name=$(basename $img | cut -d. -f1)
      $VTO match --model blender_addon/models/${product}_encoder.onnx --image $img --quality $q --out-params $out/match_${product}_${name}_${q}.json > $out/match_${product}_${name}_${q}.stdout 2> $out/match_${product}_${name}_${q}.stderr
      echo "rc=$?" >> $out/match_${product}_${name}_${q}.stderr
    done
  done
  $VTO dataset $product --out $out/ds_$product --n 4 --seed 3 --quiet > $out/ds_$product.stdout 2>&1
  $VTO dataset $product --out $out/dss_$product --n 2 --seed 5 --sensitivity --quiet > $out/dss_$product.stdout 2>&1
done
$VTO tryon lipstick --image $out/astronaut.png --params "Classic Red" --out $out/tryon.png > $out/tryon.stdout 2>&1
$VTO tryon lipstick --image $tree/benchmarks/photos/nasa_kate_rubins.jpg --params "Chocolate" --crop 64 --out $out/tryon_crop.png >> $out/tryon.stdout 2>&1
$VTO render hair --params '{}' --source 2 --out $out/render_hair.png > $out/render.stdout 2>&1
$VTO render lipstick --params 'preset:Classic Red' --source 2 --out $out/render_lips.png >> $out/render.stdout 2>&1
echo captured
