#!/bin/bash
# The extension in a real Blender window: Debian trixie's Blender 4.3.2 (Python 3.13) under Xvfb, in a chroot.
# Builds the linux-x64 zip, installs it from disk as an artist does (no hand edits), opens a .blend with a lips
# material, presses Match (Fast, then Better) in the Material tab on a whole portrait, Match (Fast) on an eye-shadow
# material with the portrait wearing eye shadow, and Match (Fast, then Better) in the Compositor's sidebar on the hair, with real X11 clicks (xdotool), undoes with a real ctrl+z, and saves
# screenshots and result.json in OUT. Stage 3, the artist's own character: the MakeHuman head (a copy of
# data/heads/makehuman.blend) in the 3D Viewport, Find Face on Mesh, Add Lipstick Layer and Add Eye Shadow Layer
# clicked in its sidebar, Match clicked for each layer on the portrait wearing eye shadow, then Material Preview through
# the face camera.   Needs root (chroot, mounts).
#   usage: bash scripts/real_window/run.sh [OUT]     (default /work/cache/real-blender/out; about 4 min with the
#          chroot made by setup_chroot.sh, which this runs first: about 3 min and 1.5 GB the first time)
#   VTO_UPDATE_DOCS=1 also copies the panel crops to docs/panel_*.png (the README's pictures) and the character's
#          screenshots to docs/character_window_*.png.
#   VTO_STAGES=3 runs the window stages named (default 23: both; stage 1, the install, always runs).
set -euo pipefail
HERE=$(cd "$(dirname "$0")" && pwd); PROJECT=$(cd "$HERE/../.." && pwd)
CACHE=${VTO_REAL_BLENDER:-/work/cache/real-blender}
OUT=$(mkdir -p "${1:-$CACHE/out}" && cd "${1:-$CACHE/out}" && pwd)
PY=${PY:-$PROJECT/.venv/bin/python}
R=$(bash "$HERE/setup_chroot.sh" "$CACHE/trixie" | tail -1)
# A folder of this run's own inside the chroot (two runs at once must not share one); /$PN inside the chroot.
PN=probe.$$; P=$R/$PN
rm -rf "$P"; mkdir -p "$P/out"
mount_all() { for d in proc sys dev dev/pts; do mountpoint -q "$R/$d" || mount --bind "/$d" "$R/$d"; done; }
umount_all() {  # only when no other run is inside the chroot
    ls -d "$R"/probe.* >/dev/null 2>&1 && return
    for d in dev/pts dev sys proc; do umount "$R/$d" 2>/dev/null || true; done
}
trap 'rm -rf "$P" "$P.build"; umount_all' EXIT
mount_all

# The zip as shipped (linux-x64: cp311 and cp313 onnxruntime).
ZIP=$(cd "$PROJECT" && "$PY" scripts/build_extension.py --out "$P.build" --platform linux-x64 \
    --wheels "${VTO_WHEEL_CACHE:-$CACHE/wheels}" | tail -1)
cp "$ZIP" "$P/vto_match.zip"
# The reference is a real photograph: scikit-image's astronaut (NASA, public domain), the whole portrait for the lips
# and for the hair (the add-on finds both), written as a PNG.
"$PY" - "$P/astronaut.png" <<'PYEOF'
import sys
from PIL import Image
from skimage import data
Image.fromarray(data.astronaut()).save(sys.argv[1])
PYEOF
# The eye-shadow reference: the same portrait wearing Royal Purple on both lids (`vto tryon eyeshadow`, Cycles here).
"$PROJECT/.venv/bin/vto" tryon eyeshadow --image "$P/astronaut.png" --params "Royal Purple" --out "$P/eyes.png" \
    > "$OUT/tryon.log" 2>&1 || { tail -5 "$OUT/tryon.log"; exit 3; }
cp "$HERE/stage1_install.py" "$HERE/stage2_gui.py" "$HERE/stage3_character.py" "$P/"
# The character: the MakeHuman base mesh (CC0; one mesh "head" under one skin material, and the eyes).
cp "$PROJECT/data/heads/makehuman.blend" "$P/makehuman.blend"
STAGES=${VTO_STAGES:-23}

# 1. blender -b: install from disk into a fresh user folder, save the preferences, save lips.blend.
chroot "$R" env HOME=/$PN BLENDER_USER_RESOURCES=/$PN/user blender -b --factory-startup \
    --python-exit-code 3 --python /$PN/stage1_install.py -- /$PN/vto_match.zip /$PN/lips.blend \
    > "$OUT/stage1.log" 2>&1 || { tail -30 "$OUT/stage1.log"; exit 3; }
# 2. the window: Xvfb 1600x1000, Mesa llvmpipe; every step on a timer, clicks and keys from xdotool. On failure
#    (exit 4) OUT still gets what stage 2 wrote: result.json up to the step it reached, and the screenshots.
FAILED=0
if [[ $STAGES == *2* ]]; then
    chroot "$R" env HOME=/$PN BLENDER_USER_RESOURCES=/$PN/user timeout 480 \
        xvfb-run -a -s "-screen 0 1600x1000x24" blender /$PN/lips.blend --python-exit-code 3 \
        --python /$PN/stage2_gui.py -- /$PN/astronaut.png /$PN/astronaut.png /$PN/out /$PN/eyes.png \
        > "$OUT/stage2.log" 2>&1 || { tail -30 "$OUT/stage2.log"; FAILED=4; }
fi
# 3. the character, in a window of its own (the head .blend opened): its entries join stage 2's in result.json
#    (under "character"). On failure (exit 5) OUT still gets what it wrote.
if [[ $STAGES == *3* ]]; then
    chroot "$R" env HOME=/$PN BLENDER_USER_RESOURCES=/$PN/user timeout 480 \
        xvfb-run -a -s "-screen 0 1600x1000x24" blender /$PN/makehuman.blend --python-exit-code 3 \
        --python /$PN/stage3_character.py -- /$PN/eyes.png /$PN/out \
        > "$OUT/stage3.log" 2>&1 || { tail -30 "$OUT/stage3.log"; [ $FAILED != 0 ] || FAILED=5; }
fi
cp "$P"/out/* "$OUT/" 2>/dev/null || true
[ $FAILED = 0 ] || exit $FAILED
grep -h "^RESULT\|^STEP" "$OUT/stage1.log" "$OUT"/stage[23].log | cut -c1-200
ls "$OUT"/result.json
if [ "${VTO_UPDATE_DOCS:-0}" = 1 ]; then
    for pair in lips_before:panel_before_match lips_after:panel_after_match lips_better:panel_after_better \
                hair_better:panel_hair_after_better hair_after:panel_hair_after_match \
                eyes_matched:panel_eyeshadow_after_match; do
        if [[ $STAGES == *2* ]]; then cp "$OUT/${pair%%:*}_panel.png" "$PROJECT/docs/${pair#*:}.png"; fi
    done
    for name in before found matched; do  # the head and the sidebar (and, matched, the Match panel) in one crop
        if [[ $STAGES == *3* ]]; then cp "$OUT/character_${name}_docs.png" "$PROJECT/docs/character_window_$name.png"; fi
    done
fi
