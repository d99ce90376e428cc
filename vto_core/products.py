"""The products (lipstick, hair, eye shadow): each declared once, without bpy; code asks the declaration, not the name.

A product is one frozen `Product` of a `Kind`: a FACE_LAYER (a material's node group layered over the skin of face-mesh
regions: lipstick, eye shadow) or a COMPOSITOR_STAGE (a stage of the scene's compositor: hair). What a kind can do
(datasets on photos, a try-on, an asset library, ...) is the kind's; a product's own fields are its parameter spec, its
regions, its coverage parameter, what a photo fixes, its fit policy (the qualities, what each costs, which are
offered), its visibility look and its training recipe. Its Blender side (how it renders, its sources, its node group,
its try-on) is one object in the add-on's renderers room, named here by `blender_module`
(blender_addon.renderers.products).
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
    bare_skin: "FaceRegion | None" = None  # the region whose bare skin it reads (the cheek under the eye): the opening
    # is judged against it, and the bare lid under a layer is guessed from it (FaceRegion.overlaps: a layer worn there)
    mirrored: bool = False  # read flipped left to right: the default scene shows its mirror image (the other eye)
    hole_opens: bool = False  # its hole opens (the mouth): an encoder may train on open views, teeth painted over it

    @property
    def attribute(self) -> str:
        """The mesh attribute that weighs where a character's skin is this region, 0 to 1 (Find Face on Mesh writes
        it; a makeup layer reads it): "vto_lips", "vto_eyelids"."""
        return "vto_" + self.name.replace(" ", "_")

    def overlaps(self, other: "FaceRegion") -> bool:
        """Whether the two regions' outer loops share a landmark (a layer on one lies on the other's edge or more)."""
        return bool(set(self.loops[0]) & set(other.loops[0]))


@dataclass(frozen=True)
class Kind:
    """A kind of product: where its renderer lives and what the add-on can do with it."""

    name: str  # "face layer"
    stage: str  # MATERIAL (a shader node group in a material) or COMPOSITOR (a compositor stage of the scene)
    fits_in_photo_scene: bool = False  # Better and Best fit a face's photo in its own scene (photo_scene_fit)
    lightings: bool = False  # its default scene takes --lighting (wide or portrait)
    user_scenes: bool = False  # `vto dataset --blend` renders an artist's scene that uses its group
    photo_datasets: bool = False  # `vto dataset --photos` tries its looks on portraits
    masks: bool = False  # `vto dataset --masks` writes its default scene's region mask (others always do, or none)
    layer_looks: bool = False  # a visibility look adds the layer an input acts on (flakes, a coat)
    tryon: bool = False  # it can be tried on a photo (`vto tryon`, Preview on Photo, batch's sheet)
    asset_library: bool = False  # `vto batch` writes its presets as materials of an asset library
    photo_is_own_source: bool = False  # a photo with '<name>_mask' beside it is its own source (histogram matching)
    shared_sources: bool = False  # `--looks-per-source`: consecutive looks may share one default-scene source render
    renders_source: bool = True  # the source image X is a render of its own (coverage 0); else it comes with the look


# A material layer over the skin of face-mesh regions, rendered in Cycles; tried on photos in the photo's own scene.
FACE_LAYER = Kind("face layer", MATERIAL, fits_in_photo_scene=True, lightings=True, user_scenes=True,
                  photo_datasets=True, masks=True, layer_looks=True, tryon=True, asset_library=True)
# A stage of the scene's compositor over a region of the render it finds itself (the hair), matched to the photo's own
# statistics: a photo with its mask is its own source, and the stage's looks share one render of their source.
COMPOSITOR_STAGE = Kind("compositor stage", COMPOSITOR, photo_is_own_source=True, shared_sources=True,
                        renders_source=False)


@dataclass(frozen=True)
class Recipe:
    """How its shipped encoder was made: what scripts/train_encoder.sh runs (`python -m vto_core.products NAME`)."""

    data: str  # the main dataset's folder
    seed: int  # its `vto dataset --seed`
    looks: int  # looks a dataset
    steps: int  # encoder training steps
    workers: int  # render processes
    train_args: str  # `vto train encoder` settings beyond the common ones (--set ...)
    data_args: str = ""  # `vto dataset` options of the main dataset
    varied: str = ""  # a second dataset's folder ("" none), trained on with the first
    varied_args: str = ""  # its `vto dataset` options (its seed among them)
    refine: str = "render:25,photo:fast,photo:better,photo:best"  # `vto eval --refine` after the export
    colour: str = "none"  # the colour imitator's data: "none", "datasets" (the encoder's) or "own" (colour_args')
    colour_args: str = ""  # `vto dataset` options of its own colour data (with "own")
    colour_steps: int = 0

    def shell(self) -> str:
        """The recipe as shell assignments (NAME=VALUE lines, quoted) for scripts/train_encoder.sh."""
        import shlex

        return "".join(f"{name.upper()}={shlex.quote(str(value))}\n" for name, value in vars(self).items())


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
    kind: Kind  # FACE_LAYER or COMPOSITOR_STAGE: what it is and what the add-on can do with it
    region: str  # what a photo shows of it, as the panel and the notes say: "lips", "hair"
    face_regions: tuple[FaceRegion, ...]  # where the face mesh has it, the default scene's first (the others, as the
    # left eye, are read too and averaged); (): found by its own locator (the hair)
    fit: FitPolicy
    target: str  # the Match operator's target id: "MATERIAL" (kept from before there were several material products)
    group_text: str  # how the panel names its group: "'VTO Lipstick' group"
    blender_module: str  # its Blender side: a module of blender_addon.renderers (".product_lipstick"), or an absolute one
    recipe: Recipe | None = None  # how its shipped encoder was made; None: it ships none
    coverage: str = ""  # the parameter that is its coverage of the region (0: the bare skin shows); "": none
    photo_fixes: Mapping[str, float] = field(default_factory=frozen)  # what a match sets, whatever the photo shows
    look: Mapping[str, float] = field(default_factory=frozen)  # the visibility look's base values
    no_library: str = ""  # why it has no asset library, where its kind has none
    presets: str = ""  # its expert presets file (a plug-in's); "": vto_core/presets/<name>.json
    smoke_params: tuple[str, ...] = ()  # what `vto demo --size smoke` models: what a tiny encoder learns in a minute
    buckets: Mapping[str, tuple[str, float]] = field(default_factory=frozen)  # `vto eval`'s groups of its own: label
    # -> (parameter, the value above which a look is in it)

    @property
    def stage(self) -> str:
        """MATERIAL or COMPOSITOR: where its renderer lives (its kind's)."""
        return self.kind.stage

    @property
    def face_region(self) -> FaceRegion | None:
        """The face-mesh region its default scene shows (its first), or None for a product found otherwise."""
        return self.face_regions[0] if self.face_regions else None

    @property
    def mouth_views(self) -> bool:
        """Whether its encoder may train on open views of its regions (a region whose hole opens, the mouth)."""
        return any(region.hole_opens for region in self.face_regions)

    def bare(self, values: Mapping[str, float]) -> dict[str, float]:
        """`values` with its coverage at 0: the bare region (a face layer's source image)."""
        return {**values, self.coverage: 0.0}

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
), 0.78, hole_opens=True)

