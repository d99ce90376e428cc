"""The photo's light, read apart from the product: its colour from the skin beside the lips, taken out of the photo
before anything reads the material (the paper's illuminant estimation, for one photo).

A global change of light (a warm lamp, a cool shade, a dark exposure) multiplies every linear pixel by per-channel
gains k (3,). The skin shows k times its own colour, so the skin is the reference. Its mean log colour s is the log
of a skin (Gaussian: the default scene's skins, mean m, covariance S, which the encoder learned on) plus log k. The
light's prior is a mixture of two Gaussians: the default scene's own light (L0: the camera's small residual cast,
which the encoder already looks past) or, with probability STRONG_LIGHT_PRIOR, a light of any colour (L1). The light
read is the posterior mean

    log k = sum_i w_i A_i (s - m),    A_i = L_i (L_i + S)^-1,    w_i ~ p_i N(s - m; 0, L_i + S)

A skin the default scene could show reads as almost no light (w_0 ~ 1): renders and photos in neutral light are left
nearly as they are. A cast no skin has reads mostly as light (w_1 ~ 1; skins differ little in chromaticity, so A_1
takes 0.93 of a cast's log). Neither holds an exposure: skins differ far more in lightness than exposures do, and a
dark skin under a bright light cannot be told from a light skin in a dim one, so that is left to the encoder (it
reads the lips beside the skin, as it learned on the default scene's metered renders). Dividing the photo by k
(neutral_photo) gives what the default scene's camera would show. The measures behind the choice are in
benchmarks/results/light.md and the lipstick model card.

Shapes: images (H, W, 3) display sRGB in [0, 1]; colours and gains (3,) linear RGB.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..colour import linear_to_srgb, srgb_to_linear
from ..portrait_light import WARM_COOL

# The default lips scene's skin beside the lips (vto_core.appearance.skin_colour of 64 px, 16 spp renders of default
# sources 910000-910095, bare lips): the mean and covariance of its log linear RGB. Reproduce:
# `python -m benchmarks.bench_light --calibrate`.
SKIN_LOG_MEAN = np.array([-0.9588, -1.5400, -1.9718])
SKIN_LOG_COV = np.array([[0.4804, 0.4659, 0.4461],
                         [0.4659, 0.4713, 0.4547],
                         [0.4461, 0.4547, 0.4631]])
# The prior on a photo's light: the standard deviation of its log gains in each chromatic direction. The default
# scene's camera: its residual warm/cool error (portrait_light.WARM_COOL). Any light: 0.6, twice the cast of 3,700 K
# or 12,000 K light on a camera balanced for daylight. Encoder on the photo with its light taken out, against the
# encoder alone, on renders with their source hidden (24 looks at seeds 9001 and 4242): +0.06 and -0.13 dB with this
# mixture; -0.19 and -1.04 dB with the wide Gaussian alone (it read the default scene's own skins as light); on the 18
# portraits re-lit, the same median (1.7) and largest (4.4) CIEDE2000 either way. Reading an exposure of half a stop
# as well cost 1.0 dB on those renders.
SCENE_CAST_SIGMA = WARM_COOL
ANY_CAST_SIGMA = 0.6
STRONG_LIGHT_PRIOR = 0.5  # the prior probability that a photo's light is not the default scene's
MAX_GAIN = 8.0  # no estimated gain goes beyond this either way (a skin of one flat channel, a synthetic image)
# A skin whose linear channels differ by less than this (log units, about 2 %) shows no colour, so no light's colour
# can be read from it (a black-and-white photo): the light is kept, not read as a cast.
NO_CHROMA_LOG = 0.02
TABLE_SIZE = 65536
TABLE_PIXELS_AT_ONCE = 1 << 20  # relit reads a large image's curves this many pixels at a time
TABLE_LINEAR = srgb_to_linear(np.linspace(0.0, 1.0, TABLE_SIZE, dtype=np.float32))  # the table's inputs, linear
NEUTRAL_KELVIN = 6504.0  # the black body nearest D65, the white of sRGB: what a daylight-balanced photo shows neutral


def light_covariance(cast_sigma: float) -> np.ndarray:
    """(3, 3) the prior covariance of a light's log gains: `cast_sigma` in each direction across grey, no exposure."""
    return cast_sigma ** 2 * (np.eye(3) - np.full((3, 3), 1.0 / 3.0))


