"""The add-on as a Blender extension: built with Blender's own tool, installed into bpy, `vto` registered."""

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

pytestmark = [pytest.mark.blender, pytest.mark.slow]
pytest.importorskip("bpy")

ROOT = Path(__file__).resolve().parents[2]

INSTALL_AND_RUN = r'''
import sys, bpy
bpy.ops.extensions.package_install_files(filepath=sys.argv[1], repo="user_default", enable_on_install=True)
addon = sys.modules["bl_ext.user_default.vto_match"]
assert addon._cli_handle is not None, "register() did not register the vto command"
import vto_core
print("CORE", vto_core.__file__)
print("RC", addon.run_cli(["render", "hair", "--params", '{"hue": 0.5}', "--res", "16", "--samples", "2",
                           "--out", sys.argv[2]]))
'''


def test_extension_builds_installs_and_runs_the_cli(tmp_path):
    build = subprocess.run([sys.executable, str(ROOT / "scripts" / "build_extension.py"), "--out", str(tmp_path)],
                           capture_output=True, text=True)
    assert build.returncode == 0, build.stdout[-800:] + build.stderr[-800:]
    package = Path(build.stdout.strip().splitlines()[-1])
    assert package.name == "vto_match-0.1.0.zip"
    out = tmp_path / "hair.png"
    env = {"BLENDER_USER_RESOURCES": str(tmp_path / "user"), "PATH": "/usr/bin:/bin"}
    done = subprocess.run([sys.executable, "-c", INSTALL_AND_RUN, str(package), str(out)], capture_output=True,
                          text=True, env=env, cwd=tmp_path)
    assert done.returncode == 0, done.stderr[-1500:]
    lines = dict(line.split(" ", 1) for line in done.stdout.splitlines() if line.startswith(("CORE", "RC")))
    assert "/extensions/user_default/vto_match/_vendor/vto_core/" in lines["CORE"], "vto_core must come from the add-on"
    assert lines["RC"] == "0"
    from vto_core.imageio import read_image

    image, _ = read_image(out)
    assert image.shape == (16, 16, 3) and np.isfinite(image).all()
