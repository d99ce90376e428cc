"""Photos the vto_core tests share: the two public-domain portraits that ship in packages."""

import numpy as np
import pytest


@pytest.fixture(scope="module")
def astronaut():
    from skimage import data

    return data.astronaut().astype(np.float32) / 255


@pytest.fixture(scope="module")
def hopper():
    import matplotlib.cbook
    from PIL import Image

    with matplotlib.cbook.get_sample_data("grace_hopper.jpg") as handle:
        return np.asarray(Image.open(handle).convert("RGB"), np.float32) / 255