def read_gain(cast_sigma: float, skin_log_cov: np.ndarray = SKIN_LOG_COV) -> np.ndarray:
    """A (3, 3) = L (L + S)^-1: how much of the skin's log deviation from the typical skin one Gaussian light prior
    of `cast_sigma` reads as light."""
    light = light_covariance(cast_sigma)
    return light @ np.linalg.inv(light + np.asarray(skin_log_cov, np.float64))


# Each prior light: (A_i, L_i + S, its log determinant, log p_i).
LIGHTS = tuple((read_gain(sigma), light_covariance(sigma) + SKIN_LOG_COV,
                np.linalg.slogdet(light_covariance(sigma) + SKIN_LOG_COV)[1], math.log(prior))
               for sigma, prior in ((SCENE_CAST_SIGMA, 1.0 - STRONG_LIGHT_PRIOR), (ANY_CAST_SIGMA, STRONG_LIGHT_PRIOR)))


def read_log_light(deviation: np.ndarray) -> np.ndarray:
    """(3,) the posterior mean of the light's log gains, given the skin's log deviation (3,) from SKIN_LOG_MEAN."""
    deviation = np.asarray(deviation, np.float64)
    scores = np.array([log_prior - 0.5 * (deviation @ np.linalg.solve(total, deviation) + log_det)
                       for _, total, log_det, log_prior in LIGHTS])
    weights = np.exp(scores - scores.max())
    weights /= weights.sum()
    return sum(weight * (gain @ deviation) for weight, (gain, *_) in zip(weights, LIGHTS))


@dataclass(frozen=True)
class PhotoLight:
    """A photo's light as read from its skin: per-channel linear gains (3,) against the default scene's light, and
    where they were read ('skin'; 'none' when the photo shows no skin to read them from, 'grey' when its skin shows
    no colour: gains 1)."""

    gains: np.ndarray
    read_from: str

    @property
    def cast(self) -> np.ndarray:
        """(3,) the gains over their geometric mean: the light's colour."""
        return self.gains / np.exp(np.mean(np.log(self.gains)))

    def describe(self) -> str:
        """One short line for the artist (the panel shows it under the thumbnail): what was read and taken out."""
        if self.read_from == "none":
            return "no skin to read the photo's light from"
        if self.read_from == "grey":
            return "no colour in the skin to read the photo's light from"
        red, _, blue = self.cast
        warmth = "neutral" if abs(math.log(red / blue)) < 0.1 else ("warm" if red > blue else "cool")
        return f"photo's light taken out: {warmth}"


def light_from_skin(skin_linear: np.ndarray | None) -> PhotoLight:
    """The light (PhotoLight) whose gains most likely turned a default-scene skin into `skin_linear` (3,, the mean
    linear RGB of the skin beside the lips, vto_core.appearance.skin_colour); gains 1 for None (no skin seen) and for
    a grey skin (no colour to read a light's colour from). Finite for any input: non-finite or non-positive channels
    are floored, the gains clipped to MAX_GAIN."""
    if skin_linear is None:
        return PhotoLight(np.ones(3), "none")
    skin = np.nan_to_num(np.asarray(skin_linear, np.float64), nan=0.0, posinf=1.0, neginf=0.0)
    log_skin = np.log(np.maximum(skin, 1e-4))
    if np.ptp(log_skin) < NO_CHROMA_LOG:
        return PhotoLight(np.ones(3), "grey")
    log_gains = read_log_light(log_skin - SKIN_LOG_MEAN)
    return PhotoLight(np.clip(np.exp(log_gains), 1.0 / MAX_GAIN, MAX_GAIN), "skin")


def light_of(image: np.ndarray, region: np.ndarray) -> PhotoLight:
    """The light of a photo (H, W, 3) read from the skin around a face region of it (mask (H, W): the lips)."""
    from ..appearance import skin_colour

    return light_from_skin(skin_colour(image, region))


