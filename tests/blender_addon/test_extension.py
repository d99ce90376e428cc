"""The add-on as a Blender extension: built with Blender's own tool, installed into bpy, `vto` registered.

The extension ships vto_core and onnxruntime as wheels (no vendored folder, no sys.path edits). Blender installs
extension wheels into <user resources>/extensions/.local/lib/python3.X/site-packages and appends that folder to
sys.path, so in this venv its own onnxruntime would win; the install runs in an isolated Python (`-I -S`) that sees
only what Blender's own Python ships that we need (bpy and its requirements, numpy, OpenImageIO), as inside
Blender.
"""

import importlib.util
import json
import os
import re
import subprocess
import sys
import tomllib
import zipfile
from pathlib import Path

import numpy as np
import pytest

pytestmark = [pytest.mark.blender, pytest.mark.slow]
pytest.importorskip("bpy")

from vto_core.products import product_names  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
ONNXRUNTIME = "1.18.1"  # cp311: Blender 4.2-5.0
ONNXRUNTIME_313 = "1.20.0"  # cp313: Blender 5.1+, the first onnxruntime with cp313 wheels
PYTHON = f"python{sys.version_info[0]}.{sys.version_info[1]}"  # bpy 4.5 and 5.0 run 3.11, bpy 5.1+ 3.13
# Blender's own Python ships these; the venv's other packages (its onnxruntime among them) stay out of sight.
# bpy's own requirements too: Blender 5.2's extensions add-on imports cattrs when it registers.
# Each declared product's default encoder and model card ship in the zip (scripts/build_extension.py shipped_models).
SHIPPED_MODELS = [f"{name}_encoder{suffix}" for name in product_names()
                  for suffix in (".onnx", ".md")]
CARDS = sorted(f"models/{p.name}" for p in (ROOT / "blender_addon" / "models").glob("*.md"))
BLENDER_PYTHON_MODULES = ["bpy", "numpy", "numpy.libs", "OpenImageIO", "attr", "attrs", "cattrs", "requests",
                          "urllib3", "certifi", "idna", "charset_normalizer", "zstandard", "typing_extensions.py"]

