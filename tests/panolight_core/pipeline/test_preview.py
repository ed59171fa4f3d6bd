import numpy as np

from panolight_core import sh
from panolight_core.lighting.adaptive import LightingModel
from panolight_core.pipeline.preview import CAPTION_ROWS, diffuse_sphere, estimate_preview, exposure_for, strip, tonemap

C = CAPTION_ROWS  # the label band above every tile


def test_exposure_puts_the_median_at_18_percent_and_degenerate_images_get_1():
    img = np.full((4, 8, 3), 0.5)
    assert np.isclose(exposure_for(img), 0.36)
    assert exposure_for(np.zeros((4, 8, 3))) == 1.0
    assert exposure_for(np.full((4, 8, 3), np.nan)) == 1.0


def test_tonemap_is_srgb_of_the_clipped_scaled_image():
    img = np.array([[[0.0, 0.5, 4.0]]])
    out = tonemap(img, 0.5)
    assert out.dtype == np.uint8 and out.tolist() == [[[0, 137, 255]]]  # srgb(0.25) = 0.537


def test_diffuse_sphere_of_a_constant_environment_is_uniform():
    c = np.zeros((9, 3))
    c[0] = 2.0 * np.sqrt(4 * np.pi)  # radiance 2 everywhere -> irradiance 2 pi -> shade 0.8 * 2
    img = diffuse_sphere(c, 32)
    inside = img[16, 16]
    assert np.allclose(inside, 1.6, rtol=1e-6)
    assert np.allclose(img[0, 0], 0.8)  # outside: half the sphere's median


def test_a_light_brightens_the_side_of_the_sphere_facing_it():
    lights = [{"type": "sun", "direction": [0.0, -1.0, 0.0], "color": [1, 1, 1], "intensity": 50.0,
               "angle": 0.01}]  # -Y: image right (the camera looks along +X)
    img = diffuse_sphere(LightingModel(lights, np.zeros((1, 3))), 32)
    assert img[16, 28].mean() > 10 * img[16, 3].mean()


def test_preview_strip_layout():
    image = np.random.default_rng(0).random((32, 64, 3))
    coeffs = sh.project(image, 2)
    out = estimate_preview(image, sh.reconstruct(coeffs, 32, 64), coeffs, 2, height=32)
    assert out.dtype == np.uint8 and out.shape == (C + 32, 64 + 4 + 64 + 4 + 32, 3)
    assert (out[:, 64:68] == 255).all()  # white gaps between the tiles
    assert strip([("a", image)], 16).shape == (C + 16, 32, 3)
    assert (out[:C, :64] == 0).any() and (out[:C, :64] > 128).any()  # the label, in its own band


def test_the_sphere_from_the_irradiance_map_matches_the_model():
    lights = [{"type": "sun", "direction": [0.6, -0.48, 0.64], "color": [1, 0.9, 0.8], "intensity": 5.0,
               "angle": 0.02}]
    c = np.zeros((9, 3))
    c[0], c[3] = 1.0, 0.4
    model = LightingModel(lights, c)
    exact = diffuse_sphere(model, 64)
    looked_up = diffuse_sphere(model, 64, irradiance_map=model.irradiance_map(256, 512))
    assert np.abs(looked_up - exact).max() < 0.01 * exact.max()


def test_an_ldr_photo_shows_as_shot_and_the_sh_panel_shares_its_exposure():
    from panolight_core.camera import ldr_to_linear

    rng = np.random.default_rng(1)
    photo = rng.integers(0, 256, (32, 64, 3), dtype=np.uint8)
    radiance = np.full((32, 64, 3), 0.002)
    radiance[17:20] = 0.5  # like a non-negative emitter: a bright band, nearly zero elsewhere (so is the median)
    out = estimate_preview(ldr_to_linear(photo), radiance, np.zeros((9, 3)), 2, height=32, exposure=1.0)
    assert (out[C:, :64] == photo).all()  # below the label band: the photo itself, every row of it
    band = out[C + 21, 68:68 + 64]
    assert (band <= 7).all()  # nearly black stays nearly black
    assert (out[C + 18, 68:68 + 64] == 188).all()  # 0.5 at the photo's exposure: sRGB 188, not clipped white
    # an exposure the model carries (2^exposure_ev) is taken out again: the same picture
    gained = estimate_preview(ldr_to_linear(photo), 4.0 * radiance, np.zeros((9, 3)), 2, height=32, exposure=1.0,
                              model_gain=4.0)
    assert (gained == out).all()
    # HDR input (exposure None): the input's median goes to 0.18, and the SH panel takes the same scale
    hdr = np.full((32, 64, 3), 0.25)
    auto = estimate_preview(hdr, radiance, np.zeros((9, 3)), 2, height=32)
    assert (auto[C + 20, :64] == tonemap(np.array([[[0.18] * 3]]), 1.0)[0, 0]).all()
    assert (auto[C + 18, 68:68 + 64] == tonemap(np.array([[[0.5] * 3]]), 0.18 / 0.25)[0, 0]).all()


