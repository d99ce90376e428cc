"""A face layer's Blender side (vto_core.products.FACE_LAYER: lipstick, eye shadow), shared: its shader node group
over the region's bare shader, its default scene's render API, its material and its dataset images. A face layer's
own modules hold only what differs: the group's layer (nodes_<name>), the default scene (scene_<name>) and a
`FaceLayerRenderer` naming them (product_<name>)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import bpy
import numpy as np

from vto_core.dataset import DEFAULT_SAMPLES
from vto_core.errors import VtoError
from vto_core.specs import RendererSpec

from . import scene_build
from .node_utils import (SHADER_TREE, Builder, add_spec_inputs, get_or_create_group, layer_material,
                         material_group_nodes, scene_group_nodes, scene_group_values, set_group_values, srgb_colour)
from .products import BoundSource, ProductRenderer

SPARKLE_RADIUS_MIN, SPARKLE_RADIUS_MAX = 0.15, 0.5  # flake radius in cell units over Sparkle Size [0, 1]
SPARKLE_ROUGHNESS = 0.15


def layer_colours(b: Builder, gin, label: str):
    """The layer's colour and its flakes' (nodes of the sRGB helper group: output [0] is linear RGB) from the
    Red/Green/Blue and Sparkle Red/Green/Blue inputs (sRGB 0-255)."""
    return (srgb_colour(b, gin, ("Red", "Green", "Blue"), label),
            srgb_colour(b, gin, ("Sparkle Red", "Sparkle Green", "Sparkle Blue"), "Sparkle Colour"))


def sparkle_flakes(b: Builder, gin, colour, normal, cells_per_unit: float, coords=None):
    """(flake weight, the flakes' BSDF): Voronoi cells on the object's xy plane (a default region faces +z); a cell
    holds a flake when its random value < Sparkle Density and the point is within its radius (Sparkle Size); a flake is
    a coloured mirror tilted from `normal` by the cell's random colour. `coords`: a Texture Coordinate node to reuse."""
    coords = coords or b.node("TexCoord")
    cells = b.node("TexVoronoi", label="Sparkle Cells", voronoi_dimensions="2D")  # 3D cells: the surface misses most
    b.link(coords.outputs["Object"], cells.inputs["Vector"])
    b.link(cells_per_unit, cells.inputs["Scale"])
    radius = b.node("MapRange", label="Sparkle Radius")
    b.link(gin["Sparkle Size"], radius.inputs["Value"])
    b.link(SPARKLE_RADIUS_MIN, radius.inputs["To Min"])
    b.link(SPARKLE_RADIUS_MAX, radius.inputs["To Max"])
    cell_random = b.node("SeparateColor")
    b.link(cells.outputs["Color"], cell_random.inputs[0])
    is_flake = b.math("MULTIPLY", b.math("LESS_THAN", cell_random.outputs[0], gin["Sparkle Density"]),
                      b.math("LESS_THAN", cells.outputs["Distance"], radius.outputs[0]))
    tilt = b.node("VectorMath", operation="MULTIPLY_ADD")
    b.link(cells.outputs["Color"], tilt.inputs[0])
    b.link((1.2, 1.2, 1.2), tilt.inputs[1])
    b.link((-0.6, -0.6, -0.6), tilt.inputs[2])
    tilted = b.node("VectorMath", operation="ADD")
    b.link(normal, tilted.inputs[0])
    b.link(tilt.outputs[0], tilted.inputs[1])
    flake_normal = b.node("VectorMath", operation="NORMALIZE")
    b.link(tilted.outputs[0], flake_normal.inputs[0])
    sparkle = b.node("BsdfGlossy", label="Sparkle")
    b.link(colour, sparkle.inputs["Color"])
    b.link(SPARKLE_ROUGHNESS, sparkle.inputs["Roughness"])
    b.link(flake_normal.outputs[0], sparkle.inputs["Normal"])
    return b.math("MULTIPLY", is_flake, gin["Sparkle Intensity"], clamp=True), sparkle.outputs[0]


@dataclass(frozen=True)
class LayerGroup:
    """A face layer's shader node group: the region's own shader in, the spec's inputs, and the layer mixed over that
    shader by its coverage; in a material, a Principled BSDF `bare_node` feeds it."""

    name: str  # the node group's: "VTO Lipstick"
    spec: Callable[[], RendererSpec]  # its inputs (the product's spec, read when the group is built)
    bare_input: str  # the group's shader input: "Lips"
    bare_description: str  # its tooltip
    layer: Callable  # (builder, group inputs) -> (coverage (a socket), the layer's shader (a socket))
    extra_inputs: Callable | None  # (group) -> None: inputs it adds after the spec's (the lid's coordinates), or None
    coverage_label: str  # the mix node's label: "Opacity"
    bare_node: str  # the bare shader's node in a material: "Bare Lips"
    bare_colour: tuple[float, float, float, float]  # its Base Color (linear RGBA)
    bare_roughness: float

    def build(self, group: bpy.types.NodeTree) -> None:
        """Build the group's interface and nodes in `group` (get_or_create_group's builder)."""
        group.interface.new_socket(self.bare_input, in_out="INPUT",
                                   socket_type="NodeSocketShader").description = self.bare_description
        add_spec_inputs(group, self.spec().params)
        if self.extra_inputs is not None:
            self.extra_inputs(group)
        group.interface.new_socket("Shader", in_out="OUTPUT", socket_type="NodeSocketShader")
        b = Builder(group, "Shader")
        gin = b.node("NodeGroupInput").outputs
        coverage, layer = self.layer(b, gin)
        over_bare = b.node("MixShader", label=self.coverage_label)
        b.link(coverage, over_bare.inputs["Fac"])
        b.link(gin[self.bare_input], over_bare.inputs[1])
        b.link(layer, over_bare.inputs[2])
        b.link(over_bare.outputs[0], b.node("NodeGroupOutput").inputs[0])

    def group(self) -> bpy.types.NodeTree:
        """Get or create the group."""
        return get_or_create_group(self.name, SHADER_TREE, self.build)

    def material(self, name: str, values: dict[str, float] | None = None) -> bpy.types.Material:
        """A new material: the Principled BSDF bare_node -> the group (inputs set from `values`, checked against the
        spec; the others at the group's defaults) -> Material Output."""
        return layer_material(name, self.group(), self.spec(), self.bare_node, self.bare_colour, self.bare_roughness,
                              values)


@dataclass(frozen=True)
class DefaultScene:
    """A face layer's default scene: the region on skin under a drawn light, set by a source seed."""

    build: Callable[[], bpy.types.Scene]  # get or create it (at source 0)
    apply_source: Callable  # (scene, seed, tones=None, light_seed=None): show that source, in place

    def mask(self, source_seed: int, res: int, lighting: str | None = None) -> np.ndarray:
        """The region in a res x res render of the scene at `source_seed`, lit the `lighting` way: (res, res) bool."""
        return scene_build.region_mask(self.build, self.apply_source, source_seed, res, lighting)


class FaceLayerRenderer(ProductRenderer):
    """A face layer's Blender side: its LayerGroup in a material, rendered with Cycles on its DefaultScene."""

    layer_group: LayerGroup
    scene: DefaultScene
    dark_below: float = 60.0  # max(R, G, B) below this (of 255) is a very dark shade (the evaluation's 'dark' bucket)
    add_hint: str = ""  # how a material gets the group, besides Add VTO <label> Material

    # 1. The group in materials and scenes.
    def nodes(self, material) -> list[bpy.types.Node]:
        """The group's nodes of `material` (none when it is None or has no node tree)."""
        return material_group_nodes(material, self.layer_group.name)

    def scene_nodes(self, scene: bpy.types.Scene) -> list[bpy.types.Node]:
        """Every group node in the materials of `scene`'s objects."""
        return scene_group_nodes(scene, self.layer_group.name)

    def set_values(self, scene: bpy.types.Scene, values: dict[str, float], fill_defaults: bool = True
                   ) -> dict[str, float]:
        """Set the group inputs on every group node of `scene` (node_utils.set_group_values: the default scene gets
        every input, a user's scene only `values`); returns the values written."""
        return set_group_values(scene, self.product.spec, self.layer_group.name, values, fill_defaults)

    def scene_values(self, scene: bpy.types.Scene) -> dict[str, float]:
        """The group inputs of the first group node of `scene` as the artist set them (linked ones left out)."""
        return scene_group_values(scene, self.product.spec, self.layer_group.name)

    def linked_inputs(self, scene: bpy.types.Scene) -> list[str]:
        """Names of the parameters whose input is driven by a link on any group node of `scene`."""
        return [p.name for p in self.product.spec.params
                if any(node.inputs[p.socket].is_linked for node in self.scene_nodes(scene))]

    def material(self, name, values=None):
        return self.layer_group.material(name, values)

    def add_group(self, obj):
        """A new material named as the group on `obj` (a mesh): a Principled BSDF (the bare region) -> the group ->
        Material Output, appended to its slots and made active. Returns the material."""
        if obj is None or obj.type != "MESH":
            raise VtoError(f"select a mesh object to add the {self.product.label.lower()} material to")
        material = self.material(self.layer_group.name)
        obj.data.materials.append(material)
        obj.active_material_index = len(obj.material_slots) - 1
        return material

    def where(self, material):
        return f"material '{material.name}'"

    def missing_group(self, material):
        return (f"material '{material.name}' does not use the '{self.layer_group.name}' node group (add one with Add "
                f"{self.layer_group.name} Material{self.add_hint})")

    # 2. The default scene.
    def default_scene(self):
        return self.scene.build()

    def render_scene(self, values: dict[str, float], source: int = 0, res: int | None = 64,
                     samples: int | None = DEFAULT_SAMPLES, seed: int = 0, scene: bpy.types.Scene | None = None,
                     lighting: str | None = None, tones: tuple[np.ndarray, np.ndarray] | None = None,
                     light_seed: int | None = None) -> np.ndarray:
        """R(X, g): display-sRGB image (res, res, 3) float32 of the default scene's `source`, lit the `lighting` way
        (None: the default), wearing `values`; `tones` (sRGB (3,) of the skin and the bare region) replace the
        source's own, and the light of source `light_seed` the source's own light, where the scene takes them.

        With `scene` given (a user's scene using the group) that scene is rendered with its own settings, only
        `values` and the res/samples given (not None) changing it; `source` is ignored.
        """
        from .cycles import configure_cycles, render_passes, render_user_scene, to_display
        from .scene_build import use_lighting

        if scene is not None:
            self.set_values(scene, values, fill_defaults=False)
            return render_user_scene(scene, res, samples, seed)
        scene = self.scene.build()
        use_lighting(scene, lighting)
        if not scene_build.applied(scene, source, tones, light_seed):
            self.scene.apply_source(scene, int(source), tones, light_seed)
        self.set_values(scene, values)
        configure_cycles(scene, res, samples, seed)
        return to_display(render_passes(scene)["Combined"][..., :3])

    def bind(self, source, res, samples, seed, lighting=None):
        self.check_source(source)
        source = int(source)

        def render(values):
            return self.render_scene(values, source, res, samples, seed, lighting=lighting)

        return BoundSource(render, lambda: render(self.product.bare({})),
                           lambda: self.scene.mask(source, res, lighting))

    def region_renderer(self, source, res, samples, tones=None):
        mask = self.scene.mask(source, res)
        return lambda values: (self.render_scene(values, source, res, samples, 0, tones=tones), mask)

    def dataset_images(self, values, source, res, samples, cycles_seed, options):
        def draw(v):
            return self.render_scene(v, source, res, samples, cycles_seed, scene=options.get("scene"),
                                     lighting=options.get("lighting"))

        bare = draw(self.product.bare(values[0])) if options.get("source_images", True) else None
        extra = {}
        if options.get("masks"):
            extra["mask"] = self.scene.mask(source, res, options.get("lighting")).astype(np.float32)
        return bare, [draw(v) for v in values], extra

    def is_dark(self, values):
        return max(values["red"], values["green"], values["blue"]) < self.dark_below
