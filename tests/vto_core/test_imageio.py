"""Tests for vto_core.imageio: format round-trips, alpha, errors and atomic writes."""

import os
import subprocess
import sys
import types

import numpy as np
import pytest

from vto_core.errors import VtoError
from vto_core.imageio import read_image, require_finite, write_image

oiio = pytest.importorskip("OpenImageIO")

REPO_ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def _random_rgb(seed, shape=(6, 9, 3)):
    """A reproducible float32 image in [0, 1]."""
    return np.random.default_rng(seed).random(shape).astype(np.float32)


def _smooth_rgb(height=32, width=48):
    """A float32 gradient image that JPEG compresses with little error."""
    rows, columns = np.mgrid[0:height, 0:width].astype(np.float32)
    return np.stack([rows / (height - 1), columns / (width - 1), 0.5 + 0.0 * rows], axis=2)


def _stored_spec(path):
    """The ImageSpec OIIO reports for the file at path."""
    image_input = oiio.ImageInput.open(str(path))
    try:
        return image_input.spec()
    finally:
        image_input.close()


@pytest.mark.parametrize(
    "name, bits, tolerance, stored_format",
    [
        ("image.png", 8, 0.5 / 255, "uint8"),
        ("image.png", 16, 0.5 / 65535, "uint16"),
        ("image.tif", 8, 0.5 / 255, "uint8"),
        ("image.tiff", 16, 0.5 / 65535, "uint16"),
    ],
)
def test_integer_formats_round_trip_within_half_a_step(tmp_path, name, bits, tolerance, stored_format):
    rgb = _random_rgb(0)
    path = write_image(tmp_path / name, rgb, bits=bits)
    assert path == str(tmp_path / name)
    read_rgb, alpha = read_image(path)
    assert read_rgb.dtype == np.float32 and read_rgb.shape == rgb.shape
    assert alpha is None
    assert np.abs(read_rgb - rgb).max() <= tolerance + 1e-7
    assert str(_stored_spec(path).format) == stored_format


def test_png_defaults_to_8_bits_and_rounds_every_code_correctly(tmp_path):
    steps = np.arange(256, dtype=np.float64)
    # Exact codes, half-way values and values just either side of them.
    values = np.concatenate([steps, steps + 0.5, steps + 0.49, steps + 0.51])[None, :] / 255.0
    rgb = np.repeat(np.clip(values, 0, 1)[:, :, None], 3, axis=2).astype(np.float32)
    read_rgb, _ = read_image(write_image(tmp_path / "codes.png", rgb))
    assert str(_stored_spec(tmp_path / "codes.png").format) == "uint8"
    assert np.abs(read_rgb - rgb).max() <= 0.5 / 255 + 1e-6
    codes = np.rint(read_rgb[0, :, 0] * 255.0)
    np.testing.assert_array_equal(codes[:256], steps)
    np.testing.assert_array_equal(codes[512:768], steps)
    np.testing.assert_array_equal(codes[768:], np.minimum(steps + 1, 255))


def test_integer_formats_clip_to_unit_range(tmp_path):
    rgb = np.array([[[-0.5, 1.7, 0.25]]], dtype=np.float32)
    read_rgb, _ = read_image(write_image(tmp_path / "clipped.png", rgb, bits=16))
    assert read_rgb[0, 0, 0] == 0.0
    assert read_rgb[0, 0, 1] == 1.0
    assert read_rgb[0, 0, 2] == pytest.approx(0.25, abs=0.5 / 65535)


def test_jpeg_round_trips_within_compression_tolerance(tmp_path):
    rgb = _smooth_rgb()
    for name in ("image.jpg", "image.jpeg"):
        read_rgb, alpha = read_image(write_image(tmp_path / name, rgb))
        assert alpha is None
        assert read_rgb.shape == rgb.shape
        assert np.abs(read_rgb - rgb).mean() < 0.01
        assert np.abs(read_rgb - rgb).max() < 0.05


