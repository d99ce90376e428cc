"""The panel's pictures. *Preview on Photo*: the reference photo's lips (eyes) beside the material's current values
tried on them (blender_addon.renderers.tryon), made after Match and on request, never on a slider move. *Find Face on
Mesh*'s front render with its landmarks. Preview images only, so nothing in the .blend changes and undo is untouched."""

from __future__ import annotations

import numpy as np

from vto_core.errors import VtoError, failure_line
from vto_core.products import get_spec

from ..matching.apply import group_nodes, material_product
from ..renderers.node_utils import node_values
from ..renderers.products import blender_side
from .thumbnail import preview_icon, reference_pixels

SIZE = 96  # px: each half of the preview (the photo, the try-on)
SAMPLES = 8  # Cycles samples: a preview, not a dataset
_made: dict[str, tuple[int, str, np.ndarray | None]] = {}  # material name -> (icon id, the note, the picture)
_found: dict[str, tuple[int, np.ndarray]] = {}  # object name -> (icon id, Find Face on Mesh's front render)


def material_values(material) -> tuple[object, dict[str, float]]:
    """(the material's product, its every parameter as the material's first group node holds it (linked inputs at
    defaults)); VtoError where the material uses no product's group or its product has no try-on."""
    product = material_product(material)
    if product is None or not product.kind.tryon:
        raise VtoError(f"material '{material.name}' uses no group that can be tried on a photo (VTO Lipstick)")
    spec = get_spec(product.name)
    return product, spec.full_values(node_values(group_nodes(product, material)[0], spec))


def compose(photo: np.ndarray, product, values: dict[str, float]) -> np.ndarray:
    """(SIZE, 2 SIZE, 3): the photo around its region | the same part wearing `values` (the product's tryon_view:
    drawn on that part only, so a 64-megapixel photo costs no whole copy)."""
    return np.concatenate(blender_side(product).tryon_view(photo, values, SIZE, SAMPLES, 0), axis=1)


def refresh(material, photo: np.ndarray | None = None) -> tuple[int, str]:
    """Make the material's preview now, on `photo` (H, W, 3) or else the panel's reference: (its icon id, '') or (0,
    the one line saying why there is none)."""
    try:
        photo = reference_pixels(material.vto_match) if photo is None else photo
        picture = compose(photo, *material_values(material))
    except Exception as exc:  # VtoError, or a render that failed: the panel says why, Match is not undone
        _made[material.name] = (0, failure_line(exc), None)
        return shown(material)
    # headless, Blender gives preview images icon id 0: the picture is kept for what reads it
    _made[material.name] = (preview_icon(f"tryon:{material.name}", picture), "", picture)
    return shown(material)


def shown(material) -> tuple[int, str]:
    """The material's last preview (icon id, note; the note is '' where the preview was made), or (0, '') before
    the first."""
    return _made.get(material.name, (0, "", None))[:2]


def picture(material) -> np.ndarray | None:
    """The material's last preview as pixels (SIZE, 2 SIZE, 3), or None."""
    return _made.get(material.name, (0, "", None))[2]


def show_found_face(name: str, picture: np.ndarray) -> int:
    """Keep Find Face on Mesh's front render of object `name`, with its landmarks, (H, W, 3) for the panel: its icon
    id (0 headless)."""
    _found[name] = (preview_icon(f"face:{name}", picture), picture)
    return _found[name][0]


def found_face(name: str) -> tuple[int, np.ndarray | None]:
    """The last front render Find Face on Mesh made of object `name`: (icon id, pixels), or (0, None)."""
    return _found.get(name, (0, None))


def unregister() -> None:
    """Forget the previews (their images go with the thumbnail's, thumbnail.unregister)."""
    _made.clear()
    _found.clear()
