"""The one rule of imports: vto_core < blender_addon (bpy), training (torch) < pipeline; no import circles."""

import ast
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("vto_core", "blender_addon", "training", "pipeline")
# package -> what it may never import, at module level or inside a function
FORBIDDEN = {
    "vto_core": {"bpy", "mathutils", "torch", "blender_addon", "training", "pipeline"},
    "blender_addon": {"torch", "training", "pipeline"},
    "training": {"bpy", "mathutils", "blender_addon", "pipeline"},
    "pipeline": set(),
}


def imports_of(path: Path, package: str) -> set[str]:
    """Every module `path` imports anywhere in it, relative imports resolved: {'vto_core.errors', 'bpy', ...}."""
    found = set()
    here = f"{package}.{path.stem}" if path.stem != "__init__" else package
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = here.rsplit(".", node.level)[0] if path.stem != "__init__" or node.level > 1 else package
                module = f"{base}.{node.module}" if node.module else base
                # `from . import x` imports the submodule x
                found.update([module] if node.module else [f"{base}.{a.name}" for a in node.names])
            else:
                found.add(node.module)
    return found


def graph(package: str) -> dict[str, set[str]]:
    """module -> the modules of the same package it imports."""
    modules = {p.stem: p for p in (ROOT / package).glob("*.py") if p.stem != "__init__"}
    return {name: {m.split(".")[1] for m in imports_of(path, package)
                   if m.startswith(package + ".") and m.split(".")[1] in modules} - {name}
            for name, path in modules.items()}


@pytest.mark.parametrize("package", PACKAGES)
def test_no_package_imports_a_layer_it_may_not(package):
    bad = {f"{path.name}: {module}" for path in (ROOT / package).glob("*.py")
           for module in imports_of(path, package) if module.split(".")[0] in FORBIDDEN[package]}
    assert not bad, f"{package} imports what it may not: {sorted(bad)}"


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


def test_the_checker_sees_imports_inside_functions_and_relative_ones(tmp_path):
    (tmp_path / "mod.py").write_text("def f():\n    from training.refine import X\n    from .apply import y\n")
    assert imports_of(tmp_path / "mod.py", "blender_addon") == {"training.refine", "blender_addon.apply"}


BLOCKER = """
import importlib.abc, importlib.util, pkgutil, sys
blocked = set(sys.argv[2].split(","))
class Block(importlib.abc.MetaPathFinder):
    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] in blocked:
            raise ImportError(f"blocked: {name}")
sys.meta_path.insert(0, Block())
package = importlib.import_module(sys.argv[1])
for info in pkgutil.iter_modules(package.__path__):
    importlib.import_module(f"{sys.argv[1]}.{info.name}")
print("ok", len(list(pkgutil.iter_modules(package.__path__))))
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
