#!/bin/bash
# The extension in a real Blender window: Debian trixie's Blender 4.3.2 (Python 3.13) under Xvfb, in a chroot.
# Builds the linux-x64 zip, installs it from disk as an artist does (no hand edits), opens a .blend with a lips
# material, presses Match in the Material tab and in the Compositor's sidebar with real X11 clicks (xdotool), undoes
# with a real ctrl+z, and saves screenshots and result.json in OUT.   Needs root (chroot, mounts).
#   usage: bash scripts/real_window/run.sh [OUT]     (default /work/cache/real-blender/out; about 2 min with the
#          chroot made by setup_chroot.sh, which this runs first: about 3 min and 1.5 GB the first time)
set -euo pipefail
HERE=$(cd "$(dirname "$0")" && pwd); PROJECT=$(cd "$HERE/../.." && pwd)
CACHE=${VTO_REAL_BLENDER:-/work/cache/real-blender}
OUT=$(mkdir -p "${1:-$CACHE/out}" && cd "${1:-$CACHE/out}" && pwd)
PY=${PY:-$PROJECT/.venv/bin/python}
R=$(bash "$HERE/setup_chroot.sh" "$CACHE/trixie" | tail -1)
P=$R/probe
rm -rf "$P"; mkdir -p "$P/out"
mount_all() { for d in proc sys dev dev/pts; do mountpoint -q "$R/$d" || mount --bind "/$d" "$R/$d"; done; }
umount_all() { for d in dev/pts dev sys proc; do umount "$R/$d" 2>/dev/null || true; done; }
trap umount_all EXIT
mount_all

# The zip as shipped (linux-x64: cp311 and cp313 onnxruntime), and two reference photos rendered by the project.
(cd "$PROJECT" && "$PY" scripts/build_extension.py --out "$CACHE/build" --platform linux-x64 \
    --wheels "${VTO_WHEEL_CACHE:-$CACHE/wheels}" | tail -1 > "$CACHE/zip_path")
cp "$(cat "$CACHE/zip_path")" "$P/vto_match.zip"
# Rendered afresh each run (seconds): a cached one would keep an older scene's lighting after the scene changes.
"$(dirname "$PY")/vto" render lipstick --params "preset:Classic Red" --res 128 --samples 16 \
    --out "$P/lips_ref.png" > /dev/null
"$(dirname "$PY")/vto" render hair --params '{"hue": 0.08, "saturation": 1.6}' --res 128 --samples 8 \
    --out "$P/hair_ref.png" > /dev/null
cp "$HERE/stage1_install.py" "$HERE/stage2_gui.py" "$P/"

# 1. blender -b: install from disk into a fresh user folder, save the preferences, save lips.blend.
chroot "$R" env HOME=/probe BLENDER_USER_RESOURCES=/probe/user blender -b --factory-startup \
    --python-exit-code 3 --python /probe/stage1_install.py -- /probe/vto_match.zip /probe/lips.blend \
    > "$OUT/stage1.log" 2>&1 || { tail -30 "$OUT/stage1.log"; exit 3; }
# 2. the window: Xvfb 1600x1000, Mesa llvmpipe; every step on a timer, clicks and keys from xdotool.
chroot "$R" env HOME=/probe BLENDER_USER_RESOURCES=/probe/user timeout 300 \
    xvfb-run -a -s "-screen 0 1600x1000x24" blender /probe/lips.blend --python-exit-code 3 \
    --python /probe/stage2_gui.py -- /probe/lips_ref.png /probe/hair_ref.png /probe/out \
    > "$OUT/stage2.log" 2>&1 || { tail -30 "$OUT/stage2.log"; exit 4; }
cp "$P"/out/* "$OUT/"
grep -h "^RESULT\|^STEP" "$OUT/stage1.log" "$OUT/stage2.log" | cut -c1-200
ls "$OUT"/result.json
