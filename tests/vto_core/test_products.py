"""Products declared once (vto_core.products): each declaration is whole and consistent, an unknown name is one line
from every command, no module outside the declarations compares a product's name to a string, and the eye shadow's
lid region and presets are what a palette holds."""

import ast
import contextlib
import io
from pathlib import Path

import pytest

from vto_core import cli
from vto_core.errors import VtoError
from vto_core.presets import load_presets
import dataclasses

from vto_core import products as declarations
from vto_core.products import (COMPOSITOR, COMPOSITOR_STAGE, EYELIDS, EYESHADOW, FACE_LAYER, HAIR, LEFT_EYELID,
                               LIPSTICK, MATERIAL, PRODUCTS, QUALITIES, FaceRegion, Kind, Product, get_product,
                               get_spec, layered_over_bare_skin, product_list, product_names, product_of_target)

ROOT = Path(__file__).resolve().parents[2]
# Where a product's name may stand beside ==: the declarations themselves.
DECLARATIONS = {"vto_core/products.py"}
PRODUCT_NAMES = {*PRODUCTS, "eye_shadow"}
# The declared objects (each product and face region) by the names vto_core.products gives them.
DECLARED = {name for name, value in vars(declarations).items() if isinstance(value, (Product, FaceRegion))}
# A product's own modules in the renderers room: its Blender side and the modules only it uses.
PRODUCT_MODULES = {"product_lipstick", "product_eyeshadow", "product_hair", "nodes_lipstick", "nodes_eyeshadow",
                   "nodes_hair", "scene_lips", "scene_eyes", "scene_hair", "hair"}


@pytest.mark.parametrize("product", PRODUCTS.values(), ids=PRODUCTS)
def test_each_declaration_is_whole_and_consistent(product):
    assert product.spec.renderer == product.name and get_spec(product.name) is product.spec
    assert product.stage in (MATERIAL, COMPOSITOR) and product.is_material == (product.stage == MATERIAL)
    assert set(product.fit.offered) <= set(QUALITIES) and product.fit.offered[0] == "FAST"
    assert set(product.fit.renders) == {"BETTER", "BEST"}
    assert all(0 < sources <= renders for sources, renders in product.fit.renders.values())
    assert set(product.fit.seconds) >= set(product.fit.offered) - {"FAST"}
    assert set(product.photo_fixes) <= set(product.spec.by_name)  # what a photo fixes is a parameter
    assert set(product.look) | set(product.smoke_params) <= set(product.spec.by_name)
    assert product.kind in (FACE_LAYER, COMPOSITOR_STAGE)
    assert (not product.coverage) or product.coverage in product.spec.modelled  # the layer's coverage is modelled
    assert product_of_target(product.target) is product
    assert load_presets(product.name)  # its presets are there
    assert all(len(loop) >= 3 for region in product.face_regions for loop in region.loops)
    assert (product.kind is FACE_LAYER) == bool(product.face_regions) == bool(product.coverage)  # a layer on regions
    assert product.recipe is None or product.recipe.steps > 0 and product.recipe.looks > 0


def test_no_boolean_of_a_product_is_one_products_flag():
    """What the products can do follows from their kind: Product holds no boolean at all, and each of Kind's booleans
    sets the two kinds apart (none is one product's flag in disguise)."""
    booleans = [f.name for f in dataclasses.fields(Product) if f.type in (bool, "bool")]
    assert booleans == [], booleans
    kind_booleans = [f.name for f in dataclasses.fields(Kind) if f.type in (bool, "bool")]
    assert len(kind_booleans) == 11
    for name in kind_booleans:
        assert getattr(FACE_LAYER, name) != getattr(COMPOSITOR_STAGE, name), name
        holders = [p.name for p in PRODUCTS.values() if getattr(p.kind, name)]
        assert holders in (["lipstick", "eyeshadow"], ["hair"]), (name, holders)


def test_the_product_lists_come_from_the_registry():
    assert product_list() == "lipstick, hair or eyeshadow"
    assert product_list(p for p in PRODUCTS.values() if p.kind.tryon) == "lipstick or eyeshadow"
    assert product_list([HAIR]) == "hair"


def test_the_training_recipe_is_the_declarations():
    assert "LOOKS=24000\n" in LIPSTICK.recipe.shell() and "SEED=51\n" in LIPSTICK.recipe.shell()
    assert "VARIED_ARGS='--seed 52 --no-source --vary gloss_roughness'\n" in LIPSTICK.recipe.shell()
    assert (LIPSTICK.recipe.colour, HAIR.recipe.colour, EYESHADOW.recipe.colour) == ("own", "datasets", "none")


