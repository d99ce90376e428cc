#!/usr/bin/env bash
# The lips encoder fine-tuned on faces of every skin tone (issue "Dark lipsticks read dark"): the shipped encoder
# trained on the London Set's training people (data/faces/london, its 'train' split: 63 people, neutral and smiling;
# never its 39 evaluation people) beside the training faces of data/faces and fresh default-scene looks.
#   scripts/train_encoder_skin_tones.sh NAME [--set key=value ...]   -> out/NAME.onnx
# The shipped file (2026-11-29, the run whole_c): `START=<the 2026-11-28 file, london_wn> STEPS=4000
# scripts/train_encoder_skin_tones.sh whole_c --set graphics_error=absolute`, on datasets rendered since the try-on
# paints a closed mouth's lips whole (2026-11-29), with dark82l given twice beside them. london_wn (2026-11-28) was
# `START=out/london_wm.onnx STEPS=4000 ... london_wn --set graphics_error=absolute` on the datasets of its day (a bare
# band through closed mouths, no dark82l), where london_wm is `START=out/london_wl.onnx STEPS=4000 ... london_wm --set
# graphics_error=absolute` run before london80l and lip64m existed, london_wl `START=out/london_w.onnx STEPS=2000 ...
# london_wl --set graphics_error=absolute` before lip64l, and london_w `START=out/london_k.onnx STEPS=3000 ...
# london_w` before london78l; then copied to blender_addon/models/lipstick_encoder.onnx. The one before them
# (2026-11-27, london_l1) was trained from a193996's file on the first three datasets alone. The datasets resume where
# they stopped (each is skipped once whole). CPU (2026-11-29): 33,000 looks at about 5 a second in each of two
# processes (about 55 min), then 4,000 steps in 7 min on one thread (150 looks a second).
set -euo pipefail
cd "$(dirname "$0")/.."
VTO=.venv/bin/vto
NAME=$1; shift
START=${START:-blender_addon/models/lipstick_encoder.onnx}
$VTO dataset lipstick --out out/data/london71 --n 3000 --seed 71 --photos data/faces/london --no-source
$VTO dataset lipstick --out out/data/faces72 --n 2000 --seed 72 --photos data/faces --no-source
$VTO dataset lipstick --out out/data/lip64e --n 2000 --seed 73 --no-source --vary gloss_roughness
# Products near the presets (90 %), then about each preset (a kernel 0.06 wide): the dark end the presets have, which
# one normal fitted on them gives to 2 % of its draws. The kernels leave out the skin-tone benchmark's 14 products
# (the normal, as every dataset before, is fitted on all 36 presets).
HELD_OUT=$(.venv/bin/python -c "from benchmarks.bench_skin_tones import PRODUCTS; print(','.join(PRODUCTS))")
$VTO dataset lipstick --out out/data/london74p --n 3000 --seed 74 --photos data/faces/london --no-source \
    --uniform-ratio 0.1
$VTO dataset lipstick --out out/data/london75k --n 3000 --seed 75 --photos data/faces/london --no-source \
    --uniform-ratio 0.1 --preset-kernel 0.06 --without-presets "$HELD_OUT"
# Wider kernels (0.12) and a fifth drawn uniformly, on the London faces and on the default lips: the neutral blacks and
# deep browns between the dark presets left in (the benchmark's dark products are all left out of the kernels).
$VTO dataset lipstick --out out/data/london76k --n 3000 --seed 76 --photos data/faces/london --no-source \
    --uniform-ratio 0.2 --preset-kernel 0.12 --without-presets "$HELD_OUT"
$VTO dataset lipstick --out out/data/lip64k --n 2000 --seed 77 --no-source \
    --uniform-ratio 0.2 --preset-kernel 0.12 --without-presets "$HELD_OUT"