@pytest.mark.parametrize("bits, stored_format", [(None, "half"), ("half", "half"), ("float", "float")])
def test_exr_keeps_hdr_and_negative_values(tmp_path, bits, stored_format):
    rgb = _random_rgb(1)
    rgb[0, 0] = [7.5, -2.25, 0.0]
    rgb[1, 2] = [1000.0, -0.125, 3.0]
    path = write_image(tmp_path / "image.exr", rgb, bits=bits)
    read_rgb, alpha = read_image(path)
    assert alpha is None
    assert str(_stored_spec(path).format) == stored_format
    np.testing.assert_array_equal(read_rgb[0, 0], [7.5, -2.25, 0.0])
    np.testing.assert_array_equal(read_rgb[1, 2], [1000.0, -0.125, 3.0])
    if stored_format == "float":
        np.testing.assert_array_equal(read_rgb, rgb)
    else:
        np.testing.assert_allclose(read_rgb, rgb, rtol=1e-3, atol=1e-4)


def test_float_tiff_keeps_hdr_and_negative_values(tmp_path):
    rgb = _random_rgb(2)
    rgb[2, 3] = [7.5, -1.0, 123456.0]
    path = write_image(tmp_path / "image.tif", rgb, bits="float")
    assert str(_stored_spec(path).format) == "float"
    read_rgb, _ = read_image(path)
    np.testing.assert_array_equal(read_rgb, rgb)


@pytest.mark.parametrize(
    "name, bits, tolerance",
    [
        ("alpha.png", 8, 0.5 / 255),
        ("alpha.png", 16, 0.5 / 65535),
        ("alpha.exr", "half", 1e-3),
        ("alpha.exr", "float", 0.0),
        ("alpha.tif", 16, 0.5 / 65535),
    ],
)
def test_alpha_is_returned_separately_and_colour_is_not_premultiplied(tmp_path, name, bits, tolerance):
    rgb = _random_rgb(3)
    alpha = np.random.default_rng(4).random(rgb.shape[:2]).astype(np.float32)
    alpha[0, :] = 0.0  # colour under zero alpha must survive too
    path = write_image(tmp_path / name, rgb, alpha, bits=bits)
    assert _stored_spec(path).nchannels == 4
    read_rgb, read_alpha = read_image(path)
    assert read_rgb.shape == rgb.shape
    assert read_alpha.shape == alpha.shape and read_alpha.dtype == np.float32
    assert np.abs(read_rgb - rgb).max() <= tolerance + 1e-7
    assert np.abs(read_alpha - alpha).max() <= tolerance + 1e-7


def test_gray_png_is_read_as_three_equal_channels(tmp_path):
    gray = _random_rgb(5, (5, 7))
    path = write_image(tmp_path / "gray.png", gray)
    assert _stored_spec(path).nchannels == 1
    read_rgb, alpha = read_image(path)
    assert alpha is None
    assert read_rgb.shape == (5, 7, 3)
    for channel in range(3):
        assert np.abs(read_rgb[:, :, channel] - gray).max() <= 0.5 / 255 + 1e-7


def test_gray_with_alpha_is_two_channels_read_as_rgb_and_alpha(tmp_path):
    gray = _random_rgb(6, (4, 5))
    alpha = _random_rgb(7, (4, 5))
    path = write_image(tmp_path / "gray_alpha.png", gray, alpha, bits=16)
    assert _stored_spec(path).nchannels == 2
    read_rgb, read_alpha = read_image(path)
    assert np.abs(read_rgb - gray[:, :, None]).max() <= 0.5 / 65535 + 1e-7
    assert np.abs(read_alpha - alpha).max() <= 0.5 / 65535 + 1e-7


