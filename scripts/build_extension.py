"""Build the Blender extension zip(s) with Blender's own tool (blender_ext.py validate, then build).

The extension follows the platform's rules: no vendored folders, no sys.path edits. vto_core and onnxruntime ship as
wheels listed in the manifest (Blender installs them into its extensions' site-packages):

  * vto_core: built here from the repository (pure Python plus presets/*.json), version from pyproject.toml;
  * onnxruntime (one wheel per declared platform and per Python Blender ships: cp311 for Blender 4.2-5.0, cp313 for
    5.1+) and the pure-Python cma and tqdm: the wheels the source manifest names, taken from --wheels DIR when they
    are there, otherwise fetched with `pip download` now, at build time (never when the add-on runs).

The models ship in the add-on's own folder: each declared product's default encoder and model card
(models/<name>_encoder.onnx and .md) are checked before the build, which stops with one line naming any missing (a zip
without one would match nothing for that product).

One zip holds both Pythons' wheels: Blender's tool derives the zip's Python versions from the wheel names (3.11 and
3.13), and Blender installs only the wheels of its own Python, so the same zip installs on 4.2-5.0 and on 5.1+.

Writes only under --out (and into --wheels DIR, used as a download cache, when given). The built zip paths are the
last lines printed.

    python scripts/build_extension.py --out build/                      # one zip for all platforms
    python scripts/build_extension.py --out build/ --split-platforms    # one zip per platform
    python scripts/build_extension.py --out build/ --platform current   # this machine's platform only
"""

from __future__ import annotations

import argparse
import platform as platform_module
import re
import shutil
import subprocess
import sys
import tempfile
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
ADDON = ROOT / "blender_addon"
MANIFEST = "blender_manifest.toml"
# Not shipped: byte code, tests, editor and OS leftovers.
IGNORE = shutil.ignore_patterns("__pycache__", "*.pyc", "tests", ".DS_Store", "*.egg-info", "wheels")

# The Pythons of the Blender releases the manifest allows: 4.2-5.0 run 3.11, 5.1 and later 3.13.
PYTHON_TAGS = ("cp311", "cp313")

# Blender platform -> the wheel platform tags that serve it (blender_ext.py maps macOS universal2 to both).
WHEEL_PLATFORMS = {
    "windows-x64": ("win_amd64",),
    "windows-arm64": ("win_arm64",),
    "linux-x64": ("_x86_64",),
    "linux-arm64": ("_aarch64",),
    "macos-x64": ("_x86_64", "_universal2"),
    "macos-arm64": ("_arm64", "_universal2"),
}


def current_platform() -> str:
    """This machine's platform in Blender's spelling, e.g. "linux-x64"."""
    system = {"linux": "linux", "win32": "windows", "darwin": "macos"}.get(sys.platform, sys.platform)
    machine = platform_module.machine().lower()
    machine = {"x86_64": "x64", "amd64": "x64", "aarch64": "arm64"}.get(machine, machine)
    return f"{system}-{machine}"


def wheel_platform_tag(filename: str) -> str:
    """The platform tag of a wheel file name (the part after the last '-', without .whl)."""
    return filename[: -len(".whl")].split("-")[-1]


def wheel_serves(filename: str, blender_platform: str) -> bool:
    """True when the wheel installs on `blender_platform` (pure-Python wheels install everywhere)."""
    tag = wheel_platform_tag(filename)
    if tag == "any":
        return True
    system = blender_platform.split("-")[0]
    prefix = {"windows": "win", "linux": ("linux", "manylinux", "musllinux"), "macos": "macosx"}[system]
    tags = tag.split(".")  # compressed tag sets: manylinux_2_27_x86_64.manylinux_2_28_x86_64
    return any(t.startswith(prefix) and t.endswith(WHEEL_PLATFORMS[blender_platform]) for t in tags)


def blender_ext_tool() -> Path:
    """blender_ext.py as shipped inside the bpy wheel (or a Blender install)."""
    import bpy

    tool = Path(bpy.utils.system_resource("SCRIPTS")) / "addons_core" / "bl_pkg" / "cli" / "blender_ext.py"
    if not tool.is_file():
        sys.exit(f"build_extension: no blender_ext.py at {tool}")
    return tool


def build_core_wheel(dest: Path) -> Path:
    """vto_core as a wheel of its own (pure Python, presets/*.json included), version from pyproject.toml."""
    # requires-python takes in every Python of PYTHON_TAGS, not only the repository's own 3.11 (pip checks it).
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    with tempfile.TemporaryDirectory() as tmp:
        source = Path(tmp)
        shutil.copytree(ROOT / "vto_core", source / "vto_core", ignore=IGNORE)
        (source / "pyproject.toml").write_text(f'''[build-system]
requires = ["setuptools>=68"]
build-backend = "setuptools.build_meta"

[project]
name = "vto_core"
version = "{project["version"]}"
description = "Core of Match from photo (no bpy): parameter specs, presets, sampling, ONNX encoder inference"
requires-python = ">=3.11"
license = {{ text = "GPL-3.0-or-later" }}
dependencies = ["numpy"]

[tool.setuptools]
packages = ["vto_core", "vto_core.photo"]

[tool.setuptools.package-data]
vto_core = ["presets/*.json"]
''')
        subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "--quiet",
                        "--wheel-dir", str(dest), str(source)], check=True, stdout=sys.stderr)
    (wheel,) = dest.glob(f"vto_core-{project['version']}-py3-none-any.whl")
    return wheel