INSTALL_AND_RUN = r'''
import json, sys
sys.path.insert(0, sys.argv[1])
import bpy
package, out, params = sys.argv[2:5]
bpy.ops.extensions.package_install_files(filepath=package, repo="user_default", enable_on_install=True)
addon = sys.modules["bl_ext.user_default.vto_match"]
assert addon._cli_handle is not None, "register() did not register the vto command"
import onnxruntime, vto_core
report = {"addon": addon.__file__, "vto_core": vto_core.__file__, "onnxruntime": onnxruntime.__file__,
          "onnxruntime_version": onnxruntime.__version__, "sys_path": sys.path,
          "blender_addon_alias": "blender_addon" in sys.modules,
          "extensions_site": bpy.utils.user_resource("EXTENSIONS", path=".local")}
report["render"] = addon.run_cli(["render", "hair", "--params", '{"hue": 0.5}', "--res", "16", "--samples", "2",
                                  "--out", out])
model = str(__import__("pathlib").Path(addon.__file__).parent / "models" / "hair_encoder.onnx")
report["match"] = addon.run_cli(["match", "--model", model, "--image", out, "--out-params", params,
                                 "--source", "0", "--refine", "render:3", "--samples", "2"])
# The operators, the panel's Match with the shipped model, and batch, all from the installed copy.
lips_png, folder = params.replace(".json", "_lips.png"), params.replace(".json", "_photos")
report["render_lips"] = addon.run_cli(["render", "lipstick", "--params", "preset:Classic Red", "--res", "64",
                                       "--samples", "2", "--out", lips_png])
mesh = bpy.data.meshes.new("Lips")
mesh.from_pydata([(0, 0, 0), (1, 0, 0), (1, 1, 0)], [], [(0, 1, 2)])
bpy.context.scene.collection.objects.link(bpy.data.objects.new("Lips", mesh))
bpy.context.view_layer.objects.active = bpy.data.objects["Lips"]
report["add_material"] = sorted(bpy.ops.vto.add_lipstick_material())
report["add_hair"] = sorted(bpy.ops.vto.add_hair_compositor())
material = bpy.data.objects["Lips"].active_material
report["match_op"] = sorted(bpy.ops.vto.match_from_photo(material=material.name, image_path=lips_png))
(group,) = [n for n in material.node_tree.nodes if getattr(n, "node_tree", None) and n.node_tree.name == "VTO Lipstick"]
report["written"] = {s.name: s.default_value for s in group.inputs if s.type == "VALUE"}
# Eye shadow: a render of one eye, a new material from the generic button, Match with the shipped eye-shadow model and
# Find Eyelids off (a close-up of one eye has no face to find them in).
eye_png = params.replace(".json", "_eye.png")
report["render_eye"] = addon.run_cli(["render", "eyeshadow", "--params", "preset:Plum", "--res", "32", "--samples",
                                      "2", "--out", eye_png])
lid = bpy.data.meshes.new("Lid")
lid.from_pydata([(0, 0, 0), (1, 0, 0), (1, 1, 0)], [], [(0, 1, 2)])
bpy.context.scene.collection.objects.link(bpy.data.objects.new("Lid", lid))
bpy.context.view_layer.objects.active = bpy.data.objects["Lid"]
report["add_eyeshadow"] = sorted(bpy.ops.vto.add_material(product="eyeshadow"))
shade = bpy.data.objects["Lid"].active_material
report["match_eyeshadow"] = sorted(bpy.ops.vto.match_from_photo(target="EYESHADOW", material=shade.name,
                                                                image_path=eye_png, find_region=False))
(shadow,) = [n for n in shade.node_tree.nodes if getattr(n, "node_tree", None) and n.node_tree.name == "VTO Eye Shadow"]
report["written_eyeshadow"] = {s.name: s.default_value for s in shadow.inputs if s.type == "VALUE"}
compat = __import__("bl_ext.user_default.vto_match.compat", fromlist=["compositor_tree"])
report["hair_groups"] = sorted(n.node_tree.name for n in compat.compositor_tree(bpy.context.scene).nodes
                               if getattr(n, "node_tree", None))
import os, shutil
os.makedirs(folder)
shutil.copy(lips_png, os.path.join(folder, "red_1.png"))
shutil.copy(lips_png, os.path.join(folder, "red_2.png"))
open(os.path.join(folder, "broken_1.png"), "wb").write(b"not an image")
lip_model = str(__import__("pathlib").Path(addon.__file__).parent / "models" / "lipstick_encoder.onnx")
report["batch"] = addon.run_cli(["batch", "--model", lip_model, "--images", folder, "--out", folder + "_out",
                                 "--group-by", "^([a-z]+)_", "--res", "16", "--samples", "1", "--quiet"])
report["modules"] = {name: sys.modules[name].__file__ for name in ("vto_core.cli", "onnxruntime", "cma")}
report["scipy"] = "scipy" in sys.modules
report["commands"] = sorted(m for m in sys.modules if m.endswith((".commands", ".match")))
print("REPORT " + json.dumps(report))
'''


def wheel_cache() -> Path:
    """Where the onnxruntime wheel is kept between runs (pip-downloaded once by the build script)."""
    base = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
    return Path(os.environ.get("VTO_WHEEL_CACHE") or base / "vto_match" / "wheels")


def load_blender_ext():
    """Blender's own extension tool (blender_ext.py from the bpy wheel) as a module."""
    import bpy

    path = Path(bpy.utils.system_resource("SCRIPTS")) / "addons_core" / "bl_pkg" / "cli" / "blender_ext.py"
    spec = importlib.util.spec_from_file_location("blender_ext", path)
    module = importlib.util.module_from_spec(spec)
    sys.modules.setdefault("blender_ext", module)
    spec.loader.exec_module(module)
    return module


