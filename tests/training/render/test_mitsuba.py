"""Mitsuba renders compared with numbers: texel convention, camera, orientation, energy, figure."""
import math

import numpy as np
import pytest

from panolight_core import sh
from panolight_core.camera.resample import sample_equirect
from panolight_core.errors import PanoLightError
from training.render import mitsuba as mr

mi = mr.mitsuba()


def _smooth_sh(seed=0, lmax=3):
    c = np.random.default_rng(seed).normal(size=((lmax + 1) ** 2, 3)) * 0.3
    c[0] += 6.0  # keeps the radiance positive everywhere (no clamping in the envmap)
    assert sh.min_over_grid(c).min() > 0
    return c


def test_envmap_texels_follow_the_conventions():
    c = _smooth_sh()
    em = mi.load_dict(mr.scene_emitters(c, [], 128)["env"])
    d = np.random.default_rng(1).normal(size=(100, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    got = []
    for v in d:
        si = mi.SurfaceInteraction3f()
        si.wi = mi.Vector3f(*(float(x) for x in -v))
        got.append(np.array(em.eval(si)).ravel()[:3])
    ref = sh.basis(d, 3) @ c
    assert np.abs(np.array(got) - ref).max() < 2e-3 * ref.mean()


def test_a_ringing_sh_envmap_holds_no_negative_light_and_the_same_diffuse_lighting():
    """Issue 23: the envmap clamped negative SH radiance to 0, which adds light."""
    c = np.zeros((25, 3))
    c[:, :] = sh.basis(np.array([[0.3, 0.4, 0.866]]) / np.linalg.norm([0.3, 0.4, 0.866]), 4)[0][:, None]
    c[0] += 0.2  # a band-limited sun over a dim sky: rings below zero
    img = mr.envmap_bitmap(c, [], 64).astype(np.float64)
    h, w = 64, 128
    theta = np.pi * np.arange(h) / (h - 1)
    u = (np.arange(w) + 0.5) / w
    st = np.sin(theta)[:, None]
    dirs = np.stack(np.broadcast_arrays(-st * np.cos(2 * np.pi * u), st * np.sin(2 * np.pi * u),
                                        np.cos(theta)[:, None]), axis=-1).reshape(-1, 3)
    omega = np.broadcast_to((2 * np.pi / w) * (np.pi / (h - 1)) * np.maximum(st, np.sin(np.pi / (2 * (h - 1)))),
                            (h, w)).reshape(-1, 1)
    model = sh.basis(dirs, 4) @ c
    assert (model < 0).mean() > 0.05 and img.min() >= 0
    y = sh.basis(dirs, 2)
    np.testing.assert_allclose((omega * y).T @ img.reshape(-1, 3), (omega * y).T @ model, atol=1e-5)


def test_camera_rays_match_mitsuba():
    sensor = mi.load_dict(mr._sensor(40, 30, 55.0, 37.0, -8.0, 1))
    rays = mr.perspective_rays(40, 30, 55.0, 37.0, -8.0)
    for px, py in ((0, 0), (39, 0), (0, 29), (20, 15), (33, 7)):
        ray, _ = sensor.sample_ray(0.0, 0.5, mi.Point2f((px + 0.5) / 40, (py + 0.5) / 30), mi.Point2f(0.5, 0.5))
        np.testing.assert_allclose(np.array(ray.d).ravel(), rays[py, px], atol=1e-5)


def _sphere_pixels(normals, size, fov, cam):
    """Pixel (row, col) where a camera at ``cam`` looking along +X sees the unit sphere's point ``n``."""
    fwd, right, up = mr.view_basis(0.0, 0.0)
    t = math.tan(math.radians(fov) / 2)
    out = []
    for n in normals:
        v = n - cam
        v /= np.linalg.norm(v)
        x = (v @ right) / (v @ fwd) / t
        y = -(v @ up) / (v @ fwd) / t
        out.append((int((y + 1) / 2 * size), int((x + 1) / 2 * size), v))
    return out


def _visible_normals(k=12, seed=3):
    n = np.random.default_rng(seed).normal(size=(200, 3))
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    return n[n[:, 0] < -0.6][:k]  # facing the camera, away from the silhouette


def test_mirror_sphere_reflects_where_the_analytic_reflection_says():
    """A mirror sphere shows the environment in direction r = v - 2 (v.n) n (Blender's convention)."""
    c = _smooth_sh(seed=5, lmax=4)
    c[1:] *= 6.0  # strong structure so a wrong orientation shows
    c[0] = 0.0
    c[0] = -sh.min_over_grid(c).min() * math.sqrt(4 * math.pi) + 0.5
    size, fov, cam = 96, 30.0, np.array([-5.0, 0.0, 0.0])
    scene = {"type": "scene", "integrator": {"type": "path", "max_depth": 4},
             "sensor": mr._sensor(size, size, fov, 0.0, 0.0, 16),
             "ball": {"type": "sphere", "radius": 1.0, "bsdf": {"type": "conductor", "material": "none"}},
             **mr.scene_emitters(c, [], 256)}
    scene["sensor"]["to_world"] = mi.ScalarTransform4f().look_at(origin=cam.tolist(), target=[0, 0, 0], up=[0, 0, 1])
    img = np.array(mi.render(mi.load_dict(scene), spp=16))
    errs, spread = [], []
    for (py, px, v), n in zip(_sphere_pixels(_visible_normals(), size, fov, cam), _visible_normals()):
        r = v - 2 * (v @ n) * n
        expect = sh.basis(r / np.linalg.norm(r), 4) @ c
        errs.append(np.abs(img[py, px, :3] - expect).max())
        spread.append(expect)
    scale = np.ptp(np.array(spread), axis=0).max()
    assert np.median(errs) < 0.1 * scale, (np.median(errs), scale)


def test_white_diffuse_sphere_matches_the_analytic_irradiance():
    """Energy: albedo / pi x (SH irradiance + sun lights' n.d) within sampling noise."""
    c = _smooth_sh(seed=7, lmax=2)
    sun = {"type": "sun", "direction": [-0.6, 0.3, 0.74], "color": [1.0, 0.9, 0.7], "intensity": 8.0, "angle": 0.01}
    sun["direction"] = (np.array(sun["direction"]) / np.linalg.norm(sun["direction"])).tolist()
    size, fov, cam = 64, 30.0, np.array([-5.0, 0.0, 0.0])
    scene = {"type": "scene", "integrator": {"type": "path", "max_depth": 2},
             "sensor": mr._sensor(size, size, fov, 0.0, 0.0, 256),
             "ball": {"type": "sphere", "radius": 1.0,
                      "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": [0.8, 0.8, 0.8]}}},
             **mr.scene_emitters(c, [sun], 256)}
    scene["sensor"]["to_world"] = mi.ScalarTransform4f().look_at(origin=cam.tolist(), target=[0, 0, 0], up=[0, 0, 1])
    img = np.array(mi.render(mi.load_dict(scene), spp=256))
    from panolight_core.lighting.lights import light_irradiance

    normals = _visible_normals(20, seed=11)
    got, expect = [], []
    for (py, px, _), n in zip(_sphere_pixels(normals, size, fov, cam), normals):
        got.append(img[py, px, :3])
        expect.append(0.8 / math.pi * (sh.irradiance(c, n) + light_irradiance([sun], n[None])[0]))
    got, expect = np.array(got), np.array(expect)
    assert np.abs(got - expect).mean() < 0.03 * expect.mean()
    assert np.abs(got.mean(0) / expect.mean(0) - 1).max() < 0.02


