#!/bin/bash
# A Debian trixie chroot with Blender 4.3.2 (Python 3.13), Xvfb, Mesa, ImageMagick and xdotool, for the real-window
# test.  Rerunnable: does nothing when the chroot is complete.  Needs root and the Debian mirror (~3 min, ~1.5 GB).
#   usage: bash scripts/real_window/setup_chroot.sh [CHROOT]     (default /work/cache/real-blender/trixie)
set -euo pipefail
R=${1:-${VTO_REAL_BLENDER:-/work/cache/real-blender}/trixie}
[ -x "$R/usr/bin/blender" ] && [ -x "$R/usr/bin/xdotool" ] && { echo "$R"; exit 0; }
command -v debootstrap >/dev/null || apt-get install -y -q debootstrap >/dev/null
mkdir -p "$(dirname "$R")"
[ -x "$R/usr/bin/apt-get" ] || debootstrap --variant=minbase trixie "$R" http://deb.debian.org/debian >&2
cp /etc/resolv.conf "$R/etc/resolv.conf"
mount_all() { for d in proc sys dev dev/pts; do mountpoint -q "$R/$d" || mount --bind "/$d" "$R/$d"; done; }
umount_all() { for d in dev/pts dev sys proc; do umount "$R/$d" 2>/dev/null || true; done; }
trap umount_all EXIT
mount_all
chroot "$R" apt-get update -q >&2
chroot "$R" env DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends \
    blender xvfb xauth libgl1-mesa-dri libegl-mesa0 python3-numpy python3-openimageio \
    imagemagick xdotool >&2
chroot "$R" apt-get clean
echo "$R"
