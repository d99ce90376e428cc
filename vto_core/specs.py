"""Parameter specs: one source of truth for sockets, sampling, networks and ONNX metadata."""

from __future__ import annotations

import json
import math
import sys
import warnings
from dataclasses import asdict, dataclass, field

import numpy as np

from .errors import VtoError

# The saturating map u = v / (v + scale) never reaches 1; capping u keeps from_unit finite.
UNIT_CAP = 1.0 - 1e-7
FLOAT_MAX = sys.float_info.max


@dataclass(frozen=True)
class ParamSpec:
    """One renderer parameter: its Blender socket, range, default and [0,1] mapping."""

    name: str
    socket: str
    low: float
    high: float  # math.inf for [low, +inf)
    default: float
    unit: str = ""
    group: str = ""
    wraps: bool = False  # hue: high is the same value as low
    scale: float = 1.0  # unbounded ranges: the saturating map is v / (v + scale)
    unit_high: float = math.inf  # unbounded ranges: the largest value the [0,1] space encodes (sampling's top)
    unit_power: float = 1.0  # the encoded unit is the affine/saturating unit ** unit_power (< 1 widens the low end)
    description: str = ""
    unmodelled_reason: str = ""  # why the parameter is left out of the default model ("" = modelled)

    def __post_init__(self):
        if not 0.0 < self.unit_power < math.inf or (self.wraps and self.unit_power != 1.0):
            raise VtoError(f"parameter '{self.name}': unit_power must be positive and finite (1 for a wrapping "
                           f"parameter), got {self.unit_power}")

    @property
    def bounded(self) -> bool:
        """Whether the range has a finite upper end."""
        return math.isfinite(self.high)

    @property
    def sample_high(self) -> float:
        """The largest value from_unit can return (the cap of an unbounded range)."""
        return self.high if self.bounded else self.from_unit(1.0)

    def clamp(self, value: float) -> float:
        """Bring a raw value into range: wrap if the parameter wraps, else clamp with a warning."""
        value = float(value)
        if math.isnan(value):
            raise VtoError(f"parameter '{self.name}' is NaN")
        if self.wraps:
            if not math.isfinite(value):
                raise VtoError(f"parameter '{self.name}' is {value}; a wrapping parameter needs a finite value")
            span = self.high - self.low
            return self.low + (value - self.low) % span
        if value < self.low or value > self.high or value == math.inf:
            clamped = min(max(value, self.low), self.high if self.bounded else FLOAT_MAX)
            warnings.warn(
                f"parameter '{self.name}' = {value:g} is outside [{self.low:g}, {self.high:g}]; clamped to {clamped:g}",
                stacklevel=3,
            )
            return clamped
        return value

    def to_unit(self, value: float) -> float:
        """Raw value -> [0,1]: affine, or v/(v+scale) for an unbounded range, then ** unit_power."""
        value = self.clamp(value) - self.low
        if self.bounded:
            unit = value / (self.high - self.low)
            if self.wraps and unit >= 1.0:
                return 0.0
        else:
            unit = min(self._saturate(value) / self._saturate(self.unit_high - self.low), 1.0)
        return unit if self.unit_power == 1.0 else unit**self.unit_power

    def _saturate(self, value: float) -> float:
        """v / (v + scale) in [0, 1], without overflow near float max (s / v is tiny there instead)."""
        if value == math.inf:
            return 1.0
        if value > 1.0:
            return 1.0 / (1.0 + self.scale / value)
        return value / (value + self.scale)

    def from_unit(self, unit: float) -> float:
        """[0,1] -> raw value; out-of-range units are clamped (or wrapped for hue)."""
        unit = float(unit)
        if math.isnan(unit):
            raise VtoError(f"normalised value of '{self.name}' is NaN")
        if self.wraps:
            unit = unit % 1.0
        unit = min(max(unit, 0.0), 1.0)
        if self.unit_power != 1.0:
            unit = unit ** (1.0 / self.unit_power)
        if self.bounded:
            return self.low + unit * (self.high - self.low)
        if unit >= 1.0 and math.isfinite(self.unit_high):
            return self.unit_high
        saturated = min(unit * self._saturate(self.unit_high - self.low), UNIT_CAP)
        return self.low + self.scale * saturated / (1.0 - saturated)


