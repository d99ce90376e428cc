"""The bare lips under a lipstick, from the skin beside them: what a photo fit in the photo's own scene puts under
the layer (a made-up photo does not show its bare lips).

Lips are skin with more blood under it: per channel, bare lips = skin x r, with log r linear in the skin's log
luminance (darker skins have lips nearer their skin's colour, or lighter). Both colours are linear RGB under the same
light, so r does not depend on the light's colour. RATIO_SLOPE and RATIO_AT_1 were fitted by least squares on the
87 training faces of data/faces that wear no lipstick (the 64 px lips frame, the skin around the lips as
vto_core.appearance.skin_colour reads it): `python -m benchmarks.bench_bare_lips` refits them and reports the error
on the faces no fit saw.

Shapes: colours (3,) linear RGB.
"""

from __future__ import annotations

import numpy as np

from ..colour import luminance

RATIO_SLOPE = np.array([-0.097, -0.123, -0.144])  # d log r / d log(skin luminance), per channel
RATIO_AT_1 = np.array([-0.136, -0.327, -0.248])  # log r at skin luminance 1
LUMINANCE_FLOOR = 1e-3  # a black skin reads as this dark (its log stays finite)


def lips_ratio(skin: np.ndarray) -> np.ndarray:
    """The bare lips over the skin (3,), per channel, for a skin's linear RGB (3,)."""
    lightness = np.log(max(float(luminance(np.nan_to_num(np.asarray(skin, np.float64)))), LUMINANCE_FLOOR))
    return np.exp(RATIO_SLOPE * min(lightness, 0.0) + RATIO_AT_1)


def bare_lips(skin: np.ndarray) -> np.ndarray:
    """The bare lips' linear RGB (3,) beside a skin's (3,), under the same light; finite for any input (NaN reads as
    0, negative as 0)."""
    skin = np.clip(np.nan_to_num(np.asarray(skin, np.float64), posinf=0.0), 0.0, None)
    return skin * lips_ratio(skin)