def test_a_product_worn_where_another_reads_bare_skin_is_named():
    assert layered_over_bare_skin(EYESHADOW) == [] and layered_over_bare_skin(LIPSTICK) == []
    blush = dataclasses.replace(LIPSTICK, name="blush", label="Blush",
                                face_regions=(FaceRegion("cheeks", ((117, 118, 50, 205, 187, 123),), 0.8),))
    PRODUCTS["blush"] = blush
    try:
        lines = layered_over_bare_skin(EYESHADOW)
    finally:
        del PRODUCTS["blush"]
    assert len(lines) == 1 and "Blush" in lines[0] and "cheek under the right eye" in lines[0], lines
    left = FaceRegion("cheeks", ((346, 347, 330, 266, 425, 411, 352),), 0.8)
    both = dataclasses.replace(blush, face_regions=blush.face_regions + (left,))
    PRODUCTS["blush"] = both
    try:
        (line,) = layered_over_bare_skin(EYESHADOW)  # one line for the product, naming the bare skin under both eyes
    finally:
        del PRODUCTS["blush"]
    assert "cheek under the right eye and cheek under the left eye" in line, line
    assert EYELIDS.bare_skin.overlaps(blush.face_region) and not EYELIDS.overlaps(LIPSTICK.face_region)


def test_the_two_products_differ_where_they_really_differ():
    assert (LIPSTICK.is_material, HAIR.is_material) == (True, False)
    assert LIPSTICK.face_region.name == "lips" and HAIR.face_region is None
    assert HAIR.kind.photo_is_own_source and not LIPSTICK.kind.photo_is_own_source
    assert HAIR.photo_values({"hue": 0.2, "intensity": 0.3}) == {"hue": 0.2, "intensity": 1.0, "blend": -1.0}
    assert LIPSTICK.photo_values({"red": 9.0}) == {"red": 9.0}
    assert HAIR.written(get_spec("hair", "hue,intensity")) == ["hue", "intensity", "blend"]
    assert (LIPSTICK.fit.polish_passes, HAIR.fit.polish_passes) == (0, 3)
    assert LIPSTICK.kind.tryon and not HAIR.kind.tryon and LIPSTICK.mouth_views and not HAIR.mouth_views
    assert not EYESHADOW.mouth_views  # a lid has no hole that opens
    assert [p.target_item[0] for p in PRODUCTS.values()] == ["MATERIAL", "HAIR", "EYESHADOW"]  # ids kept as before


def test_a_declaration_cannot_be_changed_by_the_code_that_reads_it():
    with pytest.raises(TypeError):
        HAIR.photo_fixes["intensity"] = 0.5
    with pytest.raises(TypeError):
        LIPSTICK.fit.renders["BETTER"] = (1, 1)


def test_an_unknown_product_is_one_line_listing_the_products():
    names = ", ".join(PRODUCTS)
    with pytest.raises(VtoError, match=rf"^unknown product 'nail'; choose from {names}$"):
        get_product("nail")
    with pytest.raises(VtoError, match=f"unknown renderer 'nail'; choose from {names}"):
        get_spec("nail")
    assert product_names() == list(PRODUCTS) == [p.name for p in (LIPSTICK, HAIR, EYESHADOW)]


@pytest.mark.parametrize("argv", [["spec", "nail"], ["sample", "nail"], ["presets", "nail"]])
def test_every_command_refuses_an_unknown_product_in_one_line(argv):
    err = io.StringIO()
    with contextlib.redirect_stderr(err):
        assert cli.run(argv) == 2
    lines = err.getvalue().strip().splitlines()
    assert len(lines) == 1 and "'nail'" in lines[0] and all(name in lines[0] for name in PRODUCTS), lines


def name_comparisons(source: str) -> list[int]:
    """The lines of `source` that compare a product's name to a string (==, !=, in), or a value with a declared
    product or region (`region == LIPS`, `product is not HAIR`)."""
    def named(side) -> bool:
        if isinstance(side, ast.Constant):
            return side.value in PRODUCT_NAMES
        return (side.id if isinstance(side, ast.Name) else getattr(side, "attr", None)) in DECLARED

    return [node.lineno for node in ast.walk(ast.parse(source)) if isinstance(node, ast.Compare)
            and any(named(side) for side in [node.left, *node.comparators])]


def product_module_imports(source: str) -> list[int]:
    """The lines of `source` that import one product's module of the renderers room (PRODUCT_MODULES)."""
    lines = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.ImportFrom) and node.module and "renderers" in node.module.split("."):
            names = {node.module.split(".")[-1]} | {alias.name for alias in node.names}
            lines += [node.lineno] if names & PRODUCT_MODULES else []
        elif isinstance(node, ast.Import):
            lines += [node.lineno for alias in node.names if alias.name.split(".")[-1] in PRODUCT_MODULES]
    return lines


def modules_above_the_renderers():
    """(path, source) of every module outside the declarations and the renderers room."""
    for package in ("blender_addon", "vto_core", "training", "pipeline"):
        for path in sorted((ROOT / package).rglob("*.py")):
            relative = str(path.relative_to(ROOT))
            if relative not in DECLARATIONS and not relative.startswith("blender_addon/renderers/"):
                yield relative, path.read_text()