@dataclass(frozen=True)
class RendererSpec:
    """A renderer's parameters and the subset that is modelled, in a stable vector order."""

    renderer: str
    params: tuple[ParamSpec, ...]
    modelled: tuple[str, ...] = field(default=())

    def __post_init__(self):
        if not self.modelled:
            object.__setattr__(self, "modelled", tuple(p.name for p in self.params if not p.unmodelled_reason))

    @property
    def by_name(self) -> dict[str, ParamSpec]:
        """All parameters keyed by name."""
        return {p.name: p for p in self.params}

    @property
    def modelled_params(self) -> tuple[ParamSpec, ...]:
        """The modelled parameters in vector order."""
        by_name = self.by_name
        return tuple(by_name[n] for n in self.modelled)

    @property
    def size(self) -> int:
        """Length of the parameter vector g."""
        return len(self.modelled)

    def left_out(self) -> dict[str, str]:
        """Parameters not modelled, each with why (its unmodelled_reason, or "not selected")."""
        return {p.name: p.unmodelled_reason or "not selected" for p in self.params if p.name not in self.modelled}

    def select(self, names) -> "RendererSpec":
        """A spec modelling only `names` (comma string or iterable); vector order stays the spec's order."""
        if isinstance(names, str):
            names = [n.strip() for n in names.split(",") if n.strip()]
        names = list(names)
        unknown = [n for n in names if n not in self.by_name]
        if unknown:
            raise VtoError(
                f"unknown {self.renderer} parameter(s) {', '.join(unknown)}; known: {', '.join(p.name for p in self.params)}"
            )
        if not names:
            raise VtoError("select needs at least one parameter name")
        order = [p.name for p in self.params if p.name in set(names)]
        return RendererSpec(self.renderer, self.params, tuple(order))

    def defaults(self) -> dict[str, float]:
        """Every parameter at its default."""
        return {p.name: p.default for p in self.params}

    def full_values(self, values: dict[str, float] | None = None) -> dict[str, float]:
        """All parameters: defaults overridden by `values` (checked and clamped)."""
        full = self.defaults()
        for name, value in (values or {}).items():
            if name not in full:
                raise VtoError(f"unknown {self.renderer} parameter '{name}'")
            full[name] = self.by_name[name].clamp(value)
        return full

    def check_values(self, values: dict[str, float]) -> dict[str, float]:
        """Strict form of full_values: unknown names, NaN and out-of-range values are errors (hue still wraps)."""
        for name, value in values.items():
            param = self.by_name.get(name)
            if param is None:
                raise VtoError(f"unknown {self.renderer} parameter '{name}'; known: {', '.join(self.by_name)}")
            if not isinstance(value, (int, float)) or math.isnan(value):
                raise VtoError(f"parameter '{name}' must be a number, got {value!r}")
            if not param.wraps and not param.low <= value <= (param.high if param.bounded else FLOAT_MAX):
                raise VtoError(f"parameter '{name}' = {value:g} is outside its range [{param.low:g}, {param.high:g}]")
        return self.full_values(values)

    def vector(self, values: dict[str, float]) -> np.ndarray:
        """Raw values of the modelled parameters: dict -> (size,) float64; missing names take defaults."""
        full = self.full_values(values)
        return np.array([full[n] for n in self.modelled], dtype=np.float64)

    def values(self, vector) -> dict[str, float]:
        """Raw vector (size,) -> dict of all parameters (unmodelled ones at defaults)."""
        vector = np.asarray(vector, dtype=np.float64).reshape(-1)
        if vector.shape[0] != self.size:
            raise VtoError(f"{self.renderer} vector has {vector.shape[0]} values; the spec models {self.size}")
        return self.full_values(dict(zip(self.modelled, vector.tolist())))

    def normalise(self, raw) -> np.ndarray:
        """Raw values (..., size) -> [0,1] values (..., size) float32."""
        raw = np.asarray(raw, dtype=np.float64)
        self._check_width(raw)
        flat = raw.reshape(-1, self.size)
        out = np.array([[p.to_unit(v) for p, v in zip(self.modelled_params, row)] for row in flat])
        return out.reshape(raw.shape).astype(np.float32)

    def denormalise(self, unit) -> np.ndarray:
        """[0,1] values (..., size) -> raw values (..., size) float64."""
        unit = np.asarray(unit, dtype=np.float64)
        self._check_width(unit)
        flat = unit.reshape(-1, self.size)
        out = np.array([[p.from_unit(u) for p, u in zip(self.modelled_params, row)] for row in flat])
        return out.reshape(unit.shape)

    def _check_width(self, array: np.ndarray) -> None:
        if array.ndim == 0 or array.shape[-1] != self.size:
            raise VtoError(f"expected a last axis of {self.size} {self.renderer} values, got shape {array.shape}")

    def to_dict(self) -> dict:
        """JSON-ready form (infinite ends written as null)."""
        params = []
        for p in self.params:
            entry = asdict(p)
            entry["high"] = p.high if p.bounded else None
            params.append(entry)
        return {"renderer": self.renderer, "modelled": list(self.modelled), "params": params}

    def to_json(self) -> str:
        """Compact JSON for manifests and ONNX metadata."""
        return json.dumps(self.to_dict(), sort_keys=True)

    @classmethod
    def from_dict(cls, data: dict) -> "RendererSpec":
        """Inverse of to_dict."""
        try:
            params = tuple(
                ParamSpec(**{**p, "high": math.inf if p["high"] is None else p["high"]}) for p in data["params"]
            )
            return cls(data["renderer"], params, tuple(data["modelled"]))
        except (KeyError, TypeError) as exc:
            raise VtoError(f"not a renderer spec: {exc}") from None

    def same_as(self, other: "RendererSpec") -> bool:
        """Whether two specs give the same vector (renderer, modelled names, ranges, encoding)."""
        return self.to_dict() == other.to_dict()

    def same_values(self, other: "RendererSpec") -> bool:
        """Whether two specs estimate the same raw values (renderer, modelled names and ranges), however they encode
        them in [0, 1]: models of either give comparable estimates."""
        def values(spec):
            return spec.renderer, [(p.name, p.low, p.high, p.wraps) for p in spec.modelled_params]
        return values(self) == values(other)