def test_rows_are_top_first(tmp_path):
    rgb = np.zeros((3, 2, 3), dtype=np.float32)
    rgb[0] = 1.0  # top row white
    path = write_image(tmp_path / "top.png", rgb)
    image_input = oiio.ImageInput.open(path)
    first_scanline = image_input.read_scanline(0, 0, "float")
    image_input.close()
    assert np.all(np.asarray(first_scanline) == 1.0)
    read_rgb, _ = read_image(path)
    np.testing.assert_array_equal(read_rgb, rgb)


def _assert_one_line_read_error(path, expected_text):
    """read_image(path) raises a one-line VtoError naming path and containing expected_text."""
    with pytest.raises(VtoError) as raised:
        read_image(path)
    message = str(raised.value)
    assert str(path) in message
    assert expected_text.lower() in message.lower()
    assert "\n" not in message


def test_missing_file_raises_with_path_and_oiio_error(tmp_path):
    _assert_one_line_read_error(tmp_path / "missing.png", "could not open")


def test_text_file_named_png_raises_with_path_and_oiio_error(tmp_path):
    path = tmp_path / "not_really.png"
    path.write_text("this is not an image\nsecond line\n")
    _assert_one_line_read_error(path, "not a png")


def test_truncated_png_raises_with_path_and_oiio_error(tmp_path):
    path = tmp_path / "truncated.png"
    write_image(path, _random_rgb(8, (64, 64, 3)))
    path.write_bytes(path.read_bytes()[:400])
    # OIIO's multi-line libpng message must arrive collapsed onto one line.
    _assert_one_line_read_error(path, "end of file")


def test_non_finite_values_are_read_as_is_and_require_finite_counts_pixels(tmp_path):
    rgb = _random_rgb(9)
    rgb[0, 0, 0] = np.nan
    rgb[0, 0, 2] = np.inf  # same pixel: still one bad pixel
    rgb[3, 4, 1] = -np.inf
    read_rgb, _ = read_image(write_image(tmp_path / "bad.exr", rgb, bits="float"))
    assert np.isnan(read_rgb[0, 0, 0]) and read_rgb[3, 4, 1] == -np.inf
    with pytest.raises(VtoError, match=r"render target has 2 non-finite"):
        require_finite(read_rgb, "render target")
    with pytest.raises(VtoError, match=r"mask has 1 non-finite"):
        require_finite(np.array([[0.0, np.nan], [1.0, 1.0]]), "mask")
    require_finite(_random_rgb(10), "clean image")


@pytest.mark.parametrize("name, bits", [("nan.png", 8), ("nan.png", 16), ("nan.tif", 8), ("nan.jpg", 8)])
def test_non_finite_data_to_integer_format_raises_and_writes_nothing(tmp_path, name, bits):
    rgb = _random_rgb(11)
    rgb[2, 2, 1] = np.nan
    with pytest.raises(VtoError, match="non-finite"):
        write_image(tmp_path / name, rgb, bits=bits)
    assert os.listdir(tmp_path) == []


def test_non_finite_alpha_to_png_raises(tmp_path):
    alpha = np.ones((6, 9), dtype=np.float32)
    alpha[0, 0] = np.inf
    with pytest.raises(VtoError, match="non-finite"):
        write_image(tmp_path / "alpha.png", _random_rgb(12), alpha)
    assert os.listdir(tmp_path) == []


def test_failed_validation_keeps_the_old_file(tmp_path):
    path = tmp_path / "keep.png"
    write_image(path, _random_rgb(13))
    old_bytes = path.read_bytes()
    broken = _random_rgb(14)
    broken[0, 0, 0] = np.nan
    with pytest.raises(VtoError):
        write_image(path, broken)
    assert path.read_bytes() == old_bytes
    assert os.listdir(tmp_path) == ["keep.png"]


