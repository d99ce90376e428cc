"""Read and write images through OpenImageIO as float32 numpy arrays.

Arrays are (H, W, C) row-major with the top row first, OIIO's convention.
Colour is RGB with alpha kept in a separate (H, W) array, and values are
exactly as stored in the file: nothing is premultiplied or un-premultiplied.
OpenImageIO is imported inside the functions so that importing this module
never requires it.
"""

import contextlib
import os
import uuid

import numpy as np

from vto_core.errors import VtoError

# Allowed `bits` per extension; the first entry is the default.
_BITS_BY_EXTENSION = {
    ".png": (8, 16),
    ".jpg": (8,),
    ".jpeg": (8,),
    ".exr": ("half", "float"),
    ".tif": (8, 16, "float"),
    ".tiff": (8, 16, "float"),
}
_OIIO_TYPE_BY_BITS = {8: "uint8", 16: "uint16", "half": "half", "float": "float"}
_NUMPY_INT_TYPE_BY_BITS = {8: np.uint8, 16: np.uint16}
_CHANNEL_NAMES_BY_COUNT = {
    1: ("Y",),
    2: ("Y", "A"),
    3: ("R", "G", "B"),
    4: ("R", "G", "B", "A"),
}


def _one_line(message):
    """Join the non-empty lines of an OIIO error message with '; '."""
    lines = [line.strip() for line in str(message).splitlines()]
    return "; ".join(line for line in lines if line) or "unknown error"


# The formats named first when a file cannot be read (OpenImageIO's names), and the phone formats looked for.
_COMMON_FORMATS = ("jpeg", "png", "tiff", "openexr", "webp", "bmp", "targa", "psd", "hdr")
_PHONE_FORMATS = {"heif": "HEIC/AVIF"}


def readable_formats():
    """What this OpenImageIO reads, in one phrase: 'jpeg, png, tiff, ... (not HEIC/AVIF)'."""
    import OpenImageIO as oiio

    names = [name for name in oiio.get_string_attribute("format_list").split(",") if name not in ("null", "term")]
    listed = [name for name in _COMMON_FORMATS if name in names] + [n for n in names if n not in _COMMON_FORMATS]
    missing = [label for name, label in _PHONE_FORMATS.items() if name not in names]
    return ", ".join(listed) + (f" (not {', '.join(missing)}: export those to JPEG or PNG)" if missing else "")


def upright(pixels, orientation):
    """(H, W, C) as stored -> as a viewer shows it, for an EXIF/TIFF Orientation tag 1-8 (others: as stored).

    The tag says where the stored 0th row and 0th column lie when viewed (TIFF 6.0): 2 mirrored, 3 turned 180,
    4 flipped, 5 transposed, 6 turned 90 clockwise, 7 transversed, 8 turned 90 anticlockwise. (OpenImageIO 3.0's
    ImageBufAlgo.reorient swaps 5 and 7 against this and against Pillow's exif_transpose, so it is not used.)"""
    if orientation == 2:
        pixels = pixels[:, ::-1]
    elif orientation == 3:
        pixels = pixels[::-1, ::-1]
    elif orientation == 4:
        pixels = pixels[::-1]
    elif orientation == 5:
        pixels = pixels.swapaxes(0, 1)
    elif orientation == 6:
        pixels = np.rot90(pixels, -1)
    elif orientation == 7:
        pixels = pixels[::-1, ::-1].swapaxes(0, 1)
    elif orientation == 8:
        pixels = np.rot90(pixels, 1)
    return np.ascontiguousarray(pixels)


def orientation_of(path):
    """The Orientation tag (1-8; 1 when absent or unreadable) of the image file at `path`."""
    import OpenImageIO as oiio

    image_input = oiio.ImageInput.open(os.fspath(path))
    if image_input is None:
        oiio.geterror()
        return 1
    try:
        return image_input.spec().get_int_attribute("Orientation", 1)
    finally:
        image_input.close()


