import numpy as np
import pytest
import torch
import torch.nn.functional as F

from panolight_core.errors import PanoLightError
from panolight_core.estimators.nn.ops import elu, linear, upsample_nearest2x
from panolight_core.estimators.nn.prior import spectral_prior
from panolight_core.io.safetensors_np import load_safetensors


def test_spectral_prior_numpy_and_torch_agree_and_are_safe(rng):
    c = rng.normal(size=(2, 9, 3))
    out = spectral_prior(c)
    # the magnitude ||L|| is reapplied to a softmax (which sums to 1): each channel sums to ||L||, all positive
    np.testing.assert_allclose(out.sum(axis=-2), np.linalg.norm(c, axis=-2), rtol=1e-12)
    assert np.all(out > 0)
    t = spectral_prior(torch.tensor(c))
    np.testing.assert_allclose(t.numpy(), out, atol=1e-12)
    huge = spectral_prior(np.full((9, 3), 1e300) * np.arange(1, 10)[:, None])
    assert np.all(np.isfinite(huge))
    assert np.all(spectral_prior(np.zeros((9, 3))) == 0)
    x = torch.tensor(c, requires_grad=True)
    assert torch.autograd.gradcheck(spectral_prior, (x,))


def test_elu_linear_upsample_match_torch(rng):
    x = (rng.normal(size=(4, 7)) * 30).astype(np.float32)
    np.testing.assert_allclose(elu(x), F.elu(torch.from_numpy(x)).numpy(), atol=1e-6)
    assert np.all(np.isfinite(elu(np.array([1e30, -1e30], np.float32))))
    w, b = rng.normal(size=(3, 7)).astype(np.float32), rng.normal(size=3).astype(np.float32)
    np.testing.assert_allclose(linear(x, w, b), F.linear(*(torch.from_numpy(a) for a in (x, w, b))).numpy(),
                               rtol=1e-5, atol=1e-4)
    img = rng.normal(size=(1, 2, 3, 4)).astype(np.float32)
    ref = F.interpolate(torch.from_numpy(img), scale_factor=2, mode="nearest").numpy()
    np.testing.assert_array_equal(upsample_nearest2x(img), ref)


def test_safetensors_reader_matches_the_library_and_refuses_damage(tmp_path, rng):
    from safetensors.numpy import save_file

    tensors = {"conv.weight": rng.normal(size=(4, 3, 3, 3)).astype(np.float32),
               "fc.bias": rng.normal(size=5).astype(np.float16), "steps": np.array([7], np.int64)}
    save_file(tensors, tmp_path / "w.safetensors", metadata={"config": "small"})
    got, meta = load_safetensors(tmp_path / "w.safetensors")
    assert meta == {"config": "small"} and set(got) == set(tensors)
    for k, v in tensors.items():
        np.testing.assert_array_equal(got[k], v)
        assert got[k].dtype == v.dtype
    data = (tmp_path / "w.safetensors").read_bytes()
    (tmp_path / "cut.safetensors").write_bytes(data[:-10])
    with pytest.raises(PanoLightError, match="cut.safetensors: tensor .* truncated"):
        load_safetensors(tmp_path / "cut.safetensors")
    (tmp_path / "junk.safetensors").write_bytes(b"\xff" * 64)
    with pytest.raises(PanoLightError, match="not a safetensors file"):
        load_safetensors(tmp_path / "junk.safetensors")
    with pytest.raises(PanoLightError, match="cannot read weights"):
        load_safetensors(tmp_path / "absent.safetensors")


@pytest.mark.parametrize("header", [b"[1, 2]", b'{"w": 3}', b'{"w": {"dtype": "F32"}}',
                                    b'{"w": {"dtype": "F32", "shape": "2", "data_offsets": [0, 8]}}',
                                    b'{"w": {"dtype": 5, "shape": [2], "data_offsets": [0, 8]}}',
                                    b'{"__metadata__": {"a": 1}}'])
def test_malformed_safetensors_headers_get_one_line(tmp_path, header):
    import struct

    from panolight_core.errors import PanoLightError
    from panolight_core.io.safetensors_np import load_safetensors

    path = tmp_path / "bad.safetensors"
    path.write_bytes(struct.pack("<Q", len(header)) + header + b"\0" * 8)
    with pytest.raises(PanoLightError, match="bad.safetensors: "):
        load_safetensors(path)