def load_build_script():
    """scripts/build_extension.py as a module."""
    spec = importlib.util.spec_from_file_location("build_extension", ROOT / "scripts" / "build_extension.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_build_ships_each_products_encoder_and_card_or_stops_in_one_line(tmp_path):
    """The build's list of models is one encoder and one model card a declared product, the eye shadow's among them;
    a folder that lacks one stops the build with one line naming it."""
    from vto_core.products import PRODUCTS

    build = load_build_script()
    assert sorted(SHIPPED_MODELS) == sorted(f"{p.name}_encoder{s}" for p in PRODUCTS.values() for s in (".onnx", ".md"))
    addon = tmp_path / "vto_match"
    (addon / "models").mkdir(parents=True)
    for name in SHIPPED_MODELS:
        (addon / "models" / name).write_bytes(b"model")
    assert build.shipped_models(addon) == SHIPPED_MODELS
    (addon / "models" / "eyeshadow_encoder.onnx").unlink()
    with pytest.raises(SystemExit) as stopped:
        build.shipped_models(addon)
    assert str(stopped.value) == ("build_extension: vto_match/models lacks eyeshadow_encoder.onnx: each product ships "
                                  "its encoder and model card")


def test_every_platform_zip_carries_both_pythons_onnxruntime(tmp_path):
    """--split-platforms: one zip per platform, each with a cp311 and a cp313 onnxruntime of that platform only."""
    build = subprocess.run([sys.executable, str(ROOT / "scripts" / "build_extension.py"), "--out", str(tmp_path),
                            "--split-platforms", "--wheels", str(wheel_cache())], capture_output=True, text=True)
    assert build.returncode == 0, build.stdout[-800:] + build.stderr[-800:]
    zips = [Path(line) for line in build.stdout.splitlines() if line.endswith(".zip")]  # bpy 5.2 logs to stdout
    assert [z.name for z in zips] == [f"vto_match-0.1.0-{p}.zip" for p in
                                      ("windows_x64", "linux_x64", "macos_arm64", "macos_x64")]
    tags = {"windows_x64": "win_amd64", "linux_x64": "x86_64", "macos_arm64": "universal2", "macos_x64": "universal2"}
    ext = load_blender_ext()
    for package in zips:
        with zipfile.ZipFile(package) as archive:
            names = archive.namelist()
            wheels = sorted(n.split("/")[-1] for n in names if n.startswith("wheels/onnxruntime-"))
            manifest = archive.read("blender_manifest.toml").decode()
        # the model cards ship with their models; the lab notebook (docs/experiments/) stays in the repository
        assert sorted(n for n in names if n.endswith(".md")) == CARDS, package.name
        platform = package.stem.split("-")[-1]
        assert [w.split("-")[1:3] for w in wheels] == [[ONNXRUNTIME, "cp311"], [ONNXRUNTIME_313, "cp313"]], wheels
        assert all(w.removesuffix(".whl").endswith(tags[platform]) for w in wheels), (package.name, wheels)
        assert f'platforms = ["{platform.replace("_", "-")}"]' in manifest
        assert sorted(ext.python_versions_from_wheels(wheels)) == [(3, 11), (3, 13)]

    # What Blender's install check says (the same function its Install from Disk calls), for the linux-x64 zip.
    source = tomllib.loads((ROOT / "blender_addon" / "blender_manifest.toml").read_text())
    versions = {key: source[key] for key in ("blender_version_min", "blender_version_max")}

    def verdict(python, blender):
        messages = []
        skip = ext.repository_filter_skip(
            item={"platforms": ["linux-x64"], "python_versions": ["3.11", "3.13"], **versions},
            filter_blender_version=blender, filter_python_version=python,
            filter_platform="linux-x64", skip_message_fn=messages.append, error_fn=messages.append)
        return skip, messages

    assert verdict((3, 11, 9), (4, 5, 3)) == (False, []) and verdict((3, 11, 13), (5, 0, 1)) == (False, [])
    assert verdict((3, 13, 5), (4, 3, 2)) == (False, []) and verdict((3, 13, 9), (5, 1, 0)) == (False, [])
    assert verdict((3, 13, 9), (5, 2, 3)) == (False, [])
    assert verdict((3, 12, 3), (4, 4, 0)) == (True, ["This Python version (3.12) isn't compatible with (3.11, 3.13)"])
    maximum = versions["blender_version_max"]
    skip, messages = verdict((3, 13, 9), tuple(int(v) for v in maximum.split(".")))
    assert skip and messages == [f"This Blender version ({maximum}) must be less than the maximum version ({maximum})"]


def blender_python_site(folder: Path) -> Path:
    """A site folder holding links to the modules Blender's Python ships, taken from this venv."""
    folder.mkdir()
    site = Path(importlib.util.find_spec("bpy").origin).parent.parent
    for name in BLENDER_PYTHON_MODULES:
        if (site / name).exists():
            (folder / name).symlink_to(site / name)
    return folder


def test_extension_builds_installs_and_runs_the_cli(tmp_path):
    build = subprocess.run([sys.executable, str(ROOT / "scripts" / "build_extension.py"), "--out", str(tmp_path),
                            "--platform", "current", "--wheels", str(wheel_cache())], capture_output=True, text=True)
    assert build.returncode == 0, build.stdout[-800:] + build.stderr[-800:]
    package = Path(build.stdout.strip().splitlines()[-1])
    assert package == tmp_path / "vto_match-0.1.0.zip" and package.is_file()

    with zipfile.ZipFile(package) as archive:
        names = archive.namelist()
        manifest = archive.read("blender_manifest.toml").decode()
    wheels = sorted(n for n in names if n.startswith("wheels/"))
    assert len(wheels) == 5, wheels
    assert wheels[0] == "wheels/cma-4.5.0-py3-none-any.whl"
    assert wheels[1].startswith(f"wheels/onnxruntime-{ONNXRUNTIME}-cp311-cp311-") and wheels[1].endswith(".whl")
    assert wheels[2].startswith(f"wheels/onnxruntime-{ONNXRUNTIME_313}-cp313-cp313-") and wheels[2].endswith(".whl")
    assert wheels[3:] == ["wheels/tqdm-4.70.1-py3-none-any.whl", "wheels/vto_core-0.1.0-py3-none-any.whl"]
    # Blender derives the zip's Python versions from the wheel names: both 3.11 and 3.13, so 4.2-5.0 and 5.1+ install it
    ext = load_blender_ext()
    assert sorted(ext.python_versions_from_wheels([w.split("/")[-1] for w in wheels])) == [(3, 11), (3, 13)]
    assert 'blender_version_min = "4.2.0"' in manifest and 'blender_version_max = "5.3.0"' in manifest
    for wheel in wheels:
        assert f'"./{wheel}"' in manifest, f"{wheel} is not listed in the built manifest"
    assert not [n for n in names if "_vendor" in n or "__pycache__" in n or n.endswith(".pyc") or "tests/" in n]
    for model in SHIPPED_MODELS:
        assert f"models/{model}" in names
    assert "vto_core/" not in {n.split("/")[0] + "/" for n in names}, "vto_core must come as a wheel, not a folder"

    user = tmp_path / "user"
    out, params = tmp_path / "hair.png", tmp_path / "hair.json"
    env = {"BLENDER_USER_RESOURCES": str(user), "PATH": "/usr/bin:/bin", "HOME": str(tmp_path)}
    done = subprocess.run([sys.executable, "-I", "-S", "-c", INSTALL_AND_RUN,
                           str(blender_python_site(tmp_path / "blender_site")), str(package), str(out), str(params)],
                          capture_output=True, text=True, env=env, cwd=tmp_path)
    assert done.returncode == 0, done.stdout[-1500:] + done.stderr[-1500:]
    assert "Traceback" not in done.stderr, done.stderr[-3000:]  # e.g. an add-on of Blender's that failed to register
    (line,) = [line for line in done.stdout.splitlines() if line.startswith("REPORT ")]
    report = json.loads(line.removeprefix("REPORT "))

    installed = user / "extensions" / "user_default" / "vto_match"
    site = user / "extensions" / ".local" / "lib" / PYTHON / "site-packages"
    assert Path(report["extensions_site"]) == user / "extensions" / ".local"
    assert Path(report["addon"]) == installed / "__init__.py"
    assert Path(report["vto_core"]) == site / "vto_core" / "__init__.py"
    assert Path(report["modules"]["vto_core.cli"]) == site / "vto_core" / "cli.py"
    assert Path(report["onnxruntime"]) == site / "onnxruntime" / "__init__.py"
    assert report["onnxruntime_version"] == (ONNXRUNTIME if sys.version_info < (3, 13) else ONNXRUNTIME_313)
    assert Path(report["modules"]["cma"]) == site / "cma" / "__init__.py"
    assert not report["scipy"], "Blender's Python has no scipy"
    assert str(site) in report["sys_path"]
    assert not [p for p in report["sys_path"] if "_vendor" in p or str(installed) in p]
    assert not report["blender_addon_alias"], "no sys.modules alias: the CLI is told the extension's package"
    assert report["commands"] == ["bl_ext.user_default.vto_match.matching.commands",
                                  "bl_ext.user_default.vto_match.matching.match",
                                  "bl_ext.user_default.vto_match.renderers.commands"]
    for model in SHIPPED_MODELS:
        assert (installed / "models" / model).is_file()
    assert (site / "vto_core" / "presets" / "lipstick.json").is_file()

    assert report["render"] == 0 and report["match"] == 0, done.stderr[-1500:]
    from vto_core.imageio import read_image

    image, _ = read_image(out)
    assert image.shape == (16, 16, 3) and np.isfinite(image).all()
    (matched,) = [json.loads(line) for line in done.stdout.splitlines() if line.startswith('{"out": "' + str(params))]
    assert matched["refined"] is True and not matched["note"], "the render search (cma) ran in the installed copy"
    estimate = json.loads(params.read_text())
    assert estimate["renderer"] == "hair" and estimate["params"]
    assert all(np.isfinite(v) for v in estimate["params"].values())

    # The operators and batch of the installed copy: the shipped lipstick model's estimate lands in the group.
    assert report["render_lips"] == 0 and report["add_material"] == ["FINISHED"] == report["match_op"]
    assert report["add_hair"] == ["FINISHED"] and report["hair_groups"] == ["VTO Hair Color", "VTO Hair Swatch"]
    print("\n".join(line for line in done.stdout.splitlines() if line.startswith("Info: matched")))  # shown by -rP
    from vto_core.inference import EncoderSession
    from vto_core.products import get_spec

    from blender_addon.matching.colour_fit import fit_photo_fast
    from blender_addon.matching.reference import read_reference

    # the panel's Fast on the render (a close-up of lips): the encoder, fitted through the shipped colour imitator
    reference = read_reference("lipstick", {"image_path": str(tmp_path / "hair_lips.png")})
    session = EncoderSession(str(installed / "models" / "lipstick_encoder.onnx"))
    estimate = session.predict(reference.image)[0]
    expected = fit_photo_fast(session.spec, reference.region, {k: estimate[k] for k in session.spec.modelled},
                              installed / "models" / "lipstick_colour.onnx")[0]
    spec = get_spec("lipstick")
    for name in spec.modelled:
        written = report["written"][spec.by_name[name].socket]
        assert written == pytest.approx(expected[name], rel=1e-4, abs=1e-4), name
    # eye shadow: a photo of one eye read as framed, the shipped eye-shadow model's estimate in the group
    assert report["render_eye"] == 0 and report["add_eyeshadow"] == ["FINISHED"] == report["match_eyeshadow"]
    from vto_core.photo.photo_reader import load_reference

    session = EncoderSession(str(installed / "models" / "eyeshadow_encoder.onnx"))
    estimate = session.predict(load_reference(str(tmp_path / "hair_eye.png")))[0]
    eyeshadow = get_spec("eyeshadow")
    for name in session.spec.modelled:
        written = report["written_eyeshadow"][eyeshadow.by_name[name].socket]
        assert written == pytest.approx(estimate[name], rel=1e-4, abs=1e-4), name
    assert report["batch"] == 0
    batch = json.loads((tmp_path / "hair_photos_out" / "report.json").read_text())
    assert [p["name"] for p in json.loads((tmp_path / "hair_photos_out" / "presets.json").read_text())["presets"]] \
        == ["red"]
    assert batch["estimated"] == 2 and len(batch["skipped"]) == 1 and "broken_1.png" in json.dumps(batch["skipped"])
    assert (tmp_path / "hair_photos_out" / "assets.blend").is_file()


def bpy_versions_tested() -> dict[str, tuple[int, ...]]:
    """The bpy versions the tests run: pyproject's pin, the Makefile's BPY5_VERSION, test_blender5.sh's default."""
    pins = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["dependencies"]
    found = {
        "pyproject.toml": next(d.split("==")[1] for d in pins if d.startswith("bpy==")),
        "Makefile": re.search(r"^BPY5_VERSION \?= *(\S+)", (ROOT / "Makefile").read_text(), re.M)[1],
        "scripts/test_blender5.sh": re.search(r"BPY52_VERSION:-([\d.]+)\}",
                                              (ROOT / "scripts" / "test_blender5.sh").read_text())[1],
    }
    return {where: tuple(int(v) for v in version.split(".")) for where, version in found.items()}


def test_manifest_admits_every_tested_bpy():
    """The manifest's Blender range takes in every bpy the tests run, by Blender's own install check."""
    ext = load_blender_ext()
    manifest = tomllib.loads((ROOT / "blender_addon" / "blender_manifest.toml").read_text())
    item = {key: manifest[key] for key in ("blender_version_min", "blender_version_max")}
    versions = bpy_versions_tested()
    for where, version in versions.items():
        refused = []
        # The same check Blender's Install from Disk makes; (0, 0, 0) leaves Python out, no platforms leaves it out.
        ext.repository_filter_skip(item=item, filter_blender_version=version, filter_python_version=(0, 0, 0),
                                   filter_platform="linux-x64", skip_message_fn=refused.append,
                                   error_fn=refused.append)
        assert not refused, f"bpy {'.'.join(map(str, version))} ({where}) would not install the zip: {refused}"
