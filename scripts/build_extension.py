"""Build the Blender extension zip: blender_addon with vto_core vendored in _vendor/, via Blender's own tool."""

from __future__ import annotations

import argparse
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def blender_ext_tool() -> Path:
    """blender_ext.py as shipped inside the bpy wheel (or a Blender install)."""
    import bpy

    tool = Path(bpy.utils.system_resource("SCRIPTS")) / "addons_core" / "bl_pkg" / "cli" / "blender_ext.py"
    if not tool.is_file():
        sys.exit(f"build_extension: no blender_ext.py at {tool}")
    return tool


def build(output_dir: Path) -> Path:
    """Stage the add-on with vto_core inside it, validate and build; returns the zip's path."""
    ignore = shutil.ignore_patterns("__pycache__", "*.pyc")
    with tempfile.TemporaryDirectory() as staging:
        package = Path(staging) / "vto_match"
        shutil.copytree(ROOT / "blender_addon", package, ignore=ignore)
        shutil.copytree(ROOT / "vto_core", package / "_vendor" / "vto_core", ignore=ignore)
        tool = [sys.executable, str(blender_ext_tool())]
        subprocess.run(tool + ["validate", str(package)], check=True)
        output_dir.mkdir(parents=True, exist_ok=True)
        subprocess.run(tool + ["build", "--source-dir", str(package), "--output-dir", str(output_dir)], check=True)
    zips = sorted(output_dir.glob("vto_match-*.zip"))
    return zips[-1]


def main() -> None:
    """python scripts/build_extension.py [--out build/]."""
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--out", default=str(ROOT / "build"))
    print(build(Path(parser.parse_args().out)))


if __name__ == "__main__":
    main()
