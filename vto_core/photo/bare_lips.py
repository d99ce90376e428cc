"""The bare lips under a lipstick, from the skin beside them: what a photo fit in the photo's own scene puts under
the layer (a made-up photo does not show its bare lips).

Lips are skin with more blood under it: per channel, bare lips = skin x r, with log r linear in the skin's log
luminance (darker skins have lips nearer their skin's colour; below L* 45 more steeply, DARK_SLOPE: a black skin's lips
are lighter than the skin) and in its log chroma (red over green, blue over green:
the London Set's studio portraits, whose skin is less red than data/faces' NASA portraits, have lips darker and redder
against their skin, 0.75-0.84 of what the luminance alone predicted). The skin is given in the light's own white
(the caller divides the photo's light colour out), so the light's colour does not move r. COEFFICIENTS were fitted
by least squares (RATIO_SLOPE held) on the 213 training faces that wear no lipstick, of data/faces and the London Set
(the 64 px lips frame, the skin around the lips as vto_core.appearance.skin_colour reads it): `python -m
benchmarks.bench_bare_lips` refits them and reports the error on the faces no fit saw.

Shapes: colours (3,) linear RGB.
"""

from __future__ import annotations

import numpy as np

from ..colour import luminance

# log r (3,) = RATIO_SLOPE x min(log skin luminance, 0) + DARK_SLOPE x min(log(luminance / DARK_KNEE), 0)
#   + COEFFICIENTS.T @ (1, log(R/G), log(B/G)) of the skin. The
# slope on luminance is the one fitted on data/faces alone and kept: fitted on both sets it is twice as steep, and a
# photo's exposure then moves Better more (the re-lit portraits at +0.7 / -0.7 EV: medians 5.6 / 4.0 against 4.9 / 3.5
# with the slope kept, 4.5 / 3.3 with no chroma).
RATIO_SLOPE = np.array([-0.097, -0.123, -0.144])
COEFFICIENTS = np.array([[-0.501, -1.043, -0.701],
                         [0.580, 1.228, 0.803],
                         [0.203, 0.504, 0.352]])
# Below the skin luminance DARK_KNEE (L* 45) log r also climbs DARK_SLOPE per unit of log luminance. With the slope
# above alone the bare lips of the London Set's black faces were guessed 4-5 L* too dark (training split -5.0 on 6
# photos, evaluation -4.3 on 20), and Better then read their lipsticks as thin coats of lighter colours. Fitted by
# least squares on the 8 training photos of skins below the knee (COEFFICIENTS held): training -0.3 L*, evaluation
# -0.2. Skins above the knee (every other group's evaluation faces; a typical light skin 0.7 stops under) are guessed
# as before, bit for bit.
DARK_KNEE = 0.1454  # the luminance of L* 45
DARK_SLOPE = np.array([-0.317, -0.404, -0.355])
LUMINANCE_FLOOR = 1e-3  # a black skin reads as this dark (its log stays finite)
# log(R/G) and log(B/G) are held inside the training skins' range: an odd skin reading cannot push r past them
CHROMA_RANGE = ((0.3, 0.9), (-0.8, -0.1))  # the training skins: 0.40-0.81, -0.68 to -0.16


def features(skin: np.ndarray) -> np.ndarray:
    """(3,): 1, the skin's log red over green and log blue over green (each clipped to CHROMA_RANGE)."""
    skin = np.clip(np.nan_to_num(np.asarray(skin, np.float64), posinf=0.0), 1e-4, None)
    red, blue = (float(np.clip(np.log(skin[c] / skin[1]), *bounds)) for c, bounds in zip((0, 2), CHROMA_RANGE))
    return np.array([1.0, red, blue])


def lightness(skin: np.ndarray) -> float:
    """The skin's log luminance, at most 0 (a black skin reads as LUMINANCE_FLOOR)."""
    skin = np.clip(np.nan_to_num(np.asarray(skin, np.float64), posinf=0.0), 0.0, None)
    return min(np.log(max(float(luminance(skin)), LUMINANCE_FLOOR)), 0.0)


def below_knee(skin: np.ndarray) -> float:
    """How far the skin's log luminance lies below DARK_KNEE's (at most 0; 0 for a skin above the knee)."""
    return min(lightness(skin) - np.log(DARK_KNEE), 0.0)


def lips_ratio(skin: np.ndarray) -> np.ndarray:
    """The bare lips over the skin (3,), per channel, for a skin's linear RGB (3,) in the light's own white."""
    return np.exp(RATIO_SLOPE * lightness(skin) + DARK_SLOPE * below_knee(skin) + features(skin) @ COEFFICIENTS)


def bare_lips(skin: np.ndarray) -> np.ndarray:
    """The bare lips' linear RGB (3,) beside a skin's (3,) in the light's own white, under the same light; finite for
    any input (NaN reads as 0, negative as 0)."""
    skin = np.clip(np.nan_to_num(np.asarray(skin, np.float64), posinf=0.0), 0.0, None)
    return skin * lips_ratio(skin)