def test_no_module_outside_the_declarations_compares_a_products_name_or_declaration():
    found = [f"{relative}:{line}" for relative, source in modules_above_the_renderers()
             for line in name_comparisons(source)]
    found += [f"blender_addon/renderers/{path.name}:{line}"
              for path in sorted((ROOT / "blender_addon/renderers").glob("*.py"))
              for line in name_comparisons(path.read_text())]
    assert not found, f"ask the product's declaration, not its name or identity: {found}"


def test_no_module_above_the_renderers_imports_one_products_module():
    found = [f"{relative}:{line}" for relative, source in modules_above_the_renderers()
             for line in product_module_imports(source)]
    assert not found, f"go through the product's Blender side (renderers.products.blender_side): {found}"


def test_the_static_checks_see_a_comparison_and_an_import():
    assert name_comparisons('if renderer == "hair":\n    pass\n') == [1]
    assert name_comparisons('x = "lipstick" != y\n') == [1]
    assert name_comparisons('if region == LIPS:\n    pass\n') == [1]
    assert name_comparisons('ok = product is not products.HAIR\n') == [1]
    assert name_comparisons('if product.face_region is None:\n    pass\n') == []
    assert product_module_imports('from ..renderers.hair import mask_path_for\n') == [1]
    assert product_module_imports('from blender_addon.renderers import product_lipstick\n') == [1]
    assert product_module_imports('from ..renderers.products import blender_side\n') == []


def test_eye_shadow_is_a_material_on_both_eyes_lids():
    assert EYESHADOW.is_material and EYESHADOW.face_region is EYELIDS and EYESHADOW.region == "eyelids"
    assert EYESHADOW.face_regions == (EYELIDS, LEFT_EYELID) and LIPSTICK.face_regions == (LIPSTICK.face_region,)
    assert HAIR.face_regions == () and LEFT_EYELID.mirrored and not EYELIDS.mirrored  # the left eye is read flipped
    assert EYELIDS.bare_skin.loops == ((117, 118, 101, 36, 205, 187, 123),)  # the cheek under the eye
    assert EYESHADOW.kind is FACE_LAYER and EYESHADOW.kind.fits_in_photo_scene  # the lids fit in the photo's scene
    assert EYESHADOW.fit.offered == QUALITIES and EYESHADOW.photo_values({"red": 9.0}) == {"red": 9.0}
    assert EYESHADOW.kind.asset_library and not EYESHADOW.no_library  # its presets are materials, as the lipstick's
    assert 0.5 < EYELIDS.frame_share < 1.0 and EYELIDS.frame_share == LEFT_EYELID.frame_share
    right, left = EYELIDS.loops[0], LEFT_EYELID.loops[0]
    assert len(EYELIDS.loops) == 1 and len(right) == len(left) == len(set(right)) == 19
    assert right[:9] == (33, 246, 161, 160, 159, 158, 157, 173, 133)  # the lid margin, outer corner to inner
    assert left[:9] == (263, 466, 388, 387, 386, 385, 384, 398, 362)
    assert {65, 52, 53, 46, 124, 35} <= set(right) and {295, 282, 283, 276, 353, 265} <= set(left)  # the brow's edge
    assert EYELIDS.opening[:9] == right[:9] and LEFT_EYELID.opening[:9] == left[:9]  # the opening: margins, upper first
    assert EYELIDS.min_width == LEFT_EYELID.min_width > 0 and LIPSTICK.face_region.opening == ()


EYESHADOW_PRESETS = load_presets("eyeshadow")


def test_eye_shadow_presets_are_real_shades_in_range_with_every_finish():
    import json

    from vto_core.presets import PRESET_DIR

    rows = json.loads((PRESET_DIR / "eyeshadow.json").read_text())["presets"]
    assert len(rows) >= 24 and len({row["name"] for row in rows}) == len(rows)
    assert {row["finish"] for row in rows} == {"matte", "satin", "shimmer", "metallic", "glitter"}
    for name, values in EYESHADOW_PRESETS.items():
        assert EYESHADOW.spec.check_values(values), name  # every value named, in range
        assert not set(values) & {"height", "softness", "shift"}, f"{name}: placement is the artist's, not a shade's"
    dark = [n for n, v in EYESHADOW_PRESETS.items() if max(v["red"], v["green"], v["blue"]) < 60]
    assert len(dark) >= 2  # the smoky blacks: the paper's user study failed on very dark shades
    for row in rows:
        values = row["params"]
        if row["finish"] == "matte":
            assert values["shimmer"] == values["metallic"] == values["sparkle_density"] == 0.0, row["name"]
        if row["finish"] == "glitter":
            assert values["sparkle_density"] >= 0.5, row["name"]
        if row["finish"] == "metallic":
            assert values["metallic"] >= 0.7, row["name"]
