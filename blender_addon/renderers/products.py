"""Each product's Blender side, one object a product (blender_addon.renderers.product_<name>), found from its
declaration (vto_core.products): code above the renderers asks it, never the product's name."""

from __future__ import annotations

import contextlib
from collections.abc import Callable

import numpy as np

from vto_core.dataset import DEFAULT_SAMPLES
from vto_core.errors import VtoError
from vto_core.products import Product, get_product, get_spec
from vto_core.specs import RendererSpec

from .sides import blender_side  # noqa: F401  (each product's side: its module's RENDERER)

FIT_RES = 64  # px: the default-scene renders photo fits compare statistics on


def is_seed(source) -> bool:
    """Whether a source names a default-scene seed (an int, or digits), not a photo."""
    return isinstance(source, (int, np.integer)) or str(source).isdigit()


def check_lighting(product: Product, lighting: str | None, user_scene: bool = False) -> None:
    """VtoError (one line) where `lighting` is asked of a scene that keeps its own light: the default scene of a product
    without lightings (the hair), or a user's scene."""
    if lighting is not None and (user_scene or not product.kind.lightings):
        from .lighting import ONLY_LIPS

        raise VtoError(ONLY_LIPS)


class ProductRenderer:
    """What the add-on needs of a product in Blender; one subclass a product, its module's RENDERER.

    Regions are (image (H, W, 3), mask (H, W)); values are raw parameter values; sources are default-scene seeds
    (or, where the product's photo is its own source, a photo with its mask beside it).
    """

    product: Product
    fit_sources: tuple[int, ...] = ()  # default-scene seeds the photo fits render on, apart from the benchmarks'

    def check_source(self, source) -> None:
        """A one-line error for a source this product cannot render on."""
        if not is_seed(source):
            raise VtoError(f"{self.product.name} sources are seeds of the default {self.product.region} scene (an "
                           f"integer), got '{source}'")

    def render(self, values: dict[str, float], source, res: int, samples: int, seed: int,
               lighting: str | None = None) -> np.ndarray:
        """R(X, g) on `source`: (res, res, 3) display-sRGB float32."""
        return self.bind(source, res, samples, seed, lighting).render(values)

    def bind(self, source, res: int, samples: int, seed: int, lighting: str | None = None) -> "BoundSource":
        """R(X, .) on one fixed source, its source image and its region mask."""
        raise NotImplementedError

    def region_renderer(self, source: int, res: int, samples: int, tones=None
                        ) -> Callable[[dict[str, float]], tuple[np.ndarray, np.ndarray]]:
        """values -> (render (res, res, 3), its region mask (res, res)) on default-scene `source`."""
        raise NotImplementedError

    def iter_fit_sources(self, region: tuple[np.ndarray, np.ndarray], count: int, res: int, samples: int):
        """The default-scene region renderers a photo fit renders on, `count` of them; a generator (yields 0 while it
        renders what it needs once a session), returns the list."""
        raise NotImplementedError

    def photo_sources(self, folder) -> list:
        """The photos of a user folder that are their own sources (with their masks beside them), sorted; products
        whose kind has photo_is_own_source."""
        raise VtoError(f"{self.product.name} sources are seeds of its default scene, not photos")

    def fit_held(self, spec: RendererSpec, start: dict[str, float]) -> dict[int, float] | None:
        """{position in spec.modelled: unit value} a photo fit holds (what a photo fixes), or None."""
        return None

    def nodes(self, target) -> list:
        """The product's group nodes in `target` (a material, or a scene's compositor); [] when it has none."""
        raise NotImplementedError

    def material(self, name: str, values: dict[str, float] | None = None):
        """A new material `name`: a bare shader -> the product's group (`values` on its inputs) -> the output; material
        products only (the asset library's materials, add_group's)."""
        raise VtoError(f"{self.product.name} is not a material's node group")

    def add_group(self, owner):
        """Add the product's group where it lives: a new material on mesh `owner` (returned), or the stage's groups in
        scene `owner`'s compositor, wired (returned)."""
        raise NotImplementedError

    def where(self, target) -> str:
        """How a message names `target`: "material 'Lips'"."""
        raise NotImplementedError

    def fitted_target(self, target, values: dict[str, float]) -> tuple[Callable[[], None], list[str]]:
        """What writing `values` into `target` needs beyond its group inputs, computed now and written only by the
        callable returned (with notes for the user): nothing for most products."""
        return (lambda: None), []

    def missing_group(self, target) -> str:
        """The one line for a target that holds no group of the product (and how to add one)."""
        raise NotImplementedError

    photo_layer = None  # its layer in the photo scene (blender_addon.renderers.scene_photo.PhotoLayer), with a try-on

    def tryon_view(self, photo: np.ndarray, values: dict[str, float], size: int, samples: int, seed: int):
        """(the photo around the regions, the product tried on them), each (size, size, 3); products with a try-on."""
        from .tryon import tryon_view

        return tryon_view(photo, values, size, samples, seed, self.product)

    def tryon(self, photo: np.ndarray, values: dict[str, float], crop: int | None, samples: int, seed: int
              ) -> np.ndarray:
        """The photo (H, W, 3) wearing `values` (with `crop` = n: the region framed as Match frames it, (n, n, 3));
        `photo` may be changed in place. Products with a try-on."""
        from .tryon import tryon_product

        return tryon_product(self.product, photo, values, crop=crop, samples=samples, seed=seed, in_place=True)

    # The default scene's bare region (the lips, the lid) has one tone freedom across sources besides the skin's: a
    # factor drawn per source, which bare_tone moves. Its finite-difference step and its variance across sources; a
    # prior of 0: the product's scene has none (the render floor's reader of it is left out).
    bare_tone_step: float = 0.0
    bare_tone_prior: float = 0.0

    def default_scene(self):
        """Its default scene (bpy.types.Scene), got or built."""
        raise NotImplementedError

    def bare_tone(self, offset: float):
        """A context: renders inside show the default scene's bare region `offset` further along its tone factor; the
        source must already be applied (a render on it), and its tone comes back after."""
        raise NotImplementedError

    def is_dark(self, values: dict[str, float]) -> bool:
        """A very dark product (the evaluation's 'dark' bucket)."""
        return False

    def dataset_images(self, values: list[dict[str, float]], source: int, res: int, samples: int, cycles_seed: int,
                       options: dict):
        """One dataset sample's renders: (source image or None, [render of each of `values`], {name: extra image});
        options: the DatasetJob's 'lighting', 'scene' (a user scene), 'source_images', 'masks', 'photos' (hair
        sources), 'cache' (a folder where looks sharing a source keep its render, or None)."""
        raise NotImplementedError


