"""Render API of a product on a photo: the product's group rendered onto a real portrait's face regions (the lips; each
eye's lid), the paper's AR renderer, as a photo source.

The regions are found as Match finds them (vto_core.photo.photo_reader, on the shipped face models) and framed as Match
frames them (vto_core.photo.framing.region_view). Cycles renders the product's photo scene (scene_photo, its layer
declared by its Blender side) in that frame, bare and wearing the product, under the light read from the photo's skin;
the photo times their ratio, inside the region's soft mask, is the try-on (vto_core.photo.tryon.composite). Every pixel
outside the soft masks is the photo's.

Shapes: images (H, W, 3) display sRGB in [0, 1]; frames n x n.
"""

from __future__ import annotations

from dataclasses import dataclass

import bpy
import numpy as np

from vto_core.appearance import skin_colour
from vto_core.colour import linear_to_srgb, srgb_to_linear
from vto_core.dataset import DEFAULT_SAMPLES
from vto_core.errors import VtoError
from vto_core.photo.face_reader import apply_matrix, clean_photo, polygon_mask, sample_bilinear
from vto_core.photo.face_regions import region_mask, region_width
from vto_core.photo.framing import region_view, square_view, view_box, view_cut
from vto_core.photo.photo_light import light_of
from vto_core.photo.photo_reader import by_lips_locator
from vto_core.photo.tryon import composite, feathered, worn_over_bare
from vto_core.products import LIPS, LIPSTICK, FaceRegion, Product, get_product, get_spec

from ..shipped import photo_reader
from .cycles import configure_cycles, render_passes
from .node_utils import set_group_values
from .scene_photo import PhotoLayer, build_photo_scene, set_light_and_region, set_region

MAX_RENDER = 160  # px: the frame is rendered at most this large; the ratio is smooth and sampled up to the photo
EDGE = 3  # px around a region's box: more than the soft mask reaches (vto_core.photo.tryon.feathered)


def photo_layer(product: Product | str) -> PhotoLayer:
    """The photo scene's layer of `product` (its Blender side's photo_layer); VtoError for a product without one."""
    from .sides import blender_side

    product = get_product(product) if isinstance(product, str) else product
    layer = getattr(blender_side(product), "photo_layer", None)
    if layer is None or not product.kind.tryon:
        raise VtoError(f"{product.name} has no try-on on a photo")
    return layer


def find_regions(photo: np.ndarray, product: Product) -> list[tuple[FaceRegion, object]]:
    """Each face region of `product` the largest face of (H, W, 3) shows wide enough to render onto: [(region,
    vto_core.photo.lips_locator.RegionFound), ...], its face_region first; VtoError 'no face found ...' where there is
    none. Where the first region is one the lips locator reads (by_lips_locator), any reason it finds none (no face,
    not a close-up, lips covering no pixel) is 'no face found ...' here; another region's is raised as it is, unless
    it says 'no face'."""
    try:
        found, _ = photo_reader().locate_regions(product, photo)
    except VtoError as exc:
        first = product.face_region
        if not (first is not None and by_lips_locator(first)) and "no face" not in str(exc):
            raise
        found = []
    checked, problem = [], None
    for region, where in found:
        try:
            checked.append((region, to_render(where, region, photo_layer(product))))
        except VtoError as exc:
            problem = problem or exc
    if not checked:
        raise problem or VtoError(f"no face found: the {product.label.lower()} is tried on the {product.region} of a "
                                  "face; choose a portrait")
    return checked


def to_render(found, region: FaceRegion, layer: PhotoLayer):
    """`found` (vto_core.photo.lips_locator.RegionFound, or None) where it is a face's region wide enough to render
    onto; VtoError 'no face found ...' where not."""
    if found is None or found.how != "face":
        raise VtoError(f"no face found: the {layer.product} is tried on the {region.name} of a face; choose a portrait")
    width = region_width(found.landmarks, region)
    if width < layer.min_width:
        raise VtoError(f"no face found with {region.name} wide enough to try on: the {region.name} are {width:.0f} px "
                       f"wide, at least {layer.min_width:.0f} are needed; choose a larger photo or a closer portrait")
    return found


def find_lips(photo: np.ndarray, product: Product | str):
    """The lips of the largest face of (H, W, 3) (vto_core.photo.lips_locator.RegionFound) to try `product` (one worn
    on the lips: LIPSTICK) on; VtoError 'no face found ...' where there is no face, or its lips are too small to
    render `product` onto."""
    try:
        lips = photo_reader().locate_lips(photo)
    except VtoError:
        lips = None
    return to_render(lips, LIPS, photo_layer(product))