def test_the_lights_are_marked_where_they_are():
    from PIL import Image

    from panolight_core.pipeline.preview import mark_lights

    tile = Image.fromarray(np.full((64, 128, 3), 128, dtype=np.uint8))
    mark_lights(tile, [{"direction": [1.0, 0.0, 0.0]}])  # +X: the middle of the panorama, on the horizon
    a = np.asarray(tile).astype(int)
    changed = np.argwhere((a != 128).any(-1))
    ring = changed[changed[:, 1] < 70]  # the ring (radius 4 + 1), without its number to the right
    centre = ring.mean(axis=0)
    assert abs(centre[0] - 32) <= 1 and abs(centre[1] - 64) <= 1
    assert (a[32, 64] == 128).all()  # the light's own pixel stays visible inside the ring
    assert (a == 0).all(-1).any() and (a == 255).all(-1).any()  # black and white: seen on sky and ground


def test_a_recovered_sun_spread_over_the_sh_panel_darkens_it_instead_of_clipping():
    radiance = np.full((32, 64, 3), 1.0)
    radiance[24:] = 4.0  # the brightest quarter: 4 x the clip level
    photo = np.full((32, 64, 3), 0.5)
    out = estimate_preview(photo, radiance, np.zeros((9, 3)), 2, height=32, exposure=1.0)
    assert (out[C + 28, 68:68 + 64] == 255).all()  # the brightest percentile is white
    assert (out[C + 20, 68:68 + 64] == 137).all()  # the clip level at -2 EV: sRGB(0.25), not white


def test_the_preview_numbers_are_lighting_json_indices_and_labels_hide_no_ring(monkeypatch):
    """preview.png numbered the lights by sorted intensity while lights[] is in another order; a ring on the
    top edge hid under the label bar; overlapping rings hid their numbers."""
    from PIL import ImageDraw


    said = []
    real = ImageDraw.ImageDraw.text
    monkeypatch.setattr(ImageDraw.ImageDraw, "text", lambda self, xy, text, **kw: (said.append(text),
                                                                                   real(self, xy, text, **kw)))
    up = [0.1, 0.0, 0.995]  # near the zenith: the top edge of every tile
    lights = [{"type": "sun", "direction": [1.0, 0.0, 0.0], "color": [1, 1, 1], "intensity": 1.0, "angle": 0.01},
              {"type": "sun", "direction": up, "color": [1, 1, 1], "intensity": 9.0, "angle": 0.01}]
    model = LightingModel(lights, np.zeros((9, 3)))
    out = estimate_preview(np.full((64, 128, 3), 0.3), np.full((64, 128, 3), 0.3), model, 2, height=64)
    assert [t for t in said if t in ("0", "1")] == ["0", "1", "0", "1"]  # lights[] order on both panels
    top = out[C:C + 6, :128].astype(int)  # the ring at the zenith, in the picture, not under a label
    assert (top == 0).all(-1).any() and (top == 255).all(-1).any()


def test_labels_of_overlapping_rings_never_cover_each_other_or_a_ring():
    from panolight_core.pipeline.preview import label_boxes

    centres = [(60.0, 30.0), (66.0, 30.0), (63.0, 36.0), (70.0, 25.0)]  # four rings of radius 4 overlapping
    boxes = label_boxes(centres, 4, 256, 128)
    rings = [(x - 5, y - 5, x + 5, y + 5) for x, y in centres]

    def hits(a, b):
        return a[0] < b[2] and b[0] < a[2] and a[1] < b[3] and b[1] < a[3]

    for i, box in enumerate(boxes):
        assert 0 <= box[0] and box[2] < 256 and 0 <= box[1] and box[3] < 128
        assert not any(hits(box, r) for r in rings)
        assert not any(hits(box, o) for j, o in enumerate(boxes) if j != i)