def read_image(path, as_shown=True, stored=False):
    """Read the first subimage of `path` as (rgb (H,W,3) float32, alpha (H,W) float32 or None).

    as_shown: turned as a viewer shows it (its EXIF/TIFF orientation applied, see `upright`); False: as stored.
    stored: an 8- or 16-bit file comes back as its integers (uint8, uint16: a quarter or a half of float32's memory;
    `as_float` turns them into exactly what stored=False gives); other files as float32 all the same."""
    import OpenImageIO as oiio

    path = os.fspath(path)
    oiio.geterror()  # drop any stale error left by an earlier call
    config = oiio.ImageSpec()
    # Without this OIIO premultiplies straight-alpha files (PNG) on read.
    config.attribute("oiio:UnassociatedAlpha", 1)
    image_input = oiio.ImageInput.open(path, config)
    if image_input is None:
        reason = _one_line(oiio.geterror())
        if "could not find a format reader" in reason:
            reason = f"not a format that can be read here; readable: {readable_formats()}"
        raise VtoError(f"cannot read image {path}: {reason}")
    try:
        spec = image_input.spec()
        orientation = spec.get_int_attribute("Orientation", 1) if as_shown else 1
        channel_count = spec.nchannels
        if channel_count not in (1, 2, 3, 4) or spec.depth > 1:
            raise VtoError(
                f"cannot read image {path}: {channel_count} channels and depth {spec.depth}, "
                "expected a flat image with 1 to 4 channels"
            )
        # Integer formats are normalised to [0, 1] by OIIO's float conversion;
        # float formats come back as stored.
        kind = _STORED_INTEGERS.get(str(spec.format)) if stored and not spec.channelformats else None
        pixels = image_input.read_image(0, 0, 0, channel_count, kind or "float")
        if pixels is None:
            reason = image_input.geterror() or oiio.geterror()
            raise VtoError(f"cannot read image {path}: {_one_line(reason)}")
    finally:
        image_input.close()

    pixels = np.asarray(pixels, dtype=np.dtype(kind) if kind else np.float32)
    if channel_count in (1, 2):
        rgb = np.repeat(pixels[:, :, :1], 3, axis=2)
    else:
        rgb = pixels[:, :, :3]
    alpha = pixels[:, :, channel_count - 1] if channel_count in (2, 4) else None
    rgb, alpha = upright(rgb, orientation), None if alpha is None else upright(alpha, orientation)
    return rgb, alpha


_STORED_INTEGERS = {"uint8": "uint8", "uint16": "uint16"}  # OIIO's format names -> read_image(stored=True)'s dtype
ROWS_AT_ONCE = 256  # rows of a large image converted at a time, so that no whole-image temporary is made


def float_table(dtype):
    """(2^bits,) float32: what OpenImageIO's float conversion gives each value of an 8- or 16-bit integer type."""
    import OpenImageIO as oiio

    dtype = np.dtype(dtype)
    cached = _FLOAT_TABLES.get(dtype.str)
    if cached is None:
        codes = np.arange(np.iinfo(dtype).max + 1, dtype=dtype)
        buf = oiio.ImageBuf(oiio.ImageSpec(codes.size, 1, 1, dtype.name))
        buf.set_pixels(oiio.ROI(0, codes.size, 0, 1, 0, 1, 0, 1), codes.reshape(1, -1, 1))
        cached = np.ascontiguousarray(buf.get_pixels(oiio.FLOAT).reshape(-1), np.float32)
        cached.flags.writeable = False
        _FLOAT_TABLES[dtype.str] = cached
    return cached


_FLOAT_TABLES = {}


def as_float(pixels):
    """read_image(stored=True)'s pixels -> float32 exactly as read_image gives them (uint8 and uint16 through
    OpenImageIO's own conversion, a few rows at a time); float pixels as float32 (no copy where they are already)."""
    pixels = np.asarray(pixels)
    if pixels.dtype not in (np.uint8, np.uint16):
        return np.asarray(pixels, np.float32)
    table, scale = float_table(pixels.dtype), float_scale(pixels.dtype)
    out = np.empty(pixels.shape, np.float32)
    for start in range(0, max(1, pixels.shape[0]), ROWS_AT_ONCE):
        rows = slice(start, start + ROWS_AT_ONCE)
        if scale is None:
            np.take(table, pixels[rows], out=out[rows])
        else:  # the same floats, five times faster than a lookup
            np.multiply(pixels[rows], scale, out=out[rows], dtype=np.float32)
    return out