def test_failed_replace_keeps_the_old_file_and_removes_the_temp_file(tmp_path, monkeypatch):
    path = tmp_path / "keep.png"
    write_image(path, _random_rgb(15))
    old_bytes = path.read_bytes()
    temp_paths = []

    def failing_replace(source, destination):
        temp_paths.append(source)
        assert os.path.exists(source)  # the new image was fully written first
        raise OSError("simulated rename failure")

    monkeypatch.setattr(os, "replace", failing_replace)
    with pytest.raises(VtoError, match="simulated rename failure"):
        write_image(path, _random_rgb(16))
    assert path.read_bytes() == old_bytes
    assert os.listdir(tmp_path) == ["keep.png"]
    # The temp file sits beside the target and keeps the real extension last.
    assert os.path.dirname(temp_paths[0]) == str(tmp_path)
    assert temp_paths[0].endswith(".png") and ".tmp-" in temp_paths[0]


def test_failed_pixel_write_keeps_the_old_file_and_removes_the_partial_temp_file(tmp_path, monkeypatch):
    path = tmp_path / "keep.exr"
    write_image(path, _random_rgb(17))
    old_bytes = path.read_bytes()

    class FailingOutput:
        """Opens the real file, then fails to write its pixels."""

        def __init__(self, real_output):
            self.real_output = real_output

        def open(self, filename, spec):
            return self.real_output.open(filename, spec)

        def write_image(self, pixels):
            return False

        def close(self):
            return self.real_output.close()

        def geterror(self):
            return "simulated disk full\nsecond line"

    failing_oiio = types.SimpleNamespace(
        ImageSpec=oiio.ImageSpec,
        geterror=oiio.geterror,
        ImageOutput=types.SimpleNamespace(create=lambda name: FailingOutput(oiio.ImageOutput.create(name))),
    )
    monkeypatch.setitem(sys.modules, "OpenImageIO", failing_oiio)
    with pytest.raises(VtoError, match="simulated disk full; second line"):
        write_image(path, _random_rgb(18))
    assert path.read_bytes() == old_bytes
    assert os.listdir(tmp_path) == ["keep.exr"]


def test_jpeg_with_alpha_raises(tmp_path):
    with pytest.raises(VtoError, match="alpha"):
        write_image(tmp_path / "alpha.jpg", _random_rgb(19), np.ones((6, 9), dtype=np.float32))
    assert os.listdir(tmp_path) == []


@pytest.mark.parametrize("name", ["image.bmp", "image", "image.png.bak"])
def test_unknown_extension_raises(tmp_path, name):
    with pytest.raises(VtoError, match="unknown extension"):
        write_image(tmp_path / name, _random_rgb(20))
    assert os.listdir(tmp_path) == []


@pytest.mark.parametrize(
    "name, bits", [("a.jpg", 16), ("a.png", "half"), ("a.exr", 8), ("a.tif", 32), ("a.png", True)]
)
def test_bits_not_allowed_for_format_raises(tmp_path, name, bits):
    with pytest.raises(VtoError, match="bits"):
        write_image(tmp_path / name, _random_rgb(21), bits=bits)


@pytest.mark.parametrize(
    "rgb, alpha",
    [
        (np.zeros((4, 4, 2)), None),
        (np.zeros((4,)), None),
        (np.zeros((0, 4, 3)), None),
        (np.zeros((4, 4, 3)), np.zeros((4, 5))),
    ],
)
def test_bad_shapes_raise(tmp_path, rgb, alpha):
    with pytest.raises(VtoError, match="shape"):
        write_image(tmp_path / "shape.png", rgb, alpha)


def test_missing_parent_directory_raises(tmp_path):
    with pytest.raises(VtoError, match="does not exist"):
        write_image(tmp_path / "no_such_dir" / "image.png", _random_rgb(22))
    (tmp_path / "a_file").write_text("")
    with pytest.raises(VtoError, match="does not exist"):
        write_image(tmp_path / "a_file" / "image.png", _random_rgb(22))


