"""The products (lipstick, hair, eye shadow): each declared once, without bpy; code asks the declaration, not the name.

A product is one frozen `Product`: its parameter spec, whether it is a material's node group or a compositor stage, the
region it reads in a photo, what a photo fixes, its fit policy (the qualities, what each costs, which are offered),
its visibility look and its training views. Its Blender side (how it renders, its sources, its node group, its try-on)
is one object in the add-on's renderers room, named here by `blender_module` (blender_addon.renderers.products).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType

from .errors import VtoError
from .hair import PHOTO_HAIR
from .specs import RendererSpec, eyeshadow_spec, hair_spec, lipstick_spec

QUALITIES = ("FAST", "BETTER", "BEST")  # the panel's choice: the encoder (with its colour fit, where it pays), or a fit
MATERIAL, COMPOSITOR = "MATERIAL", "COMPOSITOR"  # where a product's renderer lives: a material's node group, or a stage


def frozen(mapping: Mapping | None = None) -> Mapping:
    """A read-only copy of `mapping` (a declaration's tables cannot be changed by the code that reads them)."""
    return MappingProxyType(dict(mapping or {}))


@dataclass(frozen=True)
class FaceRegion:
    """A region of the 468-point face mesh, given by its loops (each a closed polygon of landmark indices, outer
    first); holes (the mouth between the lips) are the loops after the first."""

    name: str  # what the panel and the notes call it: "lips"
    loops: tuple[tuple[int, ...], ...]
    frame_share: float  # the share of its square's width it spans where the default scene frames it (what encoders see)
    min_width: float = 0.0  # px across (its outer loop's width along the face) under which a photo's is too small to read
    opening: tuple[int, ...] = ()  # a loop that must show what it frames (the eye) for the region to be seen; () none
    skin: tuple[int, ...] = ()  # a loop of bare skin beside it (the cheek under the eye) the opening is judged against
    mirrored: bool = False  # read flipped left to right: the default scene shows its mirror image (the other eye)


@dataclass(frozen=True)
class FitPolicy:
    """How a photo of the product is fitted: Fast, Better and Best, what each costs and which the panel offers."""

    renders: Mapping[str, tuple[int, int]]  # BETTER / BEST -> (default-scene sources, renders in all)
    seconds: Mapping[str, tuple[float, float]]  # quality -> (seconds, seconds the first time in a session), 2-core CPU
    offered: tuple[str, ...]  # the qualities the panel offers: those that beat the one below them
    not_offered: str = ""  # what the panel says of a quality it leaves out
    prior_weight: float = 8.0  # CIELAB units a unit of distance from the fit's start costs
    fast_fits: bool = False  # whether Fast fits the colour imitator after the encoder
    fast_polish: int = 0  # stage passes that polish Fast's colour fit (where fast_fits)

    @property
    def polish_passes(self) -> int:
        """The passes Fast's polish takes (none where Fast does not fit)."""
        return self.fast_polish if self.fast_fits else 0


@dataclass(frozen=True)
class Product:
    """One product: everything above the renderers asks this, never the product's name."""

    name: str  # the command-line and ONNX-metadata name: "lipstick"
    label: str  # the panel's: "Lipstick"
    spec: RendererSpec
    stage: str  # MATERIAL (a shader node group in a material) or COMPOSITOR (a compositor stage of the scene)
    region: str  # what a photo shows of it, as the panel and the notes say: "lips", "hair"
    face_region: FaceRegion | None  # where the face mesh has it; None: found by its own locator (the hair)
    fit: FitPolicy
    target: str  # the Match operator's target id: "MATERIAL" (kept from before there were several material products)
    group_text: str  # how the panel names its group: "'VTO Lipstick' group"
    blender_module: str  # its Blender side: a module of blender_addon.renderers (".product_lipstick"), or an absolute one
    photo_fixes: Mapping[str, float] = field(default_factory=frozen)  # what a match sets, whatever the photo shows
    photo_is_own_source: bool = False  # a photo with '<name>_mask' beside it is its own source (histogram matching)
    fits_in_photo_scene: bool = False  # Better and Best fit a face's photo in its own scene (photo_scene_fit)
    lightings: bool = False  # its default scene takes --lighting (wide or portrait)
    user_scenes: bool = False  # `vto dataset --blend` renders an artist's scene that uses its group
    photo_datasets: bool = False  # `vto dataset --photos` tries its looks on portraits
    masks: bool = False  # `vto dataset --masks` writes its default scene's region mask (others always do, or none)
    shared_sources: bool = False  # `--looks-per-source`: consecutive looks may share one default-scene source render
    renders_source: bool = True  # the source image X is a render of its own (opacity 0); else it comes with the look
    look: Mapping[str, float] = field(default_factory=frozen)  # the visibility look's base values
    below_bar: Mapping[str, tuple[float, str]] = field(default_factory=frozen)  # modelled, under the bar: ratio, why
    layer_looks: bool = False  # a visibility look adds the layer an input acts on (flakes, a coat)
    mouth_views: bool = False  # its encoder may train on open mouths with teeth painted over the region
    tryon: bool = False  # it can be tried on a photo (`vto tryon`, Preview on Photo, batch's sheet)
    asset_library: bool = False  # `vto batch` writes its presets as materials of an asset library
    no_library: str = ""  # why it has none
    presets: str = ""  # its expert presets file; "": vto_core/presets/<name>.json
    smoke_params: tuple[str, ...] = ()  # what `vto demo --size smoke` models: what a tiny encoder learns in a minute
    other_regions: tuple[FaceRegion, ...] = ()  # the face's other places wearing it (the left eye): read too, averaged

    @property
    def face_regions(self) -> tuple[FaceRegion, ...]:
        """Every face-mesh region a face wears it on, its face_region first; () for a product found otherwise."""
        return () if self.face_region is None else (self.face_region, *self.other_regions)

    @property
    def target_item(self) -> tuple[str, str, str]:
        """The Match operator's target (id, name, tooltip)."""
        if self.is_material:
            return self.target, f"{self.label} Material", f"The {self.group_text} of a material"
        return self.target, f"{self.label} Compositor", f"The {self.group_text} of the scene's compositor"

    @property
    def is_material(self) -> bool:
        """Whether its renderer is a shader node group inside a material (else a compositor stage)."""
        return self.stage == MATERIAL

    def photo_values(self, values: Mapping[str, float]) -> dict[str, float]:
        """`values` with what a photo fixes (photo_fixes) set."""
        return {**values, **self.photo_fixes}

    def written(self, spec: RendererSpec | None = None) -> list[str]:
        """The parameters a match with `spec` (default: the product's) writes: the modelled ones, then what a photo
        fixes."""
        modelled = (spec or self.spec).modelled
        return list(modelled) + [name for name in self.photo_fixes if name not in modelled]


LIPS = FaceRegion("lips", (
    # The canonical MediaPipe FACEMESH_LIPS loops (face_landmarks_to_render_data_calculator.cc): outer, then inner.
    (61, 146, 91, 181, 84, 17, 314, 405, 321, 375, 291, 409, 270, 269, 267, 0, 37, 39, 40, 185),
    (78, 95, 88, 178, 87, 14, 317, 402, 318, 324, 308, 415, 310, 311, 312, 13, 82, 81, 80, 191),
    # The default lips scene frames the lips in a square whose width they span this share of (scene_lips.lips_mask over
    # sources 0-7 at 64 px: 0.73-0.84). A lips mask is framed alike, so the encoder sees lips at the scale it was
    # trained on: the mask's own box, stretched to a square, gave 1.7-2.5x the colour error (results/mask_crop.md).
), 0.78)

# Seconds are measured on a 2-core CPU (benchmarks/results/photo_sources.md and real_window.md, rounded up). Lips:
# Better and Best fit in the photo's own scene (photo_scene_fit: 25 renders at 64 px, 100 at 96 px); lipstick renders
# cost ~0.15 s at 64 px. Better (1.1 dB over Fast on the held-out faces' round trip) is offered; Best gains 0.9, no
# more than Better, so it stays on `vto match --quality best`. Fast does not fit the colour imitator: that fit moves the
# estimate until the default scene shows the photo's colour, light and skin included, and loses to the encoder alone on
# renders with the source hidden (-5.3 dB; benchmarks/results/light.md).
LIPSTICK = Product(
    "lipstick", "Lipstick", lipstick_spec(), MATERIAL, "lips", LIPS,
    FitPolicy(renders=frozen({"BETTER": (1, 25), "BEST": (2, 100)}),
              seconds=frozen({"BETTER": (3, 11), "BEST": (12, 18)}),
              offered=("FAST", "BETTER"), not_offered="Best: no closer than Better for lips", prior_weight=8.0),
    "MATERIAL", "'VTO Lipstick' group", ".product_lipstick", fits_in_photo_scene=True, lightings=True, user_scenes=True,
    photo_datasets=True, masks=True,
    look=frozen({"opacity": 1.0}), layer_looks=True, mouth_views=True, tryon=True, asset_library=True,
    smoke_params=("opacity", "red", "green", "blue"))

# Hair's statistics depend on the swatch alone (the stage matches the hair's histogram to it), not on a scene: a weaker
# pull lets the fit go further, and Fast's colour fit gains (+9.7 dB, hair_encoder.md), its mean colour then polished
# on 3 passes of the real stage (the imitator is a few CIELAB units off where some fits settle). The stage costs ~10 ms
# a source; its fit regions are shipped renders. Fast: 0.38-0.42 s a click in the real window, 1.3 s once after an undo.
HAIR = Product(
    "hair", "Hair", hair_spec(), COMPOSITOR, "hair", None,
    FitPolicy(renders=frozen({"BETTER": (2, 100), "BEST": (4, 400)}),
              seconds=frozen({"FAST": (0.3, 1), "BETTER": (2, 6), "BEST": (6, 10)}),
              offered=QUALITIES, prior_weight=2.0, fast_fits=True, fast_polish=3),
    "HAIR", "VTO hair groups", ".product_hair", photo_fixes=frozen(PHOTO_HAIR), photo_is_own_source=True,
    shared_sources=True, renders_source=False,
    no_library=("hair is a two-pass compositor stage fitted to each photo's own hair, not a material: its products are "
                "in the presets (vto render hair --params preset:NAME@presets.json)"),
    smoke_params=("brightness", "hue", "saturation", "intensity"))

# One eye's lid: the lid margin (outer corner to inner), up its inner side through MediaPipe's two rings between, the
# brow's lower edge (inner to outer) and down its outer side (DESIGN.md "Eye shadow"; a simple polygon on the portraits
# of data/faces). A region is one outer polygon, so each eye is its own: EYELIDS, the product's, is the subject's right
# eye (the photo's left), as the default eye scene shows it; the left eye is read flipped, as a right eye.
RIGHT_EYELID_LOOP = (33, 246, 161, 160, 159, 158, 157, 173, 133, 190, 189, 65, 52, 53, 46, 124, 35, 113, 247)
LEFT_EYELID_LOOP = (263, 466, 388, 387, 386, 385, 384, 398, 362, 414, 413, 295, 282, 283, 276, 353, 265, 342, 467)
# The eye openings (the lid margins, upper then lower): where a seen eye shows its white and iris; and the cheek under
# each eye, the bare skin its white is told from.
RIGHT_EYE_OPENING = (33, 246, 161, 160, 159, 158, 157, 173, 133, 155, 154, 153, 145, 144, 163, 7)
LEFT_EYE_OPENING = (263, 466, 388, 387, 386, 385, 384, 398, 362, 382, 381, 380, 374, 373, 390, 249)
RIGHT_CHEEK, LEFT_CHEEK = (117, 118, 101, 36, 205, 187, 123), (346, 347, 330, 266, 425, 411, 352)
# The default eye scene frames the lid in a square whose width it spans this share of (scene_eyes.eyelid_mask over
# sources 0-7 at 64 px: 0.78-0.88, mean 0.82), centred on the lid's box, as the lips are framed.
EYELID_FRAME_SHARE = 0.82
# A lid narrower than this is too small to read: the encoder would see it sampled up more than 4x (the portraits of
# benchmarks/photos and the held-out faces show lids 32-141 px across).
MIN_EYELID_WIDTH = 16
EYELIDS = FaceRegion("eyelids", (RIGHT_EYELID_LOOP,), EYELID_FRAME_SHARE, MIN_EYELID_WIDTH, RIGHT_EYE_OPENING,
                     RIGHT_CHEEK)
LEFT_EYELID = FaceRegion("eyelids", (LEFT_EYELID_LOOP,), EYELID_FRAME_SHARE, MIN_EYELID_WIDTH, LEFT_EYE_OPENING,
                         LEFT_CHEEK, mirrored=True)

# Eye shadow renders like the lipstick (a material's group over the lid's own shader, Cycles). A portrait is read at
# both eyes' lids (each framed as the default eye scene frames one, the left flipped), the estimate their mean. Better
# and Best fit the right lid in the photo's own scene (photo_scene_fit: 25 renders at 64 px, 100 at 96 px); on 13
# held-out faces x 16 products tried on (benchmarks/results/eyeshadow_photos.md) Better reads 0.46 CIEDE2000 closer
# than Fast; Best, on two faces, alike Better (median 2.51 against 2.44, mean 3.05 both), and on real made-up lids
# closer (4.22 against 4.67): both are offered. Seconds: Better 1.3 a photo there and 13 in the real window, Best 18
# there and 55 in the real window (a benchmark running beside it).
EYESHADOW = Product(
    "eyeshadow", "Eye Shadow", eyeshadow_spec(), MATERIAL, "eyelids", EYELIDS,
    FitPolicy(renders=frozen({"BETTER": (1, 25), "BEST": (2, 100)}),
              seconds=frozen({"BETTER": (2, 13), "BEST": (18, 55)}),
              offered=QUALITIES, prior_weight=8.0),
    "EYESHADOW", "'VTO Eye Shadow' group", ".product_eyeshadow", fits_in_photo_scene=True, lightings=True, masks=True,
    photo_datasets=True, look=frozen({"opacity": 1.0}), layer_looks=True, tryon=True, asset_library=True,
    smoke_params=("opacity", "red", "green", "blue"), other_regions=(LEFT_EYELID,))

PRODUCTS: dict[str, Product] = {product.name: product for product in (LIPSTICK, HAIR, EYESHADOW)}


def product_names() -> list[str]:
    """The declared products' names, in declaration order (every command's choices)."""
    return list(PRODUCTS)


def get_product(name: str) -> Product:
    """The declaration of `name`; an unknown name is one line that lists the products."""
    try:
        return PRODUCTS[name]
    except (KeyError, TypeError):
        raise VtoError(f"unknown product '{name}'; choose from {', '.join(PRODUCTS)}") from None


def product_of_region(region: FaceRegion) -> Product:
    """The product worn on face region `region` (its face_region or one of its other_regions)."""
    return next(p for p in PRODUCTS.values() if region in p.face_regions)


def product_of_target(target: str) -> Product:
    """The product the Match operator's `target` id names."""
    return next(p for p in PRODUCTS.values() if p.target == target)


def get_spec(renderer: str, params: str | list[str] | None = None) -> RendererSpec:
    """The built-in spec of product `renderer`, optionally with only `params` modelled."""
    try:
        spec = PRODUCTS[renderer].spec
    except (KeyError, TypeError):
        raise VtoError(f"unknown renderer '{renderer}'; choose from {', '.join(PRODUCTS)}") from None
    return spec.select(params) if params else spec


def declare(product: Product) -> Product:
    """Add `product` to the registry (a product declared outside this module, e.g. a plug-in's); returns it."""
    if product.name in PRODUCTS and PRODUCTS[product.name] is not product:
        raise VtoError(f"a product '{product.name}' is already declared")
    PRODUCTS[product.name] = product
    return product