# Seconds are measured on a 2-core CPU (benchmarks/results/photo_sources.md and real_window.md, rounded up). Lips:
# Better and Best fit in the photo's own scene (photo_scene_fit: 25 renders at 64 px, 100 at 96 px); lipstick renders
# cost ~0.15 s at 64 px. Better (1.1 dB over Fast on the held-out faces' round trip) is offered; Best gains 0.9, no
# more than Better, so it stays on `vto match --quality best`. Fast does not fit the colour imitator: that fit moves the
# estimate until the default scene shows the photo's colour, light and skin included, and loses to the encoder alone on
# renders with the source hidden (-5.3 dB; benchmarks/results/light.md).
# The recipe: the default lips scene under its portrait light, without the source X (the graphics loss does not read
# it), twice: with the coat's Gloss Roughness drawn per look (the presets use 0.05-1) and at its default 0.3, trained on
# as one (held out: each one's last 10 %); a deeper net (a 3x3 convolution and BatchNorm a level) with photo and mouth
# views (benchmarks/results/lighting.md, "network"; presets.md, "roughness"); the colour imitator from 4,000 looks with
# their lips masks.
LIPSTICK = Product(
    "lipstick", "Lipstick", lipstick_spec(), FACE_LAYER, "lips", (LIPS,),
    FitPolicy(renders=frozen({"BETTER": (1, 25), "BEST": (2, 100)}),
              seconds=frozen({"BETTER": (3, 11), "BEST": (12, 18)}),
              offered=("FAST", "BETTER"), not_offered="Best: no closer than Better for lips", prior_weight=8.0),
    "MATERIAL", "'VTO Lipstick' group", ".product_lipstick",
    Recipe("out/data/lip64w", 51, 24000, 30000, 2,
           "--set photo_views=true --set mouth_views=true --set blocks=1 --set batch_norm=true", "--no-source",
           "out/data/lip64r", "--seed 52 --no-source --vary gloss_roughness", colour="own",
           colour_args="--out out/data/lipstats --n 4000 --seed 611 --no-source --masks", colour_steps=6000),
    coverage="opacity", look=frozen({"opacity": 1.0}), smoke_params=("opacity", "red", "green", "blue"),
    buckets=frozen({"high gloss": ("gloss", 2.0)}))  # above the glossy presets' typical amount