def float_scale(dtype):
    """The float32 s with float_table(dtype) == codes * s for every code (OpenImageIO's conversion is that product), or
    None where it is not."""
    dtype = np.dtype(dtype)
    if dtype.str not in _FLOAT_SCALES:
        table = float_table(dtype)
        scale = np.float32(1.0) / np.float32(table.size - 1)
        codes = np.arange(table.size, dtype=np.float32)
        _FLOAT_SCALES[dtype.str] = scale if np.array_equal(codes * scale, table) else None
    return _FLOAT_SCALES[dtype.str]


_FLOAT_SCALES = {}


def require_finite(image, what):
    """Raise VtoError naming `what` if `image` (H,W) or (H,W,C) holds any NaN or inf pixel."""
    image = np.asarray(image)
    bad_pixel_count = 0
    for start in range(0, max(1, image.shape[0] if image.ndim else 1), ROWS_AT_ONCE):  # no whole-image temporaries
        bad = ~np.isfinite(image[start:start + ROWS_AT_ONCE] if image.ndim else image)
        if image.ndim == 3:
            bad = bad.any(axis=2)
        bad_pixel_count += int(np.count_nonzero(bad))
    if bad_pixel_count:
        raise VtoError(f"{what} has {bad_pixel_count} non-finite (NaN or inf) pixel(s)")


def _validated_pixels(path, rgb, alpha, bits):
    """Check the arguments of write_image and return (pixels (H,W,C) float32, bits)."""
    extension = os.path.splitext(path)[1].lower()
    allowed_bits = _BITS_BY_EXTENSION.get(extension)
    if allowed_bits is None:
        known = ", ".join(sorted(_BITS_BY_EXTENSION))
        raise VtoError(f"cannot write image {path}: unknown extension {extension!r} (known: {known})")
    if bits is None:
        bits = allowed_bits[0]
    if isinstance(bits, bool) or bits not in allowed_bits:
        raise VtoError(
            f"cannot write image {path}: bits={bits!r} not allowed for {extension}, use one of {allowed_bits}"
        )
    if alpha is not None and extension in (".jpg", ".jpeg"):
        raise VtoError(f"cannot write image {path}: JPEG cannot store alpha")

    rgb = np.asarray(rgb, dtype=np.float32)
    if rgb.ndim == 2:
        rgb = rgb[:, :, np.newaxis]
    if rgb.ndim != 3 or rgb.shape[2] not in (1, 3) or rgb.shape[0] == 0 or rgb.shape[1] == 0:
        raise VtoError(f"cannot write image {path}: rgb has shape {rgb.shape}, expected (H,W,3) or (H,W)")
    pixels = rgb  # without alpha: the caller's pixels themselves, not a copy (a 64-megapixel photo is 768 MB)
    if alpha is not None:
        alpha = np.asarray(alpha, dtype=np.float32)
        if alpha.shape != rgb.shape[:2]:
            raise VtoError(
                f"cannot write image {path}: alpha has shape {alpha.shape}, expected {rgb.shape[:2]}"
            )
        pixels = np.concatenate([rgb, alpha[:, :, np.newaxis]], axis=2)

    if bits in _NUMPY_INT_TYPE_BY_BITS:
        require_finite(pixels, f"image data for {path}")
    return pixels, bits


def _quantised(pixels, bits):
    """Return float pixels (H,W,C) as stored for `bits`: clipped and rounded integers, or float32."""
    int_type = _NUMPY_INT_TYPE_BY_BITS.get(bits)
    if int_type is None:
        return np.ascontiguousarray(pixels, dtype=np.float32)
    max_code = np.iinfo(int_type).max
    return np.rint(np.clip(pixels, 0.0, 1.0) * max_code).astype(int_type)


def _write_pixels(image_output, pixels, bits):
    """Write float pixels (H,W,C) through an open ImageOutput as stored for `bits`; an integer file taller than
    ROWS_AT_ONCE a few rows at a time, so no whole-image integer or float temporary is made. True where written."""
    height = pixels.shape[0]
    if bits not in _NUMPY_INT_TYPE_BY_BITS or height <= ROWS_AT_ONCE:
        return image_output.write_image(_quantised(pixels, bits))
    for start in range(0, height, ROWS_AT_ONCE):
        end = min(height, start + ROWS_AT_ONCE)
        if not image_output.write_scanlines(start, end, 0, _quantised(pixels[start:end], bits)):
            return False
    return True