def test_figure_smoke(tmp_path):
    """The whole figure at tiny size and 4 spp: one HDR and one LDR input, three materials, both views."""
    from PIL import Image

    from panolight_core.camera import hdr_to_ldr
    from panolight_core.data import load_studio_hdri, studio_hdri
    from panolight_core.io import read_image

    hdr = load_studio_hdri("sunset")
    ldr = tmp_path / "city.jpg"
    Image.fromarray(hdr_to_ldr(load_studio_hdri("city"), 0)).save(ldr, quality=90)
    res = mr.render_figure([str(studio_hdri("sunset")), str(ldr)], tmp_path / "fig", spp=4, resolution=(40, 30),
                           compare_hdr=True, log=lambda m: None)
    assert len(res["renders"]) == 2 * 3 * 2 + 3  # 2 inputs x 3 materials x 2 views + 3 ground-truth renders
    fig = np.asarray(Image.open(res["figure"]))
    assert fig.shape[0] == 3 * 30 + 2 * 3 and fig.shape[1] == 3 * 40 + 2 * 3
    for f in res["renders"]:
        assert np.all(np.isfinite(read_image(f, equirect=False)))
    mirror = read_image(tmp_path / "fig" / "sunset-estimated-mirror.exr", equirect=False)
    bg = sample_equirect(hdr.astype(np.float64), mr.perspective_rays(40, 30, 50.0, 0.0, -12.0))
    # above the horizon (no ground, no object) the composite is the panorama itself
    np.testing.assert_allclose(mirror[:3], bg[:3], rtol=1e-5, atol=1e-6)
    emitters = mr.scene_emitters(*mr.load_input(studio_hdri("sunset"))[:2])
    view = mr.composite_view(emitters, mr.mesh_shapes(mr.default_meshes(), "plastic", 0.0), bg,
                             (40, 30, 50.0, 0.0, -12.0), 4)
    assert 0.02 < view["mask"].mean() < 0.4  # both objects are in view
    assert np.abs(view["composite"] - bg)[view["mask"] > 0.99].mean() > 0.01 * bg.mean()


