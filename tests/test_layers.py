"""The one rule of imports: vto_core < blender_addon (bpy), training (torch) < pipeline; no import circles; inside a
package, rooms import downward only (blender_addon: ui > matching > datasets > renderers > its top-level helpers)."""

import ast
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("vto_core", "blender_addon", "training", "pipeline")
# package -> its rooms from the top down; a module outside every room sits at the bottom (the shared helpers)
ROOMS = {
    "blender_addon": ("ui", "matching", "datasets", "renderers"),
    "vto_core": ("photo",),
}
# package -> what it may never import, at module level or inside a function
FORBIDDEN = {
    "vto_core": {"bpy", "mathutils", "torch", "blender_addon", "training", "pipeline"},
    "blender_addon": {"torch", "training", "pipeline"},
    "training": {"bpy", "mathutils", "blender_addon", "pipeline"},
    "pipeline": set(),
}


def module_name(path: Path) -> str:
    """The dotted module name of a file under ROOT: blender_addon/ui/panels.py -> 'blender_addon.ui.panels'."""
    parts = path.relative_to(ROOT).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def imports_of(path: Path, here: str) -> set[str]:
    """Every module `path` (the module `here`) imports anywhere in it, relative imports resolved: {'bpy', ...}."""
    found = set()
    package = here if path.stem == "__init__" else here.rpartition(".")[0]
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.rsplit(".", node.level - 1)[0] if node.level > 1 else package
                module = f"{base}.{node.module}" if node.module else base
            else:
                module = node.module
            # `from package import x` may import the submodule x: both are kept, graph() keeps the modules
            found.update([module] + [f"{module}.{a.name}" for a in node.names])
    return found


def modules(package: str) -> dict[str, Path]:
    """Every module of a package, its rooms included: dotted name -> file."""
    return {module_name(p): p for p in sorted((ROOT / package).rglob("*.py"))}


def graph(package: str) -> dict[str, set[str]]:
    """module -> the modules of the same package it imports (packages' __init__ files left out)."""
    found = {name: path for name, path in modules(package).items() if path.stem != "__init__"}
    return {name: {m for m in imports_of(path, name) if m in found} - {name} for name, path in found.items()}


def room_rank(module: str) -> int:
    """0 for the top room of its package, larger further down; the helpers outside every room rank last."""
    package, _, rest = module.partition(".")
    rooms = ROOMS.get(package, ())
    room = rest.split(".")[0]
    return rooms.index(room) if room in rooms and "." in rest else len(rooms)


@pytest.mark.parametrize("package", PACKAGES)
def test_no_package_imports_a_layer_it_may_not(package):
    bad = {f"{name}: {module}" for name, path in modules(package).items()
           for module in imports_of(path, name) if module.split(".")[0] in FORBIDDEN[package]}
    assert not bad, f"{package} imports what it may not: {sorted(bad)}"


@pytest.mark.parametrize("package", sorted(ROOMS))
def test_rooms_import_downward_only(package):
    upward = {f"{name} -> {target}" for name, targets in graph(package).items() for target in targets
              if room_rank(target) < room_rank(name)}
    assert not upward, f"{package}: a lower room imports a higher one: {sorted(upward)}"


def test_each_room_says_its_role_in_one_line():
    for package, rooms in ROOMS.items():
        for room in rooms:
            doc = ast.get_docstring(ast.parse((ROOT / package / room / "__init__.py").read_text()))
            assert doc and "\n" not in doc.strip(), f"{package}/{room}/__init__.py needs a one-line docstring"


def test_blender_addon_keeps_its_top_level_small():
    top = [p.name for p in (ROOT / "blender_addon").iterdir() if p.is_file()]
    assert len(top) <= 8, sorted(top)


@pytest.mark.parametrize("package", PACKAGES)
def test_no_import_circles_inside_a_package(package):
    edges = graph(package)
    state: dict[str, int] = {}

    def visit(node, trail):
        state[node] = 1
        for nxt in sorted(edges[node]):
            if state.get(nxt) == 1:
                raise AssertionError(f"{package}: import circle {' -> '.join(trail + [node, nxt])}")
            if nxt not in state:
                visit(nxt, trail + [node])
        state[node] = 2

    for start in sorted(edges):
        if start not in state:
            visit(start, [])


def test_the_room_rule_sees_an_upward_import():
    assert room_rank("blender_addon.renderers.hair") > room_rank("blender_addon.matching.apply")
    assert room_rank("blender_addon.compat") > room_rank("blender_addon.renderers.cycles")
    assert room_rank("vto_core.colour") > room_rank("vto_core.photo.face_reader")


def test_the_checker_sees_imports_inside_functions_and_relative_ones(tmp_path):
    (tmp_path / "mod.py").write_text("def f():\n    from training.refine import X\n    from ..renderers import hair\n"
                                     "    from .apply import y\n")
    assert imports_of(tmp_path / "mod.py", "blender_addon.matching.mod") >= {
        "training.refine", "blender_addon.renderers.hair", "blender_addon.matching.apply"}


BLOCKER = """
import importlib.abc, importlib.util, pkgutil, sys
blocked = set(sys.argv[2].split(","))
class Block(importlib.abc.MetaPathFinder):
    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] in blocked:
            raise ImportError(f"blocked: {name}")
sys.meta_path.insert(0, Block())
package = importlib.import_module(sys.argv[1])
found = list(pkgutil.walk_packages(package.__path__, sys.argv[1] + "."))
for info in found:
    importlib.import_module(info.name)
print("ok", len(found))
"""


@pytest.mark.parametrize("package", ["vto_core", "training", "blender_addon"])
def test_each_package_imports_with_the_layers_it_may_not_use_blocked(package):
    if package == "blender_addon":
        pytest.importorskip("bpy")
    if package == "training":
        pytest.importorskip("torch")
    done = subprocess.run([sys.executable, "-c", BLOCKER, package, ",".join(sorted(FORBIDDEN[package]))],
                          capture_output=True, text=True, cwd=ROOT)
    assert done.returncode == 0 and done.stdout.startswith("ok"), done.stderr[-800:]
