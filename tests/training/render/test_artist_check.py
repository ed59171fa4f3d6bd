import numpy as np

from panolight_core.lighting.adaptive import LightingModel
from training.render import artist_check as A


def test_plane_ratio_is_the_direct_light_over_the_sky():
    coeffs = np.zeros((9, 3))
    coeffs[0] = 1.0  # a uniform sky of radiance 1 / sqrt(4 pi): pi times that on a plane, sqrt(pi) / 2
    sun = {"type": "sun", "direction": [0.0, 0.6, 0.8], "intensity": 3.0, "color": [1.0, 1.0, 1.0], "angle": 0.01}
    below = dict(sun, direction=[0.0, 0.6, -0.8])  # below the horizon: never in the plane's light
    lit, shadow, ratio = A.plane_ratio(LightingModel([sun, below], coeffs, {}))
    sky = np.sqrt(np.pi) / 2
    np.testing.assert_allclose([lit, shadow, ratio], [sky + 2.4, sky, (sky + 2.4) / sky], rtol=1e-9)
    d, kind = A.key_direction(LightingModel([sun], coeffs, {}))
    assert kind == "sun" and np.allclose(d, sun["direction"])
    coeffs[3] = 0.5  # band 1, m = 1: brighter towards +X
    d, kind = A.key_direction(LightingModel([], coeffs, {}))
    assert kind == "SH" and np.allclose(d, [1.0, 0.0, 0.0])


def test_a_photo_with_a_sun_gets_a_sphere_with_a_shadow(tmp_path):
    from PIL import Image

    from panolight_core import sh

    dirs = sh.pixel_directions(128, 256)
    img = np.full((128, 256, 3), 140, np.uint8)
    img[dirs[..., 2] < 0] = 90  # ground
    img[dirs @ np.array([0.0, 0.8, 0.6]) > np.cos(np.radians(4))] = 255  # a clipped sun
    photo = tmp_path / "sunny.jpg"
    Image.fromarray(img).save(photo, quality=95)
    result = A.check(photo, ["auto"], spp=4, size=(48, 36))
    report = A.write([result], tmp_path / "out")
    e = result["estimates"][0]
    assert e["key"] in ("sun", "area") and e["plane_ratio"] > 1.05 and np.isfinite(e["rendered_ratio"])
    assert e["facing_contrast"] > 1.0 and f"| {e['facing_contrast']:.2f} |" in report.read_text()
    assert (tmp_path / "out" / "sunny.png").is_file() and "sunny.jpg" in report.read_text()


def test_a_key_light_kept_below_its_evidence_is_also_shown_raised(tmp_path, monkeypatch):
    """Where the key light's 68 % range starts above its strength, the check renders it again at the range's low
    end, estimated again with --sun-strength as the note advises: a harder shadow, and the note that says so."""
    from PIL import Image

    from panolight_core import sh

    dirs = sh.pixel_directions(128, 256)
    img = np.full((128, 256, 3), 140, np.uint8)
    img[dirs[..., 2] < 0] = 90
    img[dirs @ np.array([0.0, 0.8, 0.6]) > np.cos(np.radians(4))] = 255
    photo = tmp_path / "sunny.jpg"
    Image.fromarray(img).save(photo, quality=95)

    def kept_below(doc):  # the brightest light, as if capped at a third of its evidence
        i = max(range(len(doc["lights"])), key=lambda j: doc["lights"][j]["intensity"])
        return {"index": i, "source": "test", "elevation_deg": 37.0, "low": 3.0, "high": 12.0}

    monkeypatch.setattr(A, "key_light_range", kept_below)
    monkeypatch.setattr(A, "key_light_note", lambda doc: "kept below its evidence")
    result = A.check(photo, ["auto"], spp=4, size=(48, 36))
    plain, raised = result["estimates"]
    assert raised["estimator"] == "auto, --sun-strength 3" and plain["note"] == "kept below its evidence"
    assert raised["plane_ratio"] > plain["plane_ratio"] > 1.0
    report = A.write([result], tmp_path / "out").read_text()
    assert "`auto`: kept below its evidence" in report and "auto, --sun-strength 3" in report


def test_the_photos_own_ground_ratio_is_read_through_the_cameras_curve(monkeypatch):
    """Two flat patches of known 8-bit values: the ratio is their sRGB-linear luminances' ratio, whatever the
    photo's size, and a photo without picked patches has none."""
    from panolight_core.camera import ldr_to_linear

    px = np.full((400, 800, 3), 60, np.uint8)
    px[100:200, 100:300] = 220  # sunlit
    px[250:350, 400:600] = 120  # shadowed
    monkeypatch.setitem(A.PHOTO_GROUND, "p.jpg", ((0.3, 0.45, 0.15, 0.35), (0.65, 0.85, 0.52, 0.73)))
    want = float(ldr_to_linear(np.uint8([[[220, 220, 220]]])).mean() / ldr_to_linear(np.uint8([[[120, 120, 120]]])).mean())
    assert 3.0 < want < 4.0
    np.testing.assert_allclose(A.photo_ratio("p.jpg", px), want, rtol=1e-6)  # float32 linear values
    assert A.photo_ratio("other.jpg", px) is None
    assert abs(A.photo_ratio("building.jpg", np.full((64, 128, 3), 99, np.uint8)) - 1.0) < 1e-9  # the shipped boxes