def test_bad_mesh_is_reported():
    with pytest.raises(PanoLightError, match="nope.ply: not found"):
        mr.mesh_shapes(["nope.ply"], "mirror", 0.0)
    with pytest.raises(PanoLightError, match="unknown material"):
        mr.mesh_shapes(mr.default_meshes(), "velvet", 0.0)


def test_figure_from_the_camera_jpeg_has_truth_in_the_jpeg_units(tmp_path):
    """--from-ldr: an HDR input is estimated from its camera JPEG; the truth row is k x HDR."""
    import warnings

    from panolight_core.camera import auto_exposure
    from panolight_core.data import load_studio_hdri, studio_hdri

    hdr = load_studio_hdri("city")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        coeffs, lights, pano, label, truth, white, units = mr.load_input(studio_hdri("city"), from_ldr=0.0)
    assert (white, units) == (1.0, "relative")  # a made JPEG records no exposure
    np.testing.assert_allclose(truth, hdr * auto_exposure(hdr, 0.0, robust=True))
    assert pano.max() <= 1.0 + 1e-6 and "JPEG ev +0" in label  # the background is the photograph
    from panolight_core import sh
    from panolight_core.lighting.adaptive import LightingModel

    naive, true = sh.project(pano, 2)[0, 1], sh.project(truth, 2)[0, 1]
    got = LightingModel(lights, coeffs).project(2)[0, 1]
    assert naive < got and abs(got - true) < abs(naive - true)  # the clipped energy came back, not all of it
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = mr.render_figure([str(studio_hdri("city"))], tmp_path / "fig", spp=2, resolution=(24, 18),
                               compare_hdr=True, from_ldr=0.0, in_panorama=False, materials=("plastic",),
                               log=lambda m: None)
    assert len(res["renders"]) == 2 and any("ground_truth" in r for r in res["renders"])