def fetch_wheel(filename: str, dest: Path, cache: Path | None) -> Path:
    """The wheel `filename` in dest: copied from the cache folder, or pip-downloaded (into the cache if given)."""
    if cache is not None and (cache / filename).is_file():
        return Path(shutil.copy2(cache / filename, dest / filename))
    name, version, python_tag = filename.split("-")[:3]
    download = cache if cache is not None else dest
    download.mkdir(parents=True, exist_ok=True)
    command = [sys.executable, "-m", "pip", "download", f"{name}=={version}", "--no-deps", "--only-binary=:all:",
               "--dest", str(download), "--quiet"]
    if wheel_platform_tag(filename) != "any":  # a binary wheel: ask for its Python and platform, not this machine's
        command += ["--python-version", python_tag.removeprefix("cp"), "--implementation", "cp"]
        for tag in wheel_platform_tag(filename).split("."):
            command += ["--platform", tag]
    subprocess.run(command, check=True, stdout=sys.stderr)
    if not (download / filename).is_file():
        sys.exit(f"build_extension: pip download did not produce {filename}")
    if download != dest:
        shutil.copy2(download / filename, dest / filename)
    return dest / filename


def shipped_models(addon: Path = ADDON) -> list[str]:
    """The files under models/ that each declared product (vto_core.products) ships: its default encoder
    (<name>_encoder.onnx, the one Match reads) and its model card; exits with one line naming what is missing."""
    from vto_core.products import PRODUCTS

    names = [f"{product.name}_encoder{suffix}" for product in PRODUCTS.values() for suffix in (".onnx", ".md")]
    missing = [name for name in names if not (addon / "models" / name).is_file()]
    if missing:
        sys.exit(f"build_extension: {addon.name}/models lacks {', '.join(missing)}: each product ships its encoder "
                 "and model card")
    return names


def toml_list(key: str, values: list[str]) -> str:
    return f"{key} = [\n" + "".join(f'  "{v}",\n' for v in values) + "]"


def write_manifest(path: Path, platforms: list[str], wheels: list[str]) -> None:
    """Rewrite the staged manifest's `platforms` and `wheels` lists to what is staged."""
    text = path.read_text()
    for key, values in (("platforms", platforms), ("wheels", wheels)):
        text, count = re.subn(rf"(?ms)^{key} = \[.*?\]", lambda _: toml_list(key, values), text, count=1)
        if count != 1:
            sys.exit(f"build_extension: no `{key} = [...]` in {path}")
    path.write_text(text)


def build(output_dir: Path, platforms: list[str] | None = None, wheels_dir: Path | None = None,
          split_platforms: bool = False) -> list[Path]:
    """Stage the add-on with its wheels, validate and build; returns the zip paths."""
    manifest = tomllib.loads((ADDON / MANIFEST).read_text())
    declared = list(manifest["platforms"])
    platforms = declared if platforms is None else platforms
    unknown = [p for p in platforms if p not in declared]
    if unknown:
        sys.exit(f"build_extension: platform(s) {', '.join(unknown)} not declared in the manifest ({declared})")
    listed = [Path(w).name for w in manifest["wheels"] if not Path(w).name.startswith("vto_core-")]
    shipped_models()  # copied below with the rest of the add-on: refuse a zip without a product's encoder
    with tempfile.TemporaryDirectory() as staging:
        package = Path(staging) / manifest["id"]
        shutil.copytree(ADDON, package, ignore=IGNORE)
        wheels = package / "wheels"
        wheels.mkdir()
        staged = [build_core_wheel(wheels).name]
        for blender_platform in platforms:
            serving = [w for w in listed if wheel_serves(w, blender_platform)]
            for python_tag in PYTHON_TAGS:
                if not [w for w in serving if w.split("-")[2] == python_tag]:
                    sys.exit(f"build_extension: the manifest lists no {python_tag} onnxruntime wheel for "
                             f"{blender_platform}")
            for filename in serving:
                if filename not in staged:
                    staged.append(fetch_wheel(filename, wheels, wheels_dir).name)
        write_manifest(package / MANIFEST, platforms, [f"./wheels/{w}" for w in staged])
        tool = [sys.executable, str(blender_ext_tool())]
        subprocess.run(tool + ["validate", str(package)], check=True, stdout=sys.stderr)
        output_dir.mkdir(parents=True, exist_ok=True)
        split = split_platforms and len(platforms) > 1
        subprocess.run(tool + ["build", "--source-dir", str(package), "--output-dir", str(output_dir)]
                       + (["--split-platforms"] if split else []), check=True, stdout=sys.stderr)
    stem = f"{manifest['id']}-{manifest['version']}"
    names = [f"{stem}-{p.replace('-', '_')}.zip" for p in platforms] if split else [f"{stem}.zip"]
    zips = [output_dir / name for name in names]
    missing = [str(z) for z in zips if not z.is_file()]
    if missing:
        sys.exit(f"build_extension: Blender's tool did not write {', '.join(missing)}")
    return zips


def main() -> None:
    """python scripts/build_extension.py [--out build/] [--wheels DIR] [--platform current|all|NAME ...]."""
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", default=str(ROOT / "build"), help="folder for the zip(s) (default: build/)")
    parser.add_argument("--wheels", default=None,
                        help="folder holding the wheels the manifest lists; missing ones are pip-downloaded into it")
    parser.add_argument("--platform", nargs="+", default=["all"],
                        help="'all' (default), 'current' (this machine's), or Blender platform names (linux-x64 ...)")
    parser.add_argument("--split-platforms", action="store_true", help="one zip per platform")
    args = parser.parse_args()
    if args.platform == ["all"]:
        platforms = None
    else:
        platforms = [current_platform() if p == "current" else p for p in args.platform]
    wheels = Path(args.wheels).resolve() if args.wheels else None
    for path in build(Path(args.out).resolve(), platforms, wheels, args.split_platforms):
        print(path)


if __name__ == "__main__":
    main()
