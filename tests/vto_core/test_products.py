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
from vto_core.products import (COMPOSITOR, EYELIDS, EYESHADOW, HAIR, LEFT_EYELID, LIPSTICK, MATERIAL, PRODUCTS,
                               QUALITIES, get_product, get_spec, product_names, product_of_target)

ROOT = Path(__file__).resolve().parents[2]
# Where a product's name may stand beside ==: the declarations themselves.
DECLARATIONS = {"vto_core/products.py"}
PRODUCT_NAMES = {"lipstick", "hair", "eyeshadow", "eye_shadow"}


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
    assert set(product.below_bar) <= set(product.spec.modelled)
    assert product_of_target(product.target) is product
    assert load_presets(product.name)  # its presets are there
    assert (product.face_region is None) or all(len(loop) >= 3 for loop in product.face_region.loops)


def test_the_two_products_differ_where_they_really_differ():
    assert (LIPSTICK.is_material, HAIR.is_material) == (True, False)
    assert LIPSTICK.face_region.name == "lips" and HAIR.face_region is None
    assert HAIR.photo_is_own_source and not LIPSTICK.photo_is_own_source
    assert HAIR.photo_values({"hue": 0.2, "intensity": 0.3}) == {"hue": 0.2, "intensity": 1.0, "blend": -1.0}
    assert LIPSTICK.photo_values({"red": 9.0}) == {"red": 9.0}
    assert HAIR.written(get_spec("hair", "hue,intensity")) == ["hue", "intensity", "blend"]
    assert (LIPSTICK.fit.polish_passes, HAIR.fit.polish_passes) == (0, 3)
    assert LIPSTICK.fits_in_photo_scene and LIPSTICK.tryon and LIPSTICK.mouth_views and not HAIR.mouth_views
    assert [p.target_item[0] for p in PRODUCTS.values()] == ["MATERIAL", "HAIR", "EYESHADOW"]  # ids kept as before


def test_a_declaration_cannot_be_changed_by_the_code_that_reads_it():
    with pytest.raises(TypeError):
        HAIR.photo_fixes["intensity"] = 0.5
    with pytest.raises(TypeError):
        LIPSTICK.fit.renders["BETTER"] = (1, 1)


def test_an_unknown_product_is_one_line_listing_the_products():
    with pytest.raises(VtoError, match=r"^unknown product 'nail'; choose from lipstick, hair, eyeshadow$"):
        get_product("nail")
    with pytest.raises(VtoError, match="unknown renderer 'nail'; choose from lipstick, hair, eyeshadow"):
        get_spec("nail")
    assert product_names() == ["lipstick", "hair", "eyeshadow"]


@pytest.mark.parametrize("argv", [["spec", "nail"], ["sample", "nail"], ["presets", "nail"]])
def test_every_command_refuses_an_unknown_product_in_one_line(argv):
    err = io.StringIO()
    with contextlib.redirect_stderr(err):
        assert cli.run(argv) == 2
    lines = err.getvalue().strip().splitlines()
    assert len(lines) == 1 and "'nail'" in lines[0] and "lipstick" in lines[0] and "hair" in lines[0], lines


def name_comparisons(source: str) -> list[int]:
    """The lines of `source` that compare a product's name to a string (==, !=, in)."""
    return [node.lineno for node in ast.walk(ast.parse(source)) if isinstance(node, ast.Compare)
            and any(isinstance(side, ast.Constant) and side.value in PRODUCT_NAMES
                    for side in [node.left, *node.comparators])]


def test_no_module_outside_the_declarations_compares_a_products_name():
    found = [f"{path.relative_to(ROOT)}:{line}" for package in ("blender_addon", "vto_core", "training", "pipeline")
             for path in sorted((ROOT / package).rglob("*.py")) if str(path.relative_to(ROOT)) not in DECLARATIONS
             for line in name_comparisons(path.read_text())]
    assert not found, f"compare the product's declaration, not its name: {found}"


def test_the_static_check_sees_a_comparison():
    assert name_comparisons('if renderer == "hair":\n    pass\n') == [1]
    assert name_comparisons('x = "lipstick" != y\n') == [1]
    assert name_comparisons('if product.face_region is None:\n    pass\n') == []


def test_eye_shadow_is_a_material_on_both_eyes_lids():
    assert EYESHADOW.is_material and EYESHADOW.face_region is EYELIDS and EYESHADOW.region == "eyelids"
    assert EYESHADOW.face_regions == (EYELIDS, LEFT_EYELID) and LIPSTICK.face_regions == (LIPSTICK.face_region,)
    assert HAIR.face_regions == () and LEFT_EYELID.mirrored and not EYELIDS.mirrored  # the left eye is read flipped
    assert EYESHADOW.tryon and EYESHADOW.photo_datasets and EYESHADOW.fits_in_photo_scene  # lids in the photo's scene
    assert EYESHADOW.fit.offered == QUALITIES and EYESHADOW.photo_values({"red": 9.0}) == {"red": 9.0}
    assert EYESHADOW.asset_library and not EYESHADOW.no_library  # its presets are materials, as the lipstick's
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