@contextlib.contextmanager
def shifted_colour(socket, shift: Callable[[np.ndarray], np.ndarray]):
    """A colour socket's sRGB (3,) moved by `shift` (sRGB (3,) -> sRGB (3,)) inside the block, put back after."""
    from vto_core.colour import linear_to_srgb, srgb_to_linear

    kept = tuple(socket.default_value)
    socket.default_value = (*srgb_to_linear(shift(linear_to_srgb(np.array(kept[:3])))), kept[3])
    try:
        yield
    finally:
        socket.default_value = kept


class BoundSource:
    """R(X, .) on one fixed source X: render(values) -> (res, res, 3); source_image() is X as the imitator sees it;
    mask is the region's mask (res, res); own_photo says whether X is a photo (its own source)."""

    def __init__(self, render: Callable, source_image: Callable, mask: Callable, own_photo: bool = False):
        self.render, self._source_image, self._mask, self.own_photo = render, source_image, mask, own_photo

    def source_image(self) -> np.ndarray:
        return self._source_image()

    @property
    def mask(self) -> np.ndarray:
        return self._mask()


def render(renderer: str, values: dict[str, float], source, res: int = 64, samples: int = DEFAULT_SAMPLES,
           seed: int = 0, lighting: str | None = None):
    """R(X, g) of product `renderer`: (res, res, 3) display-sRGB float32; values are checked strictly.

    lighting: the default scene's, "wide" or "portrait" (None: the default), where the product has lightings (lips);
    the others have only their own.
    """
    values = get_spec(renderer).check_values(values)
    product = get_product(renderer)
    check_lighting(product, lighting)
    return blender_side(product).render(values, source, res, samples, seed, lighting)