def test_render_refuses_zero_spp_and_absurd_orders(tmp_path, capsys):
    from panolight_core.apps.cli import main
    from panolight_core.io.lighting import make_lighting, write_lighting

    doc = make_lighting(np.zeros(((mr.MAX_RENDER_ORDER + 2) ** 2, 3)))
    path = tmp_path / "lighting.json"
    write_lighting(path, doc)
    assert main(["render-mitsuba", str(path), "--out", str(tmp_path / "r"), "-q"]) == 1
    assert f"above the {mr.MAX_RENDER_ORDER}" in capsys.readouterr().err
    with pytest.raises(SystemExit) as exc:
        main(["render-mitsuba", str(path), "--out", str(tmp_path / "r"), "--spp", "0"])
    assert exc.value.code == 2 and "--spp must be between" in capsys.readouterr().err


def test_a_lighting_file_cannot_point_the_renderer_at_any_file(tmp_path):
    import hashlib
    import warnings

    from panolight_core.errors import PanoLightWarning
    from panolight_core.io import write_image
    from panolight_core.io.lighting import make_lighting, write_lighting

    pano = write_image(tmp_path / "pano.exr", np.full((8, 16, 3), 0.25, np.float32))
    secret = tmp_path / "secret.exr"
    write_image(secret, np.full((8, 16, 3), 9.0, np.float32))
    digest = hashlib.sha256(pano.read_bytes()).hexdigest()
    for target, expect_bg in ((pano, True), (secret, False)):
        doc = make_lighting(np.zeros((1, 3)), source={"path": str(target), "sha256": digest})
        path = write_lighting(tmp_path / "lighting.json", doc)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            bg = mr.load_input(path).panorama
        assert (bg is not None) == expect_bg
        assert expect_bg or any(isinstance(w.message, PanoLightWarning) for w in caught)


def test_renders_are_in_cd_m2_where_the_photo_s_exif_gives_the_scale_and_shown_as_shot(tmp_path):
    """A JPEG whose EXIF gives its exposure (f/8, 1/100 s, ISO 200): the default estimate writes cd/m^2, --relative
    keeps relative values; render-mitsuba renders both in the lighting's own units, with the plate at its photo's
    white (cd/m^2 or 1), so the absolute render is the relative one times the camera's white. The photo itself
    renders in cd/m^2 too."""
    import warnings

    from panolight_core.apps.cli import main
    from panolight_core.camera import hdr_to_ldr, units
    from panolight_core.io import read_image
    from tests.panolight_core.pipeline.test_brackets import _city, _frame

    photo = _frame(tmp_path / "exif.jpg", hdr_to_ldr(_city(32), 0.0), 1 / 100, 8.0, 200)
    white = units.white_luminance(units.ev100(1 / 100, 8.0, 200.0))
    renders = {}
    for name, extra in (("absolute", []), ("relative", ["--relative"])):
        assert main(["estimate", photo, "-o", str(tmp_path / name), "-q", "--outputs", "lighting"] + extra) == 0
        inp = mr.load_input(tmp_path / name / "lighting.json")
        assert inp.units == ("cd/m^2" if name == "absolute" else "relative")
        assert inp.white == pytest.approx(white if name == "absolute" else 1.0)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            res = mr.render_figure([str(tmp_path / name / "lighting.json")], tmp_path / f"fig_{name}", spp=2,
                                   resolution=(24, 18), in_panorama=False, materials=("plastic",),
                                   log=lambda m: None)
        renders[name] = read_image(res["renders"][0], equirect=False).astype(np.float64)
        (shown,) = res["exposures"].values()
        if name == "absolute":  # the figure shows the plate as shot: its white at white
            assert shown == pytest.approx(1.0 / white)
    np.testing.assert_allclose(renders["absolute"], renders["relative"] * white, rtol=2e-3, atol=1e-6 * white)
    shot = mr.load_input(photo)  # the photo itself, estimated here
    assert shot.units == "cd/m^2" and shot.white == pytest.approx(white)
    assert shot.panorama.max() == pytest.approx(white, rel=1e-6)  # its clipped white is the camera's white
