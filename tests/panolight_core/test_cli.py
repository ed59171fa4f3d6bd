import json
import subprocess
import sys

import numpy as np
import pytest

from panolight_core import sh
from panolight_core.cli import main
from panolight_core.io import read_image, write_image
from panolight_core.lighting import read_lighting


def test_project_writes_its_outputs_and_they_are_right(tmp_path, rng):
    img = (rng.random((32, 64, 3)) * 3).astype(np.float32)
    src = write_image(tmp_path / "in.exr", img)
    out = tmp_path / "out"
    assert main(["project", str(src), "-o", str(out), "--lmax", "3", "--resolution", "64x32", "-q"]) == 0
    assert sorted(p.name for p in out.iterdir()) == ["irradiance.exr", "lighting.json", "preview.png", "radiance.exr"]
    coeffs, doc = read_lighting(out / "lighting.json")
    np.testing.assert_allclose(coeffs, sh.project(img.astype(np.float64), 3), rtol=1e-12)
    assert doc["source"]["sha256"] and doc["estimator"]["name"] == "projection"
    np.testing.assert_allclose(read_image(out / "radiance.exr"), sh.reconstruct(coeffs, 32, 64), rtol=1e-5, atol=1e-6)
    np.testing.assert_allclose(read_image(out / "irradiance.exr", negative="error"),
                               sh.irradiance_map(coeffs, 32, 64), rtol=1e-5, atol=1e-6)
    preview = read_image(out / "preview.png", equirect=False)
    assert preview.shape[0] == 256 and preview.shape[1] > 3 * 512


def test_auto_window_recorded(tmp_path):
    img = np.full((32, 64, 3), 1e-3, np.float32)
    img[8, 20] = 1e5
    src = write_image(tmp_path / "sun.exr", img)
    assert main(["project", str(src), "-o", str(tmp_path / "o"), "--lmax", "6", "--window", "auto", "-q"]) == 0
    coeffs, doc = read_lighting(tmp_path / "o" / "lighting.json")
    assert doc["window"]["mode"] == "auto" and doc["window"]["width"] > 1
    assert sh.min_over_grid(coeffs).min() >= -1e-6 * coeffs[0].max()


def test_bad_input_exit_status_and_message(tmp_path, capsys):
    assert main(["project", str(tmp_path / "missing.jpg"), "-o", str(tmp_path / "o"), "-q"]) == 1
    err = capsys.readouterr().err
    assert "missing.jpg: file not found" in err and "Traceback" not in err
    assert not (tmp_path / "o").exists()
    with pytest.raises(SystemExit):
        main(["project", "x.exr", "--resolution", "300x100"])
    assert "2:1" in capsys.readouterr().err


def test_help_teaches_and_module_entry_works():
    r = subprocess.run([sys.executable, "-m", "panolight_core", "project", "--help"], capture_output=True, text=True)
    assert r.returncode == 0 and "examples:" in r.stdout and "lighting.json" in r.stdout


def test_demo_on_a_blender_studio_hdri(tmp_path):
    from panolight_core.color import LUMINANCE_WEIGHTS, luminance
    from panolight_core.data import studio_hdri

    assert main(["demo", "--scene", "sunrise", "-o", str(tmp_path / "d"), "-q", "--resolution", "64x32"]) == 0
    coeffs, doc = read_lighting(tmp_path / "d" / "lighting.json")
    assert doc["source"]["width"] == 1024 and doc["source"]["dynamic_range"] == "hdr"
    # the l = 1 lobe points near the sun (luminance centroid of pixels above half the peak, EVALUATION.md)
    img = read_image(studio_hdri("sunrise")).astype(np.float64)
    lum = luminance(img)
    sun = (sh.pixel_directions(512, 1024) * (lum * (lum >= 0.5 * lum.max()))[..., None]).sum((0, 1))
    lobe = coeffs[[3, 1, 2]] @ LUMINANCE_WEIGHTS
    cos = sun @ lobe / np.linalg.norm(sun) / np.linalg.norm(lobe)
    assert np.degrees(np.arccos(cos)) < 15