def write_image(path, rgb, alpha=None, bits=None, orientation=1):
    """Write rgb (H,W,3) or gray (H,W) and optional alpha (H,W) atomically to `path`; return the path.

    The format comes from the extension: .png (bits 8 or 16), .jpg/.jpeg (8,
    no alpha), .exr ('half' or 'float'), .tif/.tiff (8, 16 or 'float'); the
    first listed is the default.  Integer formats clip to [0, 1] and refuse
    NaN/inf.  orientation: the EXIF/TIFF Orientation tag (1-8) stored with
    the pixels, which are written as given (a phone's sideways photo).  The
    data go to a temporary file beside `path` that replaces it only once
    complete, so a failed write leaves `path` untouched.
    """
    import OpenImageIO as oiio

    path = os.fspath(path)
    pixels, bits = _validated_pixels(path, rgb, alpha, bits)
    parent = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(parent):
        raise VtoError(f"cannot write image {path}: directory {parent} does not exist")

    height, width, channel_count = pixels.shape
    spec = oiio.ImageSpec(width, height, channel_count, _OIIO_TYPE_BY_BITS[bits])
    spec.channelnames = _CHANNEL_NAMES_BY_COUNT[channel_count]
    spec.alpha_channel = channel_count - 1 if alpha is not None else -1
    # Without this OIIO un-premultiplies colour before writing straight-alpha formats (PNG).
    spec.attribute("oiio:UnassociatedAlpha", 1)
    if orientation != 1:
        spec.attribute("Orientation", int(orientation))

    # Keep the real extension last so OIIO picks the format from the temp name.
    stem, extension = os.path.splitext(path)
    temp_path = f"{stem}.tmp-{os.getpid()}-{uuid.uuid4().hex[:8]}{extension}"
    try:
        oiio.geterror()  # drop any stale error left by an earlier call
        image_output = oiio.ImageOutput.create(temp_path)
        if image_output is None:
            raise VtoError(f"cannot write image {path}: {_one_line(oiio.geterror())}")
        if not image_output.open(temp_path, spec):
            raise VtoError(f"cannot write image {path}: {_one_line(image_output.geterror())}")
        written = _write_pixels(image_output, pixels, bits)
        closed = image_output.close()
        if not (written and closed):
            raise VtoError(f"cannot write image {path}: {_one_line(image_output.geterror())}")
        try:
            os.replace(temp_path, path)
        except OSError as error:
            raise VtoError(f"cannot write image {path}: {error}") from error
    except BaseException:
        with contextlib.suppress(OSError):
            os.remove(temp_path)
        raise
    return path


def jpeg_round_trip(image, quality, folder):
    """(H, W, 3) display in [0, 1] -> the same after a JPEG at `quality` (1-100, 4:2:0 as cameras write), float32;
    the file lives in `folder` only while it is read back."""
    import OpenImageIO as oiio

    path = os.path.join(os.fspath(folder), f"round-trip-{os.getpid()}-{uuid.uuid4().hex[:8]}.jpg")
    pixels = np.clip(np.nan_to_num(np.asarray(image, np.float32)) * 255 + 0.5, 0, 255).astype(np.uint8)
    spec = oiio.ImageSpec(pixels.shape[1], pixels.shape[0], 3, oiio.UINT8)
    spec.attribute("compression", f"jpeg:{int(quality)}")
    output = oiio.ImageOutput.create(path)
    try:
        if output is None or not output.open(path, spec) or not output.write_image(pixels):
            raise VtoError(f"cannot write a JPEG in {folder}: {_one_line(oiio.geterror())}")
        output.close()
        return read_image(path, as_shown=False)[0]
    finally:
        if os.path.exists(path):
            os.remove(path)


def resize(image, height, width):
    """Area-filtered resize through OpenImageIO: (H, W, C) float -> (height, width, C) float32."""
    import OpenImageIO as oiio

    image = np.ascontiguousarray(image, dtype=np.float32)
    if image.ndim == 2:
        return resize(image[..., None], height, width)[..., 0]
    source = oiio.ImageBuf(image)
    resized = oiio.ImageBufAlgo.resize(source, roi=oiio.ROI(0, width, 0, height, 0, 1, 0, image.shape[2]))
    if resized.has_error:
        raise VtoError(f"resize failed: {_one_line(resized.geterror())}")
    return resized.get_pixels(oiio.FLOAT).reshape(height, width, image.shape[2])