@dataclass
class PhotoRegion:
    """A portrait's face region ready to render onto: found, framed as Match frames it at n x n px, its light read."""

    photo: np.ndarray  # (H, W, 3) display
    found: object  # vto_core.photo.lips_locator.RegionFound: the region found (the lips, a lid)
    cast: np.ndarray  # (3,) the photo's light colour, linear gains of mean 1
    n: int
    to_frame: np.ndarray  # (2, 3) photo px -> frame px
    points: np.ndarray  # (468, 2) the face mesh in frame px
    depth: np.ndarray | None  # (468,) in frame px, nearer lower
    frame: np.ndarray  # (n, n, 3) display: what the frame sees of the photo
    mask: np.ndarray  # (n, n) the region in the frame
    region: FaceRegion  # the region `found` is
    layer: PhotoLayer  # the product's layer


def photo_region(photo: np.ndarray, found, region: FaceRegion, layer: PhotoLayer, n: int | None = None,
                 light=None) -> PhotoRegion:
    """A found face region (RegionFound, checked by to_render) of the photo (H, W, 3) display framed at n x n px (None:
    the frame's own size, at most 2 x MAX_RENDER), the photo's light read beside the lips (`light`: read already)."""
    view, size, _ = region_view(found, region)
    n = n or min(size, MAX_RENDER * 2)
    view = view.copy()
    view[:, :2] *= size / n  # the same frame seen at n x n
    to_frame = np.linalg.inv(np.vstack([view, [0.0, 0.0, 1.0]]))[:2]
    points = apply_matrix(to_frame, found.landmarks.astype(np.float64))
    photo_scale = np.sqrt(abs(np.linalg.det(view[:, :2])))  # photo px per frame px
    depth = None if found.depth is None else found.depth / photo_scale
    mask, _ = region_mask([points[list(loop)] for loop in region.loops], n, n)
    if light is None:
        light = light_of(photo, photo_reader().light_mask((region, found), found.mask))
    return PhotoRegion(photo, found, light.cast, n, to_frame, points, depth, view_cut(photo, view, n), mask, region,
                       layer)


def photo_lips(photo: np.ndarray, product: Product | str, n: int | None = None, lips=None) -> PhotoRegion:
    """The lips of the largest face of (H, W, 3) display (or `lips`, found in it before), framed at n x n px (None:
    the frame's own size, at most 2 x MAX_RENDER) to try `product` (one worn on the lips: LIPSTICK) on. VtoError 'no
    face found ...' (find_lips, to_render)."""
    photo = clean_photo(photo)  # no copy of a clean photo (a 64-megapixel one is 778 MB)
    layer = photo_layer(product)
    lips = find_lips(photo, product) if lips is None else to_render(lips, LIPS, layer)
    return photo_region(photo, lips, LIPS, layer, n)


def photo_regions(photo: np.ndarray, product: Product, n: int | None = None) -> list[PhotoRegion]:
    """Every face region of `product` on the largest face of (H, W, 3) display (find_regions), each framed at n x n
    px (None: its own size), one light read for all."""
    photo = clean_photo(photo)
    layer = photo_layer(product)
    found = find_regions(photo, product)
    light = light_of(photo, photo_reader().light_mask(found[0], found[0][1].mask))
    return [photo_region(photo, where, region, layer, n, light) for region, where in found]


def set_photo_region(target: PhotoRegion, samples: int, seed: int) -> bpy.types.Scene:
    """The layer's photo scene set to `target`'s region, light and colour, rendering render_size(target) px."""
    res = render_size(target)
    scale = res / target.n
    layer = target.layer
    scene = build_photo_scene(layer)
    vertices, quads, uvs = layer.mesh(target.points * scale, None if target.depth is None else target.depth * scale,
                                      target.region)
    set_region(scene, layer, vertices, quads, uvs, res)
    inside = target.mask > 0.5
    albedo = (srgb_to_linear(target.frame[inside]).mean(axis=0) / target.cast if inside.any() else np.full(3, 0.2))
    skin = skin_colour(target.frame, target.mask)
    set_light_and_region(scene, layer, target.cast, albedo, (albedo if skin is None else skin) / target.cast)
    configure_cycles(scene, res, samples, seed)
    return scene


def render_size(target: PhotoRegion) -> int:
    """px a side of the render of `target`'s frame: its n, at most MAX_RENDER."""
    return min(target.n, MAX_RENDER)