@pytest.mark.skipif(os.name != "posix" or os.geteuid() == 0, reason="root ignores directory permissions")
def test_unwritable_directory_raises(tmp_path):
    locked = tmp_path / "locked"
    locked.mkdir()
    locked.chmod(0o500)
    try:
        with pytest.raises(VtoError, match="locked"):
            write_image(locked / "image.png", _random_rgb(23))
        assert os.listdir(locked) == []
    finally:
        locked.chmod(0o700)


def test_import_needs_neither_openimageio_nor_blender_nor_torch():
    script = (
        "import sys\n"
        "sys.modules['OpenImageIO'] = None\n"
        "import vto_core.imageio, vto_core.metrics\n"
        "assert 'bpy' not in sys.modules and 'torch' not in sys.modules\n"
    )
    environment = dict(os.environ, PYTHONPATH=REPO_ROOT)
    completed = subprocess.run(
        [sys.executable, "-c", script], env=environment, capture_output=True, text=True
    )
    assert completed.returncode == 0, completed.stderr


@pytest.mark.parametrize("orientation", range(1, 9))
@pytest.mark.parametrize("extension", [".jpg", ".tif"])
def test_each_orientation_is_read_as_a_viewer_shows_it(tmp_path, orientation, extension):
    from PIL import Image, ImageOps

    stored = np.zeros((24, 40, 3), np.float32)
    stored[:8, :8, 0] = 1.0  # a red corner at the stored top left, a green one at the stored top right
    stored[:8, -8:, 1] = 1.0
    path = tmp_path / f"tagged{extension}"
    write_image(path, stored, orientation=orientation)
    shown, _ = read_image(path)
    with Image.open(path) as picture:  # Pillow's exif_transpose: what viewers show
        expected = np.asarray(ImageOps.exif_transpose(picture).convert("RGB"), np.float32) / 255
    assert shown.shape == expected.shape == ((24, 40, 3) if orientation < 5 else (40, 24, 3))
    assert np.abs(shown - expected).max() < 1e-6
    assert np.array_equal(read_image(path, as_shown=False)[0].shape, stored.shape)


def test_an_unreadable_file_names_the_formats_that_are_read(tmp_path):
    path = tmp_path / "photo.heic"
    path.write_bytes(b"\x00\x00\x00\x18ftypheic" + bytes(64))
    with pytest.raises(VtoError) as caught:
        read_image(path)
    message = str(caught.value)
    assert "\n" not in message and "readable: jpeg, png, tiff" in message and "not HEIC/AVIF" in message


@pytest.mark.parametrize("form", ["CMYK JPEG", "palette PNG", "animated GIF"])
def test_photos_saved_as_other_programs_save_them(tmp_path, form):
    """The forms a reference photo arrives in besides RGB JPEG/PNG: CMYK JPEG and palette PNG read as their colours;
    an animated GIF, which this OpenImageIO has no reader for, is one line naming what is read."""
    from PIL import Image

    rgb = _smooth_rgb()
    picture = Image.fromarray(np.rint(rgb * 255).astype(np.uint8))
    if form == "CMYK JPEG":
        path = tmp_path / "print.jpg"
        picture.convert("CMYK").save(path, quality=95)
    elif form == "palette PNG":
        path = tmp_path / "palette.png"
        picture.quantize(256).save(path)
    else:
        path = tmp_path / "moving.gif"
        frames = [picture, Image.fromarray(np.rint(rgb[::-1] * 255).astype(np.uint8))]
        frames[0].save(path, save_all=True, append_images=frames[1:], duration=100, loop=0)
        with pytest.raises(VtoError) as caught:
            read_image(path)
        assert "\n" not in str(caught.value) and "readable: jpeg, png" in str(caught.value)
        return
    read, _ = read_image(path)
    assert read.shape == rgb.shape and np.abs(read - rgb).mean() < 0.02


