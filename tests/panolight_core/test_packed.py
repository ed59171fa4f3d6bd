import numpy as np
import pytest

from panolight_core import threads
from panolight_core.packed import PackedImage, Packer, half_encode, rgbe_decode, rgbe_encode


def _rgbe(rng, shape):
    """Random normalised RGBE pixels (the largest mantissa 128-255), some black."""
    rgbe = rng.integers(0, 256, size=shape + (4,), dtype=np.uint8)
    top = rng.integers(0, 3, size=shape)
    np.put_along_axis(rgbe[..., :3], top[..., None], rng.integers(128, 256, size=shape + (1,), dtype=np.uint8), -1)
    rgbe[..., :3] = np.minimum(rgbe[..., :3], np.take_along_axis(rgbe[..., :3], top[..., None], -1))
    rgbe[..., 3] = rng.integers(100, 180, size=shape)
    rgbe[rng.random(shape) < 0.1] = 0
    return rgbe


def _reference_decode(rgbe):
    """Radiance's definition in float64: (mantissa + 0.5) 2^(e - 136), 0 for e = 0."""
    e = rgbe[..., 3].astype(np.float64)
    return np.where(e[..., None] > 0, (rgbe[..., :3] + 0.5) * np.exp2(e - 136)[..., None], 0.0)


def test_rgbe_decodes_as_radiance_defines_it_and_encodes_back_bit_for_bit(rng):
    rgbe = _rgbe(rng, (64, 128))
    values = rgbe_decode(rgbe)
    assert values.dtype == np.float32
    np.testing.assert_array_equal(values.astype(np.float64), _reference_decode(rgbe))
    code = rgbe_encode(values)
    np.testing.assert_array_equal(code, rgbe)
    np.testing.assert_array_equal(rgbe_decode(code).view(np.int32), values.view(np.int32))


@pytest.mark.parametrize("bad", [-1.0, np.nan, np.inf, 0.3, 1e-39, 1e38])
def test_rgbe_refuses_values_that_are_not_rgbe(rng, bad):
    values = rgbe_decode(_rgbe(rng, (4, 8)))
    values[2, 3, 1] = bad
    assert rgbe_encode(values) is None


def test_half_keeps_exact_values_nan_and_infinities_and_refuses_others():
    values = np.array([[[0.0, 1.5, 65504.0], [np.nan, np.inf, -2.0]]], np.float32)
    np.testing.assert_array_equal(half_encode(values).astype(np.float32), values)
    for bad in (0.1, 1e-8, 70000.0):
        values[0, 0, 0] = bad
        assert half_encode(values) is None


@pytest.mark.parametrize("n_threads", [1, 2])
@pytest.mark.parametrize("bad_block", [None, 0, 3])
def test_packer_packs_or_falls_back_to_float32_with_the_same_values(rng, n_threads, bad_block):
    values = rgbe_decode(_rgbe(rng, (40, 16)))
    if bad_block is not None:
        values[bad_block * 8 + 5, 2, 0] = 0.1  # not an RGBE value
    with threads.limited(n_threads), Packer(40, 16, "rgbe") as packer:
        for r0 in range(0, 40, 8):
            packer.put(r0, values[r0:r0 + 8].copy())
        image = packer.result()
    if bad_block is None:
        assert isinstance(image, PackedImage) and image.nbytes == 40 * 16 * 4
        image = np.asarray(image)
    else:
        assert isinstance(image, np.ndarray) and image.dtype == np.float32
    np.testing.assert_array_equal(image.view(np.int32), values.view(np.int32))


def test_packer_refuses_blocks_out_of_order_and_missing_rows():
    packer = Packer(16, 4, "half")
    with pytest.raises(ValueError, match="in order"):
        packer.put(8, np.zeros((8, 4, 3), np.float32))
    packer.put(0, np.zeros((8, 4, 3), np.float32))
    with pytest.raises(ValueError, match="8 of 16 rows"):
        packer.result()


def test_a_packed_image_reads_like_its_float_array(rng):
    values = rgbe_decode(_rgbe(rng, (32, 64)))
    image = PackedImage(rgbe_encode(values), "rgbe")
    assert image.shape == (32, 64, 3) and image.dtype == np.float32 and len(image) == 32
    np.testing.assert_array_equal(image[5:17], values[5:17])
    np.testing.assert_array_equal(image[..., 5:17, :, :], values[5:17])
    rows, cols = np.array([0, 3, 31]), np.array([63, 0, 7])
    np.testing.assert_array_equal(image[rows, cols], values[rows, cols])
    np.testing.assert_array_equal(np.asarray(image), values)
    wide = image.astype(np.float64)
    assert wide.dtype == np.float64 and wide[0:4].dtype == np.float64
    np.testing.assert_array_equal(wide[0:4], values[0:4].astype(np.float64))
    assert image.peak() == float(values.max())
    assert PackedImage(half_encode(values[..., :3] * 0 + 2.0), "half").peak() == 2.0
    with pytest.raises(TypeError, match="row slices"):
        image[:, 3:5]


@pytest.mark.parametrize("n_threads", [1, 2])
def test_a_packer_that_can_read_the_rows_again_leaves_the_image_in_its_file(rng, n_threads):
    """Given ``reread``, the first block no code holds makes the image a RowFile (``done``: the rest need not be
    read now; with threads, a block or two later), whose rows and gathers are the file's, repaired as its
    validation decides."""
    from panolight_core.packed import RowFile

    values = rng.random((40, 16, 3), dtype=np.float32) + np.float32(0.1)
    values[:8] = 0.5  # the first block fits half floats
    reads = []

    def reread(r0, r1):
        reads.append((r0, r1))
        return values[r0:r1].copy()

    with threads.limited(n_threads), Packer(40, 16, "half", reread) as packer:
        for r0 in range(0, 40, 8):
            packer.put(r0, values[r0:r0 + 8].copy())
            if packer.done:
                break
        image = packer.result()
    assert r0 == (8 if n_threads == 1 else 24) and image.kind == "file" and isinstance(image.store, RowFile) and image.nbytes == 0
    np.testing.assert_array_equal(np.asarray(image), values)
    rows, cols = np.array([39, 0, 300 // 8]), np.array([1, 15, 2])
    np.testing.assert_array_equal(image[rows, cols], values[rows, cols])
    image.store.repair, image.store.top = (7.0, True), 1.5
    values[3, 3] = [np.inf, -1.0, np.nan]
    assert image[3:4][0, 3].tolist() == [7.0, 0.0, 0.0] and image.peak() == 1.5 and reads