# Colours spread evenly over lightness (a third of the looks, sampling.at_lightness), the rest as above.
$VTO dataset lipstick --out out/data/london78l --n 3000 --seed 78 --photos data/faces/london --no-source \
    --uniform-ratio 0.3 --uniform-lightness --preset-kernel 0.12 --without-presets "$HELD_OUT"
$VTO dataset lipstick --out out/data/lip64l --n 3000 --seed 79 --no-source \
    --uniform-ratio 0.3 --uniform-lightness --preset-kernel 0.12 --without-presets "$HELD_OUT"
# Half of the looks spread evenly over lightness, on the London faces and on the default lips: more of the dark end,
# where the products still read light (Goth Black, and the black faces' products).
$VTO dataset lipstick --out out/data/london80l --n 3000 --seed 80 --photos data/faces/london --no-source \
    --uniform-ratio 0.5 --uniform-lightness --preset-kernel 0.12 --without-presets "$HELD_OUT"
$VTO dataset lipstick --out out/data/lip64m --n 3000 --seed 81 --no-source \
    --uniform-ratio 0.5 --uniform-lightness --preset-kernel 0.12 --without-presets "$HELD_OUT"
# The training split's darker-skinned faces alone: the London Set's 4 training people who are not white (of 63; the
# skin-tone benchmark's evaluation holds 29 such of 39) and data/faces' 2 training faces of dark skin (of 98): their
# folder is given twice (its 3,000 looks weigh as 6,000 of the 26,000 on real faces): once, the black group's bias
# fell as far, but the dark products read no darker and the held-out NASA round trip lost 0.35 (2026-11-29, whole_b).
DARK=out/faces_darker
mkdir -p "$DARK"
.venv/bin/python - "$DARK" <<'PY'
import json, sys
from pathlib import Path
out, kept = Path(sys.argv[1]), []
for listing, darker in (("data/faces/london/faces.json", lambda e: e["ethnicity"] != "white"),
                        ("data/faces/faces.json", lambda e: e.get("skin") == "dark")):
    for entry in json.loads(Path(listing).read_text()):
        photo = Path(listing).parent / Path(entry["file"]).name
        if entry["split"] == "train" and darker(entry) and photo.is_file():
            link = out / photo.name
            if not link.exists():
                link.symlink_to(photo.resolve())
            kept.append({"file": photo.name, "split": "train"})
(out / "faces.json").write_text(json.dumps(kept, indent=1))
PY
$VTO dataset lipstick --out out/data/dark82l --n 3000 --seed 82 --photos "$DARK" --no-source \
    --uniform-ratio 0.5 --uniform-lightness --preset-kernel 0.12 --without-presets "$HELD_OUT"
SETTINGS=(--set loss=graphics --set augment=true --set photo_views=true --set mouth_views=true --set blocks=1
       --set batch_norm=true --set lr=0.0003 --set schedule=cosine --set warmup_steps=50 --set input_filter=3
       --set colour_imitator=blender_addon/models/lipstick_colour.onnx --set lambda_colour=1.0 --set log_every=250
       --set checkpoint_every=1000 --set steps="${STEPS:-4000}")
# The shipped file (whole_c) was trained with the held-out tail of all the folders together (`--set val_split=tail`,
# the only split then): of dark82l given twice, the whole second copy and the last 600 looks of the first, so it
# trained on 2,400 of its 3,000 looks, once; whole_b and whole_d, which gave it once and last, never trained on it
# (found on 2026-11-29). `vto train` now holds out each folder's own last 10 % and names them in its log and in the
# run's config.json (`held_out`).
$VTO train encoder --data out/data/lip64e out/data/faces72 out/data/london71 out/data/london74p out/data/london75k \
    out/data/london76k out/data/lip64k out/data/london78l out/data/lip64l out/data/london80l out/data/lip64m \
    out/data/dark82l out/data/dark82l \
    --out "out/runs/$NAME" \
    "${SETTINGS[@]}" --set init="$START" "$@"
$VTO export --encoder "out/runs/$NAME" --out "out/$NAME.onnx"