# Hair's statistics depend on the swatch alone (the stage matches the hair's histogram to it), not on a scene: a weaker
# pull lets the fit go further, and Fast's colour fit gains (+9.7 dB, hair_encoder.md), its mean colour then polished
# on 3 passes of the real stage (the imitator is a few CIELAB units off where some fits settle). The stage costs ~10 ms
# a source; its fit regions are shipped renders. Fast: 0.38-0.42 s a click in the real window, 1.3 s once after an undo.
# The recipe: regions of the default strands scene (what an artist gives: hair, not a head), 16 looks sharing each
# source render (the stage costs ~7 ms a look, the strands ~1 s), the swatch and shine only (a photo fixes intensity and
# blend), photo views; two datasets of 20,000 looks (1,250 sources each) trained on as one, each rendered by one
# process (two would both render each shared source); the colour imitator from the encoder's own looks.
HAIR = Product(
    "hair", "Hair", hair_spec(), COMPOSITOR_STAGE, "hair", (),
    FitPolicy(renders=frozen({"BETTER": (2, 100), "BEST": (4, 400)}),
              seconds=frozen({"FAST": (0.3, 1), "BETTER": (2, 6), "BEST": (6, 10)}),
              offered=QUALITIES, prior_weight=2.0, fast_fits=True, fast_polish=3),
    "HAIR", "VTO hair groups", ".product_hair",
    Recipe("out/data/hairreg_401", 401, 20000, 12000, 1, "--set photo_views=true --set blocks=1 --set batch_norm=true",
           "--looks-per-source 16", "out/data/hairreg_402", "--seed 402 --looks-per-source 16", colour="datasets",
           colour_steps=8000),
    photo_fixes=frozen(PHOTO_HAIR),
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
UNDER_RIGHT_EYE = FaceRegion("cheek under the right eye", (RIGHT_CHEEK,), 0.0)
UNDER_LEFT_EYE = FaceRegion("cheek under the left eye", (LEFT_CHEEK,), 0.0)
# The default eye scene frames the lid in a square whose width it spans this share of (scene_eyes.eyelid_mask over
# sources 0-7 at 64 px: 0.78-0.88, mean 0.82), centred on the lid's box, as the lips are framed.
EYELID_FRAME_SHARE = 0.82
# A lid narrower than this is too small to read: the encoder would see it sampled up more than 4x (the portraits of
# benchmarks/photos and the held-out faces show lids 32-141 px across).
MIN_EYELID_WIDTH = 16
EYELIDS = FaceRegion("eyelids", (RIGHT_EYELID_LOOP,), EYELID_FRAME_SHARE, MIN_EYELID_WIDTH, RIGHT_EYE_OPENING,
                     UNDER_RIGHT_EYE)
LEFT_EYELID = FaceRegion("eyelids", (LEFT_EYELID_LOOP,), EYELID_FRAME_SHARE, MIN_EYELID_WIDTH, LEFT_EYE_OPENING,
                         UNDER_LEFT_EYE, mirrored=True)

# Eye shadow renders like the lipstick (a material's group over the lid's own shader, Cycles). A portrait is read at
# both eyes' lids (each framed as the default eye scene frames one, the left flipped), the estimate their mean. Better
# and Best fit the right lid in the photo's own scene (photo_scene_fit: 25 renders at 64 px, 100 at 96 px); on 13
# held-out faces x 16 products tried on (benchmarks/results/eyeshadow_photos.md) Better reads 0.46 CIEDE2000 closer
# than Fast; Best, on two faces, alike Better (median 2.51 against 2.44, mean 3.05 both), and on real made-up lids
# closer (4.22 against 4.67): both are offered. Seconds: Better 1.3 a photo there and 13 in the real window, Best 18
# there and 55 in the real window (a benchmark running beside it). The recipe: the default eye scene (portrait light,
# no source) once, the lipstick's network from scratch reading its input box-filtered (input_filter=3, as the lips
# encoder ends), with photo views; Fast does not fit a colour imitator, so none is trained.
EYESHADOW = Product(
    "eyeshadow", "Eye Shadow", eyeshadow_spec(), FACE_LAYER, "eyelids", (EYELIDS, LEFT_EYELID),
    FitPolicy(renders=frozen({"BETTER": (1, 25), "BEST": (2, 100)}),
              seconds=frozen({"BETTER": (2, 13), "BEST": (18, 55)}),
              offered=QUALITIES, prior_weight=8.0),
    "EYESHADOW", "'VTO Eye Shadow' group", ".product_eyeshadow",
    Recipe("out/data/eye64a", 81, 6000, 6000, 1,
           "--set photo_views=true --set blocks=1 --set batch_norm=true --set input_filter=3", "--no-source",
           refine="render:25,photo:fast"),
    coverage="opacity", look=frozen({"opacity": 1.0}), smoke_params=("opacity", "red", "green", "blue"))

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
    """The product worn on face region `region` (one of its face_regions)."""
    return next(p for p in PRODUCTS.values() if region in p.face_regions)


def layered_over_bare_skin(product: Product) -> list[str]:
    """One line for each other declared product worn where `product` reads bare skin (FaceRegion.bare_skin): a layer
    there moves what its fit takes for the bare skin."""
    lines = []
    for other in (other for other in PRODUCTS.values() if other is not product):
        read = [region for region in product.face_regions if region.bare_skin is not None
                and any(region.bare_skin.overlaps(worn) for worn in other.face_regions)]
        if read:
            lines.append(f"{product.label}'s {product.face_region.name} are guessed from the bare "
                         f"{' and '.join(dict.fromkeys(region.bare_skin.name for region in read))}, where "
                         f"{other.label} is worn: {other.label} there moves the guess")
    return lines


def either(words) -> str:
    """Words as a help text lists the alternatives, each once: "lips, hair or eyelids" ("" for none)."""
    words = list(dict.fromkeys(words))
    return ", ".join(words[:-1]) + " or " + words[-1] if len(words) > 1 else "".join(words)


def product_list(products=None) -> str:
    """The declared products' names (or those of `products`) as a help text or an error lists them: "lipstick, hair
    or eyeshadow"."""
    return either(p.name for p in (PRODUCTS.values() if products is None else products))


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


if __name__ == "__main__":  # `python -m vto_core.products NAME`: the product's training recipe as shell assignments
    import sys

    recipe = get_product(sys.argv[1] if len(sys.argv) > 1 else "").recipe
    if recipe is None:
        raise SystemExit(f"{sys.argv[1]} ships no encoder recipe")
    print(recipe.shell(), end="")
