#!/usr/bin/env bash
# The Blender tests on bpy 5.2 (cp313 wheels only) under Python 3.13, in a cached Debian trixie chroot; among them
# test_extension.py builds the extension zip there (pip fetches its wheels), installs it into bpy and runs Match.
#   usage (root; needs the Debian mirror and PyPI): bash scripts/test_blender5.sh [pytest args]
# The chroot and its venv are made once and reused; the checkout is copied in (tracked and untracked, not ignored
# files), never written to. torch is left out (its PyPI cp313 wheel is the CUDA build): torch tests are skipped.
set -euo pipefail
PROJECT=$(cd "$(dirname "$0")/.." && pwd)
ROOT=${VTO_TRIXIE_ROOT:-/work/cache/trixie-py313}
BPY=${BPY52_VERSION:-5.2.3}
VENV=/opt/vto-bpy$BPY

if [ ! -x "$ROOT/usr/bin/apt-get" ]; then
  command -v debootstrap >/dev/null || { apt-get update -q && apt-get install -y -q debootstrap; }
  debootstrap --variant=minbase trixie "$ROOT" http://deb.debian.org/debian
fi
cp /etc/resolv.conf "$ROOT/etc/resolv.conf"
cp /etc/ssl/certs/ca-certificates.crt "$ROOT/etc/host-ca-certificates.crt"  # pip trusts what the host trusts
for d in proc sys dev dev/shm; do mountpoint -q "$ROOT/$d" || mount --bind "/$d" "$ROOT/$d"; done
trap 'for d in dev/shm dev sys proc; do umount "$ROOT/$d" 2>/dev/null || true; done' EXIT
in_root() { chroot "$ROOT" env -i HOME=/root LANG=C.UTF-8 PATH=/usr/local/bin:/usr/bin:/bin \
    PIP_CERT=/etc/host-ca-certificates.crt "$@"; }

if [ ! -x "$ROOT/usr/bin/python3" ]; then
  # Python 3.13 and what the bpy wheel links against (X11 and GL client libraries; no display is used).
  in_root apt-get update -q
  in_root env DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends python3 python3-venv \
      ca-certificates libgl1 libegl1 libx11-6 libxrender1 libxxf86vm1 libxfixes3 libxi6 libxkbcommon0 libsm6 \
      libice6 libxext6 libglib2.0-0t64 libgomp1
  in_root apt-get clean
fi
if [ ! -f "$ROOT$VENV/.installed" ]; then
  # pyproject.toml's pins, less bpy, torch and numpy (bpy 5.2 picks a numpy with cp313 wheels).
  pins=$(python3 -c "import tomllib; p = tomllib.load(open('$PROJECT/pyproject.toml', 'rb'))['project']
print(' '.join(d for d in p['dependencies'] + p['optional-dependencies']['test']
               if d.split('==')[0] not in ('bpy', 'torch', 'numpy')))")
  in_root python3 -m venv "$VENV"
  in_root "$VENV/bin/pip" install -q --disable-pip-version-check "bpy==$BPY" $pins
  touch "$ROOT$VENV/.installed"
fi
if ! in_root "$VENV/bin/python" -c "import setuptools" 2>/dev/null; then
  # test_extension.py builds the zip, and build_extension.py builds the vto_core wheel with pyproject's build backend.
  in_root "$VENV/bin/pip" install -q --disable-pip-version-check $(python3 -c "import tomllib
print(' '.join(tomllib.load(open('$PROJECT/pyproject.toml', 'rb'))['build-system']['requires']))")
fi

rm -rf "$ROOT/project" && mkdir -p "$ROOT/project"
(cd "$PROJECT" && git ls-files -z --cached --others --exclude-standard \
    | tar --null --ignore-failed-read -T - -cf - 2>/dev/null) | tar -C "$ROOT/project" -xf -
in_root env PYTHONPATH=/project PYTHONDONTWRITEBYTECODE=1 bash -c "cd /project && $VENV/bin/python -c \
'import bpy, numpy, sys; print(\"bpy\", bpy.app.version_string, \"numpy\", numpy.__version__, \"python\", sys.version.split()[0])' \
    && $VENV/bin/python -m pytest -q -p no:cacheprovider -m blender $*"