def test_a_jpeg_round_trip_loses_more_at_lower_quality_and_leaves_no_file(tmp_path):
    from vto_core.imageio import jpeg_round_trip

    y, x = np.mgrid[:40, :48] / 8.0
    image = np.stack([0.5 + 0.3 * np.sin(x + y), 0.5 + 0.3 * np.sin(1.3 * x), 0.4 + 0.2 * np.cos(y)], -1)
    fine, coarse = (np.abs(jpeg_round_trip(image, q, tmp_path) - image).mean() for q in (95, 20))
    assert 0 < fine < 0.01 < coarse and fine < coarse / 3
    assert jpeg_round_trip(image, 95, tmp_path).shape == image.shape and not list(tmp_path.iterdir())


@pytest.mark.parametrize("name, bits", [("tall.png", 8), ("tall.png", 16), ("tall.tif", 8), ("tall.jpg", 8)])
def test_a_tall_image_is_written_a_few_rows_at_a_time_byte_for_byte_as_in_one_write(tmp_path, name, bits):
    """Integer files taller than ROWS_AT_ONCE are quantised and written in parts (no whole-image copies: a 64-megapixel
    photo is 778 MB a float copy); the file is the one a single write makes."""
    from vto_core.imageio import ROWS_AT_ONCE

    rgb = _random_rgb(3, (2 * ROWS_AT_ONCE + 37, 41, 3)) * 1.2 - 0.1
    write_image(tmp_path / name, rgb, bits=bits)
    codes = np.rint(np.clip(rgb, 0.0, 1.0) * (255 if bits == 8 else 65535)).astype(np.uint8 if bits == 8 else np.uint16)
    spec = oiio.ImageSpec(41, rgb.shape[0], 3, "uint8" if bits == 8 else "uint16")
    spec.channelnames = ("R", "G", "B")
    spec.attribute("oiio:UnassociatedAlpha", 1)
    once = tmp_path / f"once{os.path.splitext(name)[1]}"
    output = oiio.ImageOutput.create(str(once))
    assert output.open(str(once), spec) and output.write_image(codes) and output.close()
    assert (tmp_path / name).read_bytes() == once.read_bytes()


@pytest.mark.parametrize("name, bits, dtype", [("a.png", 8, np.uint8), ("a.png", 16, np.uint16), ("a.jpg", 8, np.uint8),
                                               ("a.exr", "half", np.float32), ("a.tif", "float", np.float32)])
def test_stored_integers_turn_into_exactly_the_floats_read_image_gives(tmp_path, name, bits, dtype):
    """read_image(stored=True) keeps an 8- or 16-bit file's integers (a quarter or a half of float32's memory); as_float
    gives the very floats read_image gives. Float files come back as float32 either way."""
    from vto_core.imageio import as_float

    write_image(tmp_path / name, _random_rgb(4, (300, 23, 3)), bits=bits, orientation=6)
    stored, _ = read_image(tmp_path / name, stored=True)
    floats, _ = read_image(tmp_path / name)
    assert stored.dtype == dtype and stored.shape == floats.shape == (23, 300, 3)  # turned as shown
    assert as_float(stored).dtype == np.float32 and np.array_equal(as_float(stored), floats)


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16])
def test_every_stored_integer_turns_into_openimageio_s_float(dtype):
    """as_float's product with one scale gives, for every code of the type, the float OpenImageIO's conversion gives."""
    import OpenImageIO as oiio

    from vto_core.imageio import as_float, float_scale

    codes = np.arange(np.iinfo(dtype).max + 1, dtype=dtype)
    buf = oiio.ImageBuf(oiio.ImageSpec(codes.size, 1, 1, np.dtype(dtype).name))
    buf.set_pixels(oiio.ROI(0, codes.size, 0, 1, 0, 1, 0, 1), codes.reshape(1, -1, 1))
    assert float_scale(dtype) is not None  # the fast path is the one taken
    assert np.array_equal(as_float(codes.reshape(-1, 1, 1)).ravel(), buf.get_pixels(oiio.FLOAT).ravel())