# Measured by tests/blender_addon/test_visibility.py and benchmarks/bench_render.py (benchmarks/results/render.md).
INVISIBLE = ("at 64 px and the default samples its 25th->75th percentile change stands less than 3x above render "
             "noise on the lips (4x4 block means): the encoder cannot learn it; select it with --params to model it")


ROUGHNESS_BELOW_BAR = ("its 25th->75th percentile change stands 2.36x (less than 3x) above render noise on the lips "
                       "at 64 px, even under a gloss of 2: a rough and a sharp coat spread the same highlight over a "
                       "few pixels, so the encoder cannot learn it; select it with --params to model it")


# The encoded unit is the linear (reflection) or saturating (gloss) unit ** power, fitted so that the cumulative
# visibility of the power-1 quarters rises evenly: those stood 2.9, 2.1, 1.9, 1.8x above render noise for gloss and
# 3.7, 2.5, 2.6, 2.5x for reflection; now 2.1-2.3x and 2.6-3.0x (benchmarks/results/visibility.md).
GLOSS_UNIT_POWER = 0.8
REFLECTION_UNIT_POWER = 0.85


def lipstick_spec() -> RendererSpec:
    """The VTO Lipstick group's inputs (paper Table 2 and the extended ones)."""
    main, ext = "main", "extended"
    p = ParamSpec
    return RendererSpec(
        "lipstick",
        (
            p("opacity", "Opacity", 0.0, 1.0, 0.8, "", main, description="Makeup coverage over the bare lips"),
            p("red", "Red", 0.0, 255.0, 170.0, "8-bit sRGB", main, description="Makeup colour, red"),
            p("green", "Green", 0.0, 255.0, 40.0, "8-bit sRGB", main, description="Makeup colour, green"),
            p("blue", "Blue", 0.0, 255.0, 60.0, "8-bit sRGB", main, description="Makeup colour, blue"),
            p("gloss", "Gloss", 0.0, math.inf, 0.5, "", main, scale=1.0, unit_high=8.0, unit_power=GLOSS_UNIT_POWER,
              description="Amount of gloss: the clear coat's reflectance, saturating as gloss grows (0 = none). "
                          "Sampled and estimated over [0, 8], twice the glossiest preset"),
            p("gloss_roughness", "Gloss Roughness", 0.0, 1.0, 0.3, "", main, unmodelled_reason=ROUGHNESS_BELOW_BAR,
              description="Roughness of the gloss layer (the clear coat's roughness)"),
            p("reflection", "Reflection", 0.0, 1.0, 0.2, "", main, unit_power=REFLECTION_UNIT_POWER,
              description="Environment reflection intensity"),
            p("sparkle_density", "Sparkle Density", 0.0, 1.0, 0.0, "", ext, unmodelled_reason=INVISIBLE, description="Fraction of the surface with glitter"),
            p("sparkle_size", "Sparkle Size", 0.0, 1.0, 0.3, "", ext, unmodelled_reason=INVISIBLE, description="Size of the glitter flakes"),
            p("sparkle_intensity", "Sparkle Intensity", 0.0, 1.0, 0.5, "", ext, unmodelled_reason=INVISIBLE, description="Brightness of the flakes"),
            p("sparkle_red", "Sparkle Red", 0.0, 255.0, 255.0, "8-bit sRGB", ext, unmodelled_reason=INVISIBLE, description="Flake colour, red"),
            p("sparkle_green", "Sparkle Green", 0.0, 255.0, 255.0, "8-bit sRGB", ext, unmodelled_reason=INVISIBLE, description="Flake colour, green"),
            p("sparkle_blue", "Sparkle Blue", 0.0, 255.0, 255.0, "8-bit sRGB", ext, unmodelled_reason=INVISIBLE, description="Flake colour, blue"),
            p("lip_line", "Lip Line", 0.0, 1.0, 0.0, "", ext, unmodelled_reason=INVISIBLE, description="Darkening of the lip contour (lip-liner)"),
            p("texture", "Texture", 0.0, 1.0, 0.0, "", ext, unmodelled_reason=INVISIBLE, description="Bump strength of the creamy texture"),
            p("metallic", "Metallic", 0.0, 1.0, 0.0, "", ext, unmodelled_reason=INVISIBLE, description="Metallic finish"),
            p("sheen", "Sheen", 0.0, 1.0, 0.0, "", ext, unmodelled_reason=INVISIBLE, description="Satin sheen"),
        ),
    )



