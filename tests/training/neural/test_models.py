"""The paper's networks: torch modules and the torch-free numpy forward give the same numbers."""
import numpy as np
import pytest
import torch
from safetensors.torch import save_file

from panolight_core import sh
from panolight_core.estimators.nn.model import forward
from panolight_core.io.safetensors_np import load_safetensors
from training.neural.models import LightingNet, load_config


@pytest.mark.parametrize("prior", [True, False])
def test_numpy_forward_matches_torch_to_1e4(tmp_path, rng, prior):
    config = {**load_config("small"), "input_height": 32, "prior": prior}
    torch.manual_seed(0)
    net = LightingNet(config).eval()
    for p in net.ae.out.parameters():  # trained-looking output layer (it starts at zero)
        torch.nn.init.normal_(p, std=0.1)
    ldr = torch.tensor(rng.random((2, 7, 32, 64)), dtype=torch.float32)
    ldr[:, 3] = 0.0
    ldr[:, :4, 5:8, 10:14] = 1.0  # clipped cells exercise the HDR branch
    with torch.no_grad():
        coeffs, hdr = net(ldr)
    save_file({k: v.contiguous() for k, v in net.state_dict().items()}, str(tmp_path / "w.safetensors"))
    weights, _ = load_safetensors(tmp_path / "w.safetensors")  # no torch, no pickle
    c_np, hdr_np = forward(weights, config, ldr.numpy())
    assert coeffs.shape == (2, 9, 3)
    np.testing.assert_allclose(hdr_np, hdr.numpy(), rtol=1e-4, atol=1e-5)
    np.testing.assert_allclose(c_np, coeffs.numpy(), rtol=1e-4, atol=1e-4)


def test_configs_build_and_the_paper_model_is_larger():
    small, paper = LightingNet(load_config("small")), LightingNet(load_config("paper"))
    n = lambda m: sum(p.numel() for p in m.parameters())  # noqa: E731
    assert n(paper) > 10 * n(small)
    out, hdr = small(torch.rand(1, 7, 64, 128))
    assert out.shape == (1, 9, 3) and hdr.shape == (1, 3, 64, 128) and torch.isfinite(out).all()


def test_an_untrained_network_is_the_physical_model_and_training_corrects_only_clipped_cells():
    """hdr = linear(colour) + a * b * exp(y) with y = 0 at start: exactly the highlight model's guess."""
    torch.manual_seed(0)
    net = LightingNet({**load_config("small"), "input_height": 16}).eval()
    x = torch.rand(1, 7, 16, 32) * 0.9
    x[:, 3] = 0.0
    x[:, :4, 4:6, 8:12] = 1.0
    x[:, 4:7] = torch.log(torch.tensor(0.05))
    x[:, 4:7, 4:6, 8:12] = torch.log(torch.tensor(40.0))
    lin = torch.where(x[:, :3] <= 0.04045, x[:, :3] / 12.92, ((x[:, :3] + 0.055) / 1.055) ** 2.4)
    with torch.no_grad():
        coeffs, hdr = net(x)
        torch.testing.assert_close(hdr, lin + x[:, 3:4] * torch.exp(x[:, 4:7]))
        # the residual head starts near 0 (not at it: the spectral prior's norm has no gradient there)
        torch.testing.assert_close(coeffs, sh.project(hdr.permute(0, 2, 3, 1), 2), atol=1e-2, rtol=1e-2)
        for p in net.ae.out.parameters():
            torch.nn.init.normal_(p, std=0.5)
        _, hdr2 = net(x)
    free = x[:, 3:4].expand_as(lin) == 0
    torch.testing.assert_close(hdr2[free], lin[free])
    assert not torch.allclose(hdr2[:, :, 4:6, 8:12], hdr[:, :, 4:6, 8:12])


@pytest.mark.parametrize("prior", [True, False])
def test_the_lighting_head_learns_from_its_first_step(prior):
    torch.manual_seed(0)
    net = LightingNet({**load_config("small"), "input_height": 16, "prior": prior})
    coeffs, _ = net(torch.rand(2, 7, 16, 32))
    (coeffs - 1.0).pow(2).mean().backward()
    assert net.encoder.fc2.weight.grad.abs().max() > 0 and net.encoder.convs[0].conv.weight.grad.abs().max() > 0