def render_look(scene: bpy.types.Scene, values: dict[str, float], layer: PhotoLayer) -> np.ndarray:
    """The layer's photo scene (set_photo_region) wearing `values`: (res, res, 3) linear."""
    set_group_values(scene, get_spec(layer.product), layer.group_name, values)
    return render_passes(scene)["Combined"][..., :3]


def product_ratio(target: PhotoRegion, values: dict[str, float], samples: int, seed: int,
                  bare: np.ndarray | None = None, bare_seed: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """What the product does to `target`'s region: (worn / bare (n, n, 3) linear, the bare render (res, res, 3)). The
    frame is rendered at render_size px, the smooth ratio sampled up to n; `bare`: a bare render of this target kept
    from before (None: rendered now, with `bare_seed`, or None: `seed`)."""
    scene = set_photo_region(target, samples, seed if bare_seed is None else bare_seed)
    if bare is None:
        bare = render_look(scene, get_product(target.layer.product).bare(values), target.layer)
    scene.cycles.seed = seed
    ratio = worn_over_bare(bare, render_look(scene, values, target.layer))
    res, size = ratio.shape[0], target.n
    if res == size:
        return ratio, bare
    centres = (np.arange(size) + 0.5) * res / size
    u, v = np.meshgrid(centres, centres)
    return sample_bilinear(ratio, u, v).transpose(1, 2, 0), bare


def tryon_product(product: Product | str, photo: np.ndarray, values: dict[str, float], crop: int | None = None,
                  samples: int = DEFAULT_SAMPLES, seed: int = 0, in_place: bool = False) -> np.ndarray:
    """R(X, g) on a real photo: (H, W, 3) display wearing `product`'s `values` on each of its face regions, or, with
    `crop` = n, its first region framed as Match frames it at n x n px. VtoError for a photo without a face, or
    regions too small. in_place: a clean float32 photo (in [0, 1], finite) is drawn on itself, not on a copy (a
    64-megapixel photo is 778 MB)."""
    product = get_product(product) if isinstance(product, str) else product
    values = product.spec.check_values(values)
    targets = photo_regions(photo, product, crop)
    if crop:
        target = targets[0]
        ratio, _ = product_ratio(target, values, samples, seed)
        worn = composite(srgb_to_linear(target.frame), ratio, feathered(target.mask), values[product.coverage])
        return np.clip(linear_to_srgb(worn), 0.0, 1.0).astype(np.float32)
    out = targets[0].photo
    for k, target in enumerate(targets):
        ratio, _ = product_ratio(target, values, samples, seed)
        out = on_photo(out, target.found, target.to_frame, ratio, values[product.coverage], in_place or k > 0)
    return out


def tryon_lipstick(photo: np.ndarray, values: dict[str, float], crop: int | None = None,
                   samples: int = DEFAULT_SAMPLES, seed: int = 0, in_place: bool = False) -> np.ndarray:
    """tryon_product of the lipstick: (H, W, 3) display wearing `values`, or with `crop` = n its lips framed at n x n
    px."""
    return tryon_product(LIPSTICK, photo, values, crop, samples, seed, in_place)


def around_region(found, size: int) -> np.ndarray:
    """The view (2, 3) of a size x size square on a found region (the lips; an eye's lid) and around it (2.2 of its
    widths across, upright): what the previews show of a photo."""
    return around([np.asarray(found.outer, np.float64)], size)


def around(loops: list[np.ndarray], size: int) -> np.ndarray:
    """The view (2, 3) of a size x size square upright on the found regions' outer loops [(K, 2), ...] of a photo:
    2.2 widths of the widest across, or 1.25 of all of them together (both eyes, their brows)."""
    points = np.concatenate(loops)
    side = max(2.2 * max(float(np.ptp(loop[:, 0])) for loop in loops), 1.25 * float(np.ptp(points[:, 0])))
    view, side = square_view((points.min(axis=0) + points.max(axis=0)) / 2, side, 0.0)
    view[:, :2] *= side / size
    return view


def region_pixels_mask(found, x0: int, y0: int, width: int, height: int) -> np.ndarray:
    """(height, width) bool: the pixels of the box inside `found`'s outer loop and outside its inner one (if any)."""
    mask = polygon_mask(np.asarray(found.outer), x0, y0, width, height)
    if len(found.inner) >= 3:
        mask &= ~polygon_mask(np.asarray(found.inner), x0, y0, width, height)
    return mask


def on_photo(photo: np.ndarray, found, to_frame: np.ndarray, ratio: np.ndarray, opacity: float,
             in_place: bool = False, window: tuple[int, int, int, int] | None = None) -> np.ndarray:
    """The photo with the frame's product ratio (n, n, 3) applied inside a found region's soft mask (`found`: the
    lips, a lid; to_frame (2, 3): photo pixels to the frame's); every other pixel is the photo's own, unchanged.
    in_place: drawn on `photo` itself. window (x0, y0, x1, y1): only that part of the photo, drawn on a copy of it (it
    holds the region's box and EDGE px around it): a 64-megapixel portrait costs its part, not a whole copy."""
    x, y, w, h = found.box
    height, width = photo.shape[:2]
    x0, y0 = max(0, x - EDGE), max(0, y - EDGE)
    x1, y1 = min(width, x + w + EDGE), min(height, y + h + EDGE)
    mask = region_pixels_mask(found, x0, y0, x1 - x0, y1 - y0)
    xs, ys = np.meshgrid(np.arange(x0, x1) + 0.5, np.arange(y0, y1) + 0.5)
    u = to_frame[0, 0] * xs + to_frame[0, 1] * ys + to_frame[0, 2]
    v = to_frame[1, 0] * xs + to_frame[1, 1] * ys + to_frame[1, 2]
    local = sample_bilinear(ratio, u, v).transpose(1, 2, 0)
    soft = feathered(mask)
    worn = composite(srgb_to_linear(photo[y0:y1, x0:x1]), local, soft, opacity)
    if window is None:
        out, (left, top) = (photo if in_place else photo.copy()), (0, 0)
    else:
        left, top, right, bottom = window
        out = photo[top:bottom, left:right].copy()
    out[y0 - top:y1 - top, x0 - left:x1 - left][soft > 0] = np.clip(linear_to_srgb(worn), 0.0, 1.0)[soft > 0]
    return out


def tryon_view(photo: np.ndarray, values: dict[str, float], size: int, samples: int, seed: int,
               product: Product | str) -> tuple[np.ndarray, np.ndarray]:
    """What the previews show of `product` tried on a portrait (H, W, 3): (the photo around its regions, the same
    square wearing `values`), each (size, size, 3), framed by `around` all the regions found (the lips; both eyes):
    tryon_product's try-on, drawn only on the part of the photo the square shows. VtoError 'no face found ...' where it
    has no face, or its regions are too small."""
    product = get_product(product) if isinstance(product, str) else product
    values = product.spec.check_values(values)
    targets = photo_regions(photo, product)
    view = around([np.asarray(t.found.outer, np.float64) for t in targets], size)
    photo = targets[0].photo
    height, width = photo.shape[:2]
    x, y, w, h = view_box(view, size, (height, width))
    boxes = [t.found.box for t in targets]
    # the part of the photo that view_cut reads (a pixel more each way) and on_photo draws on (EDGE around each region)
    x0 = max(0, min([x - 1] + [bx - EDGE for bx, _, _, _ in boxes]))
    y0 = max(0, min([y - 1] + [by - EDGE for _, by, _, _ in boxes]))
    x1 = min(width, max([x + w + 1] + [bx + bw + EDGE for bx, _, bw, _ in boxes]))
    y1 = min(height, max([y + h + 1] + [by + bh + EDGE for _, by, _, bh in boxes]))
    worn = photo[y0:y1, x0:x1].copy()
    for target in targets:
        ratio, _ = product_ratio(target, values, samples, seed)
        shifted_frame = target.to_frame.copy()
        shifted_frame[:, 2] += target.to_frame[:, :2] @ np.array([x0, y0], np.float64)
        worn = on_photo(worn, shifted(target.found, -x0, -y0), shifted_frame, ratio, values[product.coverage],
                        in_place=True)
    moved = view.copy()
    moved[:, 2] -= (x0, y0)
    return view_cut(photo, view, size), view_cut(worn, moved, size)


def shifted(found, dx: float, dy: float):
    """A found region (RegionFound) moved by (dx, dy) px: its loops and box (the rest as it was)."""
    import dataclasses

    offset = np.array([dx, dy], np.float32)
    x, y, w, h = found.box
    return dataclasses.replace(found, box=(int(x + dx), int(y + dy), w, h), outer=np.asarray(found.outer) + offset,
                               inner=np.asarray(found.inner) + offset if len(found.inner) else found.inner)