# Where the shadow sits on the lid is the artist's choice for a character, not a property of the product: a photo of a
# made-up eye shows one placement among many (Kips et al.'s video makeup leaves the zone to the user as well).
PLACEMENT = ("where the shadow sits on the lid: the artist sets it for the character, a photo of a product does not "
             "fix it")
# Measured by benchmarks/bench_parameter_visibility.py (results/visibility.md, "eyeshadow-parameters"): 25th -> 75th
# percentile change over render noise on the lids of default sources 1-4, the bar 3. The flakes cover a few pixels of a
# 64 px eye: their size and brightness sit just under the bar (2.88, 2.80), their colour far under it (1.4-1.7).
FLAKES_UNDER_BAR = ("under the visibility bar at 64 px (change/noise {ratio} < 3 on the default eye's lids): the flakes "
                    "cover a few pixels; select it with --params to model it at a larger size")


def eyeshadow_spec() -> RendererSpec:
    """The VTO Eye Shadow group's inputs: the product (colour, shimmer, flakes, metallic) and its placement."""
    product, placement = "product", "placement"
    p = ParamSpec
    def flakes(ratio):
        return FLAKES_UNDER_BAR.format(ratio=ratio)

    return RendererSpec(
        "eyeshadow",
        (
            p("opacity", "Opacity", 0.0, 1.0, 0.8, "", product, description="Shadow coverage over the bare lid"),
            p("red", "Red", 0.0, 255.0, 150.0, "8-bit sRGB", product, description="Shadow colour, red"),
            p("green", "Green", 0.0, 255.0, 110.0, "8-bit sRGB", product, description="Shadow colour, green"),
            p("blue", "Blue", 0.0, 255.0, 95.0, "8-bit sRGB", product, description="Shadow colour, blue"),
            p("shimmer", "Shimmer", 0.0, 1.0, 0.0, "", product,
              description="Amount of a fine pearlescent sheen: the share of the shadow that reflects like pearl "
                          "(0 = matte)"),
            p("shimmer_roughness", "Shimmer Roughness", 0.0, 1.0, 0.4, "", product,
              description="Roughness of the shimmer's sheen (0 = a sharp glint, 1 = a soft glow)"),
            p("shimmer_tint", "Shimmer Tint", 0.0, 1.0, 0.5, "", product,
              description="Colour of the shimmer's sheen: a mix from white (0) to the shadow colour (1)"),
            p("sparkle_density", "Sparkle Density", 0.0, 1.0, 0.0, "", product,
              description="Fraction of the shadow with glitter flakes"),
            p("sparkle_size", "Sparkle Size", 0.0, 1.0, 0.3, "", product, unmodelled_reason=flakes("2.88"),
              description="Size of the glitter flakes"),
            p("sparkle_intensity", "Sparkle Intensity", 0.0, 1.0, 0.5, "", product, unmodelled_reason=flakes("2.80"),
              description="Brightness of the flakes"),
            p("sparkle_red", "Sparkle Red", 0.0, 255.0, 255.0, "8-bit sRGB", product, unmodelled_reason=flakes("1.42"),
              description="Flake colour, red"),
            p("sparkle_green", "Sparkle Green", 0.0, 255.0, 255.0, "8-bit sRGB", product, unmodelled_reason=flakes("1.61"),
              description="Flake colour, green"),
            p("sparkle_blue", "Sparkle Blue", 0.0, 255.0, 255.0, "8-bit sRGB", product, unmodelled_reason=flakes("1.72"),
              description="Flake colour, blue"),
            p("metallic", "Metallic", 0.0, 1.0, 0.0, "", product,
              description="Metallic finish: the shadow reflects in its own colour, like foil"),
            p("height", "Height", 0.0, 1.0, 0.65, "", placement, unmodelled_reason=PLACEMENT,
              description="How far the shadow reaches toward the brow, in lid coordinate (0 = the lash line, 1 = the "
                          "brow)"),
            p("softness", "Softness", 0.0, 1.0, 0.5, "", placement, unmodelled_reason=PLACEMENT,
              description="Softness of the shadow's edge: how far it fades out above Height and toward the lid's "
                          "ends (0 = a sharp edge)"),
            p("shift", "Shift", -1.0, 1.0, 0.0, "", placement, unmodelled_reason=PLACEMENT,
              description="Where along the lid the shadow is densest: -1 the inner corner, 0 even, 1 the outer "
                          "corner"),
        ),
    )