def relit(image: np.ndarray, gains: np.ndarray) -> np.ndarray:
    """(H, W, 3) display -> (H, W, 3) float32 display: each linear channel times `gains` (3,), clipped to [0, 1] as a
    camera would. Dividing by a light's gains (1 / gains) neutralises it. Inputs outside [0, 1] (HDR, negatives, NaN)
    are clipped first. An image with more values than a table of TABLE_SIZE points per channel reads each channel's
    curve from that table at the nearest point (within 1e-4 of the exact curve; a 1-megapixel photo in ~40 ms, where
    the exact powers took ~90 ms); a smaller one (the framed lips) is computed exactly, cheaper than the table."""
    image = np.asarray(image)
    gains = np.asarray(gains, np.float32)
    if image.size <= 3 * TABLE_SIZE:
        image = np.clip(np.nan_to_num(np.asarray(image, np.float32), nan=0.0), 0.0, 1.0)
        return np.clip(linear_to_srgb(np.clip(srgb_to_linear(image) * gains, 0.0, 1.0)), 0.0, 1.0)
    curves = np.clip(linear_to_srgb(np.clip(TABLE_LINEAR[:, None] * gains, 0.0, 1.0)), 0.0, 1.0)  # (TABLE_SIZE, 3)
    out = np.empty(image.shape, np.float32)
    step = max(1, 3 * TABLE_PIXELS_AT_ONCE // max(1, image[0].size))  # rows (or pixels) at a time: no image-sized
    for start in range(0, len(image), step):  # temporaries (a 64-megapixel photo's hair is hundreds of MB a copy)
        part = np.clip(np.nan_to_num(np.asarray(image[start:start + step], np.float32), nan=0.0), 0.0, 1.0)
        out[start:start + step] = curves[(part * (TABLE_SIZE - 1) + 0.5).astype(np.int32), np.arange(3)]
    return out


def neutral_photo(image: np.ndarray, light: PhotoLight) -> np.ndarray:
    """(H, W, 3) display with `light` taken out: what it would show under the default scene's light."""
    if light.read_from != "skin":
        return np.asarray(image, np.float32)
    return relit(image, 1.0 / light.gains)


def planck_xy(kelvin: float) -> tuple[float, float]:
    """CIE 1931 chromaticity (x, y) of a black body at `kelvin` (1,667-25,000 K; Kim et al.'s cubic fit)."""
    t = float(np.clip(kelvin, 1667.0, 25000.0))
    if t <= 4000.0:
        x = -0.2661239e9 / t ** 3 - 0.2343589e6 / t ** 2 + 0.8776956e3 / t + 0.179910
    else:
        x = -3.0258469e9 / t ** 3 + 2.1070379e6 / t ** 2 + 0.2226347e3 / t + 0.240390
    if t <= 2222.0:
        y = -1.1063814 * x ** 3 - 1.34811020 * x ** 2 + 2.18555832 * x - 0.20219683
    elif t <= 4000.0:
        y = -0.9549476 * x ** 3 - 1.37418593 * x ** 2 + 2.09137015 * x - 0.16748867
    else:
        y = 3.0817580 * x ** 3 - 5.87338670 * x ** 2 + 3.75112997 * x - 0.37001483
    return x, y


XYZ_TO_LINEAR_SRGB = np.array([[3.2404542, -1.5371385, -0.4985314],
                               [-0.9692660, 1.8760108, 0.0415560],
                               [0.0556434, -0.2040259, 1.0572252]])


def kelvin_gains(kelvin: float, ev: float = 0.0) -> np.ndarray:
    """(3,) von Kries gains in linear sRGB that re-light a photo balanced for daylight (D65) with a black body at
    `kelvin` in place of one at NEUTRAL_KELVIN, green kept, and `ev` stops brighter: what a camera left at daylight
    balance records under that light."""
    def white(t: float) -> np.ndarray:
        x, y = planck_xy(t)
        return XYZ_TO_LINEAR_SRGB @ np.array([x / y, 1.0, (1.0 - x - y) / y])

    rgb = white(kelvin) / white(NEUTRAL_KELVIN)
    return rgb / rgb[1] * 2.0 ** ev
