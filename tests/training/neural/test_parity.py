"""The numpy inference in the core gives the numbers of the torch network it was trained as (training/neural):
its padded convolution, a freshly exported model, and the shipped weights."""
import numpy as np
import pytest
import torch
import torch.nn.functional as F

from panolight_core.estimators import estimate, register_model
from panolight_core.estimators.nn import estimator as E
from panolight_core.estimators.nn.ops import conv2d, pad
from training.neural.losses import equirect_pad
from training.neural.models import LightingNet, load_config
from training.neural.train import export


@pytest.mark.parametrize("stride,padding,mode", [(1, 1, "zeros"), (2, 1, "zeros"), (2, 1, "equirect"), (1, 0, "zeros")])
def test_conv2d_matches_torch(rng, stride, padding, mode):
    x = rng.normal(size=(2, 3, 8, 16)).astype(np.float32)
    w = rng.normal(size=(5, 3, 3, 3)).astype(np.float32)
    b = rng.normal(size=5).astype(np.float32)
    tx = torch.from_numpy(x)
    if mode == "equirect":
        ref = F.conv2d(equirect_pad(tx, padding), torch.from_numpy(w), torch.from_numpy(b), stride=stride)
    else:
        ref = F.conv2d(tx, torch.from_numpy(w), torch.from_numpy(b), stride=stride, padding=padding)
    np.testing.assert_allclose(conv2d(x, w, b, stride, padding, mode), ref.numpy(), atol=1e-5)
    np.testing.assert_allclose(pad(x, 1, "equirect")[..., 1:-1, 0], x[..., :, -1])  # wraps around the seam


def test_numpy_inference_matches_torch(tmp_path, rng):

    cfg = {**load_config("small"), "input_height": 16}
    torch.manual_seed(1)
    net = LightingNet(cfg).eval()
    for p in net.parameters():
        torch.nn.init.normal_(p, std=0.05)
    export(net, cfg, tmp_path)
    ldr = rng.integers(0, 256, size=(64, 128, 3), dtype=np.uint8)
    ldr[10:14, 20:30] = 255
    from panolight_core.estimators.nn.inputs import network_input

    with torch.no_grad():
        ref, _ = net(torch.from_numpy(network_input(ldr, 16)[None]))
    register_model("tmp-model", tmp_path / "model.safetensors")
    got = estimate(ldr, 2, "tmp-model").coeffs
    np.testing.assert_allclose(got, ref[0].double().numpy(), rtol=1e-4, atol=1e-4)


def test_the_shipped_weights_give_torch_s_numbers_in_numpy():
    from safetensors.torch import load_file

    from panolight_core.camera import hdr_to_ldr
    from panolight_core.estimators.nn.inputs import network_input
    from panolight_core.estimators.nn.model import forward

    model = E.load_model()
    net = LightingNet(model.config).eval()
    net.load_state_dict(load_file(str(E.DEFAULT_WEIGHTS)))
    h = model.config["input_height"]
    sky = np.full((h, 2 * h, 3), 0.3)
    sky[h // 5:h // 5 + 3, h // 2:h // 2 + 3] = 500.0  # a clipped sun
    x = network_input(hdr_to_ldr(sky, scale=1.0), h, model.config.get("guess", "analytic"))
    with torch.no_grad():
        ref, ref_hdr = net(torch.from_numpy(x[None]))
    got, got_hdr = forward(model.weights, model.config, x[None])
    np.testing.assert_allclose(got, ref.numpy(), rtol=1e-4, atol=1e-4)
    np.testing.assert_allclose(got_hdr, ref_hdr.numpy(), rtol=1e-4, atol=1e-4)