# A photo of hair shows a colour, not how strongly the stage was applied to an unknown source nor where it faded in:
# the estimate is the stage's setting that gives the artist's hair the photo's colour, at full effect on all the hair
# (the defaults intensity 1, blend -1). The artist lowers Intensity or moves Blend afterwards for a mix or a fade.
PHOTO_FIXED = ("a photo shows the colour, not how the stage was applied: a match sets it to its default (full effect "
               "on all the hair), the artist changes it afterwards")


def hair_spec() -> RendererSpec:
    """The VTO Hair Color stage's settings (paper 4.2)."""
    from .hair import GLOBAL_CONTRAST_GAIN, LOCAL_CONTRAST_GAIN, LOCAL_RADIUS  # the tooltip quotes the stage's maths

    sw, non = "swatch", "non-swatch"
    p = ParamSpec
    # Swatch steps run in this order on display values: (x - 0.5) * contrast + 0.5 + brightness, * exposure, clamp to
    # [0, 1], ^(1/gamma), hue shift, saturation, clamp (vto_core.colour.recolour_swatch). Each tooltip says which
    # Blender compositor node setting gives the same step (checked exactly in tests/blender_addon/test_hair_stage.py).
    return RendererSpec(
        "hair",
        (
            p("brightness", "Brightness", -0.3, 0.3, 0.0, "", sw,
              description="Swatch brightness: added to every value after the contrast step (0 = unchanged). "
                          "Blender's Brightness/Contrast node adds its Brightness before the contrast: this equals "
                          "that node with Brightness = 100 x brightness / contrast"),
            p("contrast", "Contrast", 0.5, 2.0, 1.0, "factor", sw,
              description="Swatch contrast: values scaled about mid-grey 0.5 by this factor (1 = unchanged). "
                          "Blender's Brightness/Contrast node with Contrast = 100 (1 - 1/c) for c >= 1, "
                          "100 (c - 1) below"),
            p("exposure", "Exposure", 0.5, 2.0, 1.0, "factor", sw,
              description="Swatch gain: values multiplied by this factor, then clamped to [0, 1] (1 = unchanged). "
                          "Not stops: Blender's Exposure node with Exposure = log2(factor)"),
            p("gamma", "Gamma", 0.5, 3.0, 1.0, "", sw,
              description="Swatch gamma: y = x^(1/gamma), so above 1 lightens and below 1 darkens (1 = unchanged). "
                          "The inverse of Blender's Gamma node (y = x^gamma): that node with Gamma = 1/gamma"),
            p("hue", "Hue", 0.0, 1.0, 0.0, "turns", sw, wraps=True,
              description="Swatch hue shift in turns, wrapping (0 and 1 = unchanged, 0.5 = opposite colour). "
                          "Blender's Hue/Saturation/Value node centres Hue on 0.5: its Hue = this + 0.5"),
            p("saturation", "Saturation", 0.0, 3.0, 1.0, "factor", sw,
              description="Swatch saturation factor (0 = grey, 1 = unchanged), as Blender's Hue/Saturation/Value "
                          "node's Saturation; the result is clamped to [0, 1]"),
            p("blend", "Blend", -1.0, 1.0, -1.0, "", non, unmodelled_reason=PHOTO_FIXED,
              description="Faded look: how far down the hair the new colour starts. It fades in over half the "
                          "hair's height from (1 + 3 blend) / 4 of the way down: -1 colours all the hair, 0 starts "
                          "a quarter down, 1 colours none; every step in between colours less"),
            p("intensity", "Intensity", 0.0, 1.0, 1.0, "", non, unmodelled_reason=PHOTO_FIXED,
              description="Strength of the colour change: a mix between the hair's own pixels (0) and the "
                          "recoloured ones (1)"),
            p("shine", "Shine", 0.0, 1.0, 0.0, "", non,
              description="Global and local contrast of the recoloured hair (0 = none). Global: an S-curve about "
                          f"mid-grey, y + {GLOBAL_CONTRAST_GAIN:g} shine (smoothstep(y) - y), which darkens values "
                          f"under 0.5 and brightens those over (above shine {1 / GLOBAL_CONTRAST_GAIN:g} the darkest "
                          f"clip to black); local: + {LOCAL_CONTRAST_GAIN:g} shine (y - blur(y)), a Gaussian blur of "
                          f"radius {100 * LOCAL_RADIUS:g} % of the image width, which lifts the strands' highlights"),
        ),
    )
