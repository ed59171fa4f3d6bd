import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from panolight_core import sh
from panolight_core.apps.cli import main
from panolight_core.io import read_image, write_image
from panolight_core.io.lighting import read_lighting


def test_estimate_hdr_writes_its_outputs_and_they_are_right(tmp_path, rng):
    img = (rng.random((32, 64, 3)) * 3).astype(np.float32)
    src = write_image(tmp_path / "in.exr", img)
    out = tmp_path / "out"
    assert main(["estimate", str(src), "-o", str(out), "--lmax", "3", "--resolution", "64x32", "-q"]) == 0
    assert sorted(p.name for p in out.iterdir()) == [".panolight-files.json", "hdr.exr", "irradiance.exr",
                                                     "lighting.json", "lighting.usda", "preview.png", "radiance.exr"]
    coeffs, doc = read_lighting(out / "lighting.json")
    np.testing.assert_allclose(coeffs, sh.project(img.astype(np.float64), 3), rtol=1e-5, atol=1e-6)
    np.testing.assert_array_equal(read_image(out / "hdr.exr"), img)  # an HDR input is its own HDRI
    assert doc["source"]["sha256"] and doc["estimator"]["name"] == "keylight" and doc["order"]["mode"] == "fixed"
    assert set(doc["timings"]) == {"read_s", "estimate_s", "model_s", "write_s"}
    np.testing.assert_allclose(read_image(out / "radiance.exr"), sh.reconstruct(coeffs, 32, 64), rtol=1e-5, atol=1e-5)
    np.testing.assert_allclose(read_image(out / "irradiance.exr", negative="error"),
                               sh.irradiance_map(coeffs, 32, 64), rtol=1e-5, atol=1e-5)
    preview = read_image(out / "preview.png", equirect=False)
    assert preview.shape[0] == 16 + 256 and preview.shape[1] == 2 * 512 + 256 + 8  # titles above input | radiance | sphere


def test_default_model_writes_lights_and_sh_model_does_not(tmp_path):
    import jsonschema

    from panolight_core.io.lighting import schema

    img = np.full((64, 128, 3), 0.05, np.float32)
    img[20, 90] = 5e4  # a sun
    src = write_image(tmp_path / "sun.exr", img)
    assert main(["estimate", str(src), "-o", str(tmp_path / "auto"), "-q"]) == 0
    coeffs, doc = read_lighting(tmp_path / "auto" / "lighting.json")
    jsonschema.validate(doc, schema())
    assert len(doc["lights"]) == 1 and doc["lights"][0]["type"] == "sun"
    assert doc["model"]["mode"] == "lights+sh" and doc["model"]["order"]["mode"] == "auto"
    assert doc["model"]["parameters"] == coeffs.size + 8
    # irradiance.exr holds the whole model: lights + SH
    from panolight_core.lighting.lights import light_irradiance

    expected = light_irradiance(doc["lights"], sh.pixel_directions(256, 512)) + sh.irradiance_map(coeffs, 256, 512)
    np.testing.assert_allclose(read_image(tmp_path / "auto" / "irradiance.exr", negative="error"), expected,
                               rtol=1e-4, atol=1e-6)
    assert main(["estimate", str(src), "-o", str(tmp_path / "sh"), "--model", "sh", "-q"]) == 0
    coeffs_sh, doc_sh = read_lighting(tmp_path / "sh" / "lighting.json")
    assert doc_sh["lights"] == [] and doc_sh["lmax"] == 2 and doc_sh["model"]["mode"] == "sh"


def test_estimate_ldr_auto_order_exposure_and_window(tmp_path):
    hdr = np.full((64, 128, 3), 0.2, np.float32)
    hdr[10:14, 30:34] = 400.0
    from PIL import Image

    from panolight_core.camera import hdr_to_ldr

    src = tmp_path / "sun.png"
    Image.fromarray(hdr_to_ldr(hdr, 0)).save(src)
    out = tmp_path / "o"
    assert main(["estimate", str(src), "-o", str(out), "--lmax", "auto", "--tolerance", "0.02",
                 "--exposure", "1", "--window", "auto", "-q"]) == 0
    coeffs, doc = read_lighting(out / "lighting.json")
    assert doc["order"]["mode"] == "auto" and doc["lmax"] == doc["order"]["lmax"] <= 8
    errs = doc["order"]["irradiance_error_per_order"]
    assert errs[doc["lmax"]] <= 0.02 and (doc["lmax"] == 0 or errs[doc["lmax"] - 1] > 0.02)
    assert doc["exposure_ev"] == 1 and doc["source"]["dynamic_range"] == "ldr-8bit-srgb"
    assert doc["clipped_regions"] and doc["window"]["mode"] == "auto"
    assert sh.min_over_grid(coeffs).min() >= -1e-6 * coeffs[0].max() * 1.01


def test_bad_input_exit_status_message_and_nothing_written(tmp_path, capsys, monkeypatch):
    before = set(os.listdir(tmp_path))
    assert main(["estimate", str(tmp_path / "missing.jpg"), "-o", str(tmp_path / "o"), "-q"]) == 1
    err = capsys.readouterr().err
    assert "missing.jpg: file not found" in err and "Traceback" not in err
    assert set(os.listdir(tmp_path)) == before
    bad = tmp_path / "square.png"
    write_image(bad, np.zeros((8, 8, 3)))
    assert main(["estimate", str(bad), "-o", str(tmp_path / "o2"), "-q"]) == 1
    assert "2:1" in capsys.readouterr().err
    from panolight_core.estimators.nn import estimator as nn_estimator

    monkeypatch.setattr(nn_estimator, "DEFAULT_WEIGHTS", tmp_path / "gone.safetensors")
    assert main(["estimate", str(bad), "--estimator", "neural", "-q"]) == 1
    assert "weights are missing" in capsys.readouterr().err
    for argv in (["estimate", "x.exr", "--resolution", "300x100"], ["estimate", "x.exr", "--lmax", "-1"],
                 ["estimate", "x.exr", "--window", "gauss"]):
        with pytest.raises(SystemExit):
            main(argv)


def test_unwritable_output_is_reported_not_raised(tmp_path, capsys):
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    src = write_image(tmp_path / "in.exr", np.full((8, 16, 3), 0.5, np.float32))
    assert main(["estimate", str(src), "-o", str(blocker / "sub"), "-q"]) == 1
    err = capsys.readouterr().err
    assert "panolight: error:" in err and "Traceback" not in err and str(blocker) in err


def test_project_is_the_naive_estimator(tmp_path, rng):
    src = write_image(tmp_path / "in.png", rng.random((16, 32, 3)))
    assert main(["project", str(src), "-o", str(tmp_path / "p"), "-q"]) == 0
    _, doc = read_lighting(tmp_path / "p" / "lighting.json")
    assert doc["estimator"]["name"] == "naive"


def test_help_teaches_and_module_entry_works():
    for cmd in ("estimate", "batch", "eval", "demo"):
        r = subprocess.run([sys.executable, "-m", "panolight_core", cmd, "--help"], capture_output=True, text=True)
        assert r.returncode == 0 and ("examples:" in r.stdout or "outputs" in r.stdout or "protocol" in r.stdout), cmd
    r = subprocess.run([sys.executable, "-m", "panolight_core"], capture_output=True, text=True)
    assert r.returncode == 2 and "panolight demo" in r.stdout


def test_demo_estimates_a_made_jpeg_against_the_truth(tmp_path, capsys):
    out = tmp_path / "d"
    assert main(["demo", "--scene", "city", "-o", str(out), "-q", "--resolution", "64x32"]) == 0
    assert (out / "input.jpg").is_file() and (out / "preview.png").is_file()
    said = capsys.readouterr().out
    ours = float(said.split("irr-RMSE ")[1].split(" ")[0])
    naive = float(said.split("(naive lmax 2: ")[1].split(")")[0])
    assert ours < naive  # city: the clipped sun is worth recovering


def test_estimate_never_overwrites_its_input(tmp_path, capsys):
    img = np.full((32, 64, 3), 0.5, np.float32)
    src = write_image(tmp_path / "hdr.exr", img)
    before = src.read_bytes()
    assert main(["estimate", str(src), "-o", str(tmp_path), "-q"]) == 1
    assert "would overwrite the input" in capsys.readouterr().err
    assert src.read_bytes() == before


@pytest.mark.parametrize("args,message", [
    (["--tolerance", "-1"], "--tolerance must be between"), (["--tolerance", "nan"], "--tolerance must be between"),
    (["--window-width", "-3"], "--window-width must be between"), (["--exposure", "2000"], "--exposure must be"),
    (["--exposure", "inf"], "--exposure must be"), (["--sun-strength", "-1"], "--sun-strength must be between"),
    (["--sun-strength", "nan"], "--sun-strength must be between")])
def test_bad_numbers_get_one_line(tmp_path, capsys, args, message):
    src = write_image(tmp_path / "in.exr", np.full((16, 32, 3), 0.5, np.float32))
    with pytest.raises(SystemExit) as exc:
        main(["estimate", str(src), "-o", str(tmp_path / "o"), "-q", *args])
    assert exc.value.code == 2 and message in capsys.readouterr().err
    assert not (tmp_path / "o").exists()


def test_overflowing_outputs_are_refused_before_writing(tmp_path, capsys):
    img = np.full((16, 32, 3), 3.0e38, np.float32)  # float-max pixels: their projection overflows
    src = write_image(tmp_path / "huge.exr", img)
    assert main(["estimate", str(src), "-o", str(tmp_path / "o"), "-q"]) == 1
    assert "would not be finite" in capsys.readouterr().err and not (tmp_path / "o").exists()
    src2 = write_image(tmp_path / "bright.exr", np.full((16, 32, 3), 1e30, np.float32))
    assert main(["estimate", str(src2), "-o", str(tmp_path / "o2"), "--exposure", "59", "-q"]) == 1
    assert "would not be finite" in capsys.readouterr().err and not (tmp_path / "o2").exists()


def test_sigterm_mid_write_exits_143_and_leaves_no_temporary_files(tmp_path, capsys, monkeypatch):
    import signal

    from panolight_core.pipeline import job as pipeline

    src = write_image(tmp_path / "in.exr", np.full((16, 32, 3), 0.5, np.float32))
    real = pipeline.write_image

    def write_then_terminate(path, image, **kw):
        if Path(path).name == "radiance.exr":  # the farm cancels the job while outputs are written
            os.kill(os.getpid(), signal.SIGTERM)
        return real(path, image, **kw)

    monkeypatch.setattr(pipeline, "write_image", write_then_terminate)
    out = tmp_path / "o"
    assert main(["estimate", str(src), "-o", str(out), "-q"]) == 143
    assert "terminated" in capsys.readouterr().err
    assert not out.exists()  # nothing half-done: no outputs, no temporary files, no lock, not even the folder
    assert signal.getsignal(signal.SIGTERM) is not None  # the previous handler is back


def test_outputs_never_replace_files_panolight_did_not_write(tmp_path, capsys):
    src = write_image(tmp_path / "in.exr", np.full((16, 32, 3), 0.5, np.float32))
    out = tmp_path / "o"
    out.mkdir()
    (out / "preview.png").write_bytes(b"the user's own picture")
    assert main(["estimate", str(src), "-o", str(out), "-q"]) == 1
    assert "were not written by PanoLight" in capsys.readouterr().err
    assert (out / "preview.png").read_bytes() == b"the user's own picture"
    assert main(["estimate", str(src), "-o", str(out), "-q", "--overwrite"]) == 0
    assert main(["estimate", str(src), "-o", str(out), "-q"]) == 0  # an earlier run's outputs are ours
    (out / "radiance.exr").write_bytes(b"edited by the user after the run")  # no longer the file we wrote
    assert main(["estimate", str(src), "-o", str(out), "-q"]) == 1
    assert "radiance.exr exist and were not written by PanoLight" in capsys.readouterr().err


def test_a_copied_lighting_json_does_not_make_its_neighbours_ours(tmp_path, capsys):
    """Issue 23: cp <earlier run>/lighting.json o/; echo mine > o/hdr.exr; estimate --outputs lighting
    deleted the user's hdr.exr, taking the copied lighting.json as proof of ownership."""
    src = write_image(tmp_path / "in.exr", np.full((16, 32, 3), 0.5, np.float32))
    assert main(["estimate", str(src), "-o", str(tmp_path / "earlier"), "-q"]) == 0
    out = tmp_path / "o"
    out.mkdir()
    (out / "lighting.json").write_bytes((tmp_path / "earlier" / "lighting.json").read_bytes())
    (out / "hdr.exr").write_text("mine")
    assert main(["estimate", str(src), "-o", str(out), "-q", "--outputs", "lighting"]) == 1  # lighting.json: not ours
    assert "lighting.json exist and were not written" in capsys.readouterr().err
    assert (out / "hdr.exr").read_text() == "mine"
    # replacing what it writes (--overwrite) still never deletes a user's file it does not write
    assert main(["estimate", str(src), "-o", str(out), "-q", "--outputs", "lighting", "--overwrite"]) == 0
    assert (out / "hdr.exr").read_text() == "mine" and (out / "radiance.exr").is_file()
    # an earlier run's own hdr.exr is removed when a later run does not write it: never a mix of runs
    assert main(["estimate", str(src), "-o", str(tmp_path / "p"), "-q"]) == 0
    assert main(["estimate", str(src), "-o", str(tmp_path / "p"), "-q", "--outputs", "lighting"]) == 0
    assert not (tmp_path / "p" / "hdr.exr").exists() and not (tmp_path / "p" / "preview.png").exists()


def test_an_interrupted_rename_leaves_our_files_ours(tmp_path, monkeypatch):
    """While the set is renamed into place the manifest accepts both the old and the new files."""
    from panolight_core.io import ownership

    src = write_image(tmp_path / "in.exr", np.full((16, 32, 3), 0.5, np.float32))
    src2 = write_image(tmp_path / "in2.exr", np.full((16, 32, 3), 0.7, np.float32))
    out = tmp_path / "o"
    assert main(["estimate", str(src), "-o", str(out), "-q"]) == 0
    real = os.replace
    calls = []

    def replace_then_die(a, b):
        calls.append(b)
        if Path(b).name == "preview.png":  # killed after some renames
            raise KeyboardInterrupt
        return real(a, b)

    monkeypatch.setattr(os, "replace", replace_then_die)
    assert main(["estimate", str(src2), "-o", str(out), "-q"]) == 130
    monkeypatch.setattr(os, "replace", real)
    assert not ownership.foreign(out, ["radiance.exr", "irradiance.exr", "preview.png", "hdr.exr", "lighting.json"])
    assert main(["estimate", str(src2), "-o", str(out), "-q"]) == 0


def test_a_second_writer_is_refused_for_the_whole_run_and_a_stale_lock_taken_over(tmp_path, capsys, monkeypatch):
    from panolight_core.io.atomic import folder_lock
    from panolight_core.pipeline import job as pipeline

    src = write_image(tmp_path / "in.exr", np.full((16, 32, 3), 0.5, np.float32))
    out = tmp_path / "o"
    out.mkdir()
    with folder_lock(out):  # another writer holds the folder
        assert main(["estimate", str(src), "-o", str(out), "-q"]) == 1
    assert "another PanoLight process" in capsys.readouterr().err and not (out / "lighting.json").exists()
    (out / ".panolight.lock").write_text("999999999")  # a lock file its dead writer left
    seen = []
    real = pipeline.read_image

    def read_while_a_second_estimate_starts(*a, **kw):  # the lock covers reading and estimating too
        seen.append(main(["estimate", str(src), "-o", str(out), "-q"]))
        return real(*a, **kw)

    monkeypatch.setattr(pipeline, "read_image", read_while_a_second_estimate_starts)
    assert main(["estimate", str(src), "-o", str(out), "-q"]) == 0
    assert seen == [1] and "another PanoLight process (pid " in capsys.readouterr().err
    assert (out / "lighting.json").is_file() and not (out / ".panolight.lock").exists()


def test_out_of_memory_is_one_line(tmp_path, capsys, monkeypatch):
    from panolight_core.pipeline import job as pipeline

    src = write_image(tmp_path / "in.exr", np.full((16, 32, 3), 0.5, np.float32))

    def no_memory(*a, **k):
        raise MemoryError

    monkeypatch.setattr(pipeline, "read_image", no_memory)
    assert main(["estimate", str(src), "-o", str(tmp_path / "o"), "-q"]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "out of memory" in err and "Traceback" not in err


def test_plugins_add_commands_and_a_missing_plugin_package_is_skipped(monkeypatch, capsys):
    import importlib.metadata

    from panolight_core.apps import cli

    class EntryPoint:
        def __init__(self, name, value, load):
            self.name, self.value, self._load = name, value, load

        def load(self):
            return self._load()

    def missing():
        raise ModuleNotFoundError("No module named 'absent_pkg'", name="absent_pkg")

    def broken():
        raise ImportError("cannot import name 'x'")

    def hello():
        return lambda sub: sub.add_parser("hello", help="a plugin's command").set_defaults(func=lambda a: 7)

    eps = [EntryPoint("gone", "absent_pkg.commands:register", missing),
           EntryPoint("broken", "broken_pkg.commands:register", broken),
           EntryPoint("hello", "hello_pkg:register", hello)]
    monkeypatch.setattr(importlib.metadata, "entry_points", lambda group: eps if group == cli.PLUGIN_GROUP else [])
    assert main(["hello"]) == 7
    err = capsys.readouterr().err
    assert "'broken' commands could not be loaded" in err and "gone" not in err


def test_the_checkout_registers_the_training_commands():
    r = subprocess.run([sys.executable, "-m", "panolight_core", "--help"], capture_output=True, text=True,
                       timeout=120)
    for name in ("estimate", "batch", "eval", "demo", "project", "train", "synth", "sheet", "render-mitsuba"):
        assert f"    {name}" in r.stdout, name


def test_outputs_choose_the_groups_and_leave_no_mix_of_runs(tmp_path, capsys):
    src = write_image(tmp_path / "in.exr", np.full((16, 32, 3), 0.5, np.float32))
    out = tmp_path / "o"
    assert main(["estimate", str(src), "-o", str(out), "-q"]) == 0
    capsys.readouterr()
    assert main(["estimate", str(src), "-o", str(out), "--outputs", "lighting"]) == 0
    assert sorted(p.name for p in out.iterdir()) == [".panolight-files.json", "lighting.json", "lighting.usda", "radiance.exr"]
    assert ("removed hdr.exr, irradiance.exr, preview.png: an earlier run's output(s) that this run's --outputs does "
            "not write") in capsys.readouterr().err  # said on the terminal
    assert main(["estimate", str(src), "-o", str(out), "-q", "--outputs", "hdr,previews"]) == 0
    assert sorted(p.name for p in out.iterdir()) == [".panolight-files.json", "hdr.exr", "irradiance.exr",
                                                     "lighting.json", "lighting.usda", "preview.png", "radiance.exr"]
    with pytest.raises(SystemExit):
        main(["estimate", str(src), "-o", str(out), "--outputs", "lighting,thumbnails"])
    assert "--outputs takes 'all' or a comma-separated list of lighting, hdr, previews" in capsys.readouterr().err
    assert main(["estimate", str(src), "-o", str(out), "-q", "--outputs", "all"]) == 0
    assert (out / "hdr.exr").is_file() and (out / "preview.png").is_file()


def test_an_hdri_that_would_overflow_alone_is_refused_and_leaves_no_folder(tmp_path, capsys):
    img = np.full((16, 32, 3), 1e-3, np.float32)
    img[8, 16] = 3.0e37  # one pixel: the SH and maps stay finite, the scaled HDRI's pixel does not
    src = write_image(tmp_path / "spike.exr", img)
    assert main(["estimate", str(src), "-o", str(tmp_path / "o"), "--exposure", "4", "-q"]) == 1
    assert "hdr.exr would not be finite" in capsys.readouterr().err and not (tmp_path / "o").exists()


def test_hdr_exr_is_half_floats_for_an_8_bit_input_and_float32_when_it_would_not_fit(tmp_path):
    import OpenEXR

    from panolight_core.camera import hdr_to_ldr
    from panolight_core.data import load_studio_hdri
    from panolight_core.io import write_srgb8
    from panolight_core.pipeline import Settings, estimate_lighting

    ldr = hdr_to_ldr(load_studio_hdri("sunrise"), 0.0)
    src = write_srgb8(tmp_path / "in.png", ldr)

    def channel_type(folder):
        with OpenEXR.File(str(folder / "hdr.exr")) as f:
            return f.channels()["RGB"].pixels.dtype

    # sources: no key light; keylight (the default): the sun as a 2 x 2 pixel splat, 7e4 > half's 65504 here
    for estimator, ev, dtype in (("sources", 0, np.float16), ("sources", 16, np.float32), ("keylight", 0, np.float32)):
        out = tmp_path / f"{estimator}{ev}"
        assert main(["estimate", str(src), "-o", str(out), "-q", "--exposure", str(ev), "--estimator", estimator]) == 0
        assert channel_type(out) == dtype
        want = estimate_lighting(ldr, Settings(exposure_ev=ev, estimator=estimator)).hdr_panorama(ldr)
        assert want.max() > 1.0  # energy was recovered
        np.testing.assert_allclose(read_image(out / "hdr.exr"), want, rtol=2 ** -11, atol=0)


def test_a_symlink_loop_and_a_file_size_limit_get_one_line_and_leave_nothing(tmp_path):
    """Issue 23: a symlink loop raised RuntimeError from pipeline/job.py; a full disk or `ulimit -f` a
    traceback from io/images.py."""
    import resource

    (tmp_path / "a.jpg").symlink_to("b.jpg")
    (tmp_path / "b.jpg").symlink_to("a.jpg")
    r = subprocess.run([sys.executable, "-m", "panolight_core", "estimate", "a.jpg", "-o", "out", "-q"],
                       cwd=tmp_path, capture_output=True, text=True, timeout=120)
    assert r.returncode == 1 and r.stderr.count("\n") == 1 and "Traceback" not in r.stderr
    assert "a.jpg: cannot be opened (Too many levels of symbolic links)" in r.stderr
    write_image(tmp_path / "big.exr", np.random.default_rng(0).random((256, 512, 3)).astype(np.float32))
    r = subprocess.run([sys.executable, "-m", "panolight_core", "estimate", "big.exr", "-o", "out", "-q"],
                       cwd=tmp_path, capture_output=True, text=True, timeout=120,
                       preexec_fn=lambda: resource.setrlimit(resource.RLIMIT_FSIZE, (100_000, 100_000)))
    assert r.returncode == 1 and r.stderr.count("\n") == 1 and "Traceback" not in r.stderr, r.stderr
    assert "cannot write it (File too large)" in r.stderr and "out/" in r.stderr and ".panolight-" not in r.stderr
    assert not (tmp_path / "out").exists()  # nothing partial is left


def test_a_full_disk_is_one_error_naming_the_file(tmp_path, monkeypatch):
    import errno

    from panolight_core.errors import PanoLightError
    from panolight_core.io.atomic import atomic_path

    with pytest.raises(PanoLightError, match=r"x\.json: cannot write it \(No space left on device\)"):
        with atomic_path(tmp_path / "x.json") as tmp:
            tmp.write_text("partial")
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("name, pixels, said", [
    ("black.png", np.zeros((16, 32, 3)), "the panorama is black"),
    ("black.exr", np.zeros((16, 32, 3), np.float32), "the panorama is black"),
    ("black.hdr", np.zeros((16, 32, 3), np.float32), "the panorama is black"),
    ("denormal.exr", np.full((16, 32, 3), 1e-40, np.float32), "the panorama is black"),
    ("huge.exr", np.full((16, 32, 3), 1e30, np.float32), "pixel values reach"),
    ("floatmax.exr", np.full((16, 32, 3), np.finfo(np.float32).max / 4, np.float32), "pixel values reach"),
    ("white.png", np.ones((16, 32, 3)), "100% of the pixels are clipped white"),
])
def test_inputs_with_no_meaningful_lighting_are_said_with_the_file_named(tmp_path, capsys, name, pixels, said):
    """Issue 23: all-black, 1e30 and fully clipped inputs gave zero / 3.5e30 / 160x lighting silently."""
    src = write_image(tmp_path / name, pixels)
    for estimator in ("naive", "sources"):
        assert main(["estimate", str(src), "-o", str(tmp_path / estimator), "--estimator", estimator, "-q"]) == 0
        err = capsys.readouterr().err
        assert f"warning: {src}: {said}" in err, err
    assert main(["batch", str(src), "-o", str(tmp_path / "b"), "-q"]) == 0  # batch reports say it per input
    import json

    report = json.loads((tmp_path / "b" / "batch_report.json").read_text())
    assert said in report["results"][0]["warnings"][0] and said in capsys.readouterr().err


def test_a_normal_photo_gets_no_such_warning(tmp_path, capsys, rng):
    src = write_image(tmp_path / "ok.png", rng.random((16, 32, 3)) * 0.8)
    assert main(["estimate", str(src), "-o", str(tmp_path / "o"), "-q"]) == 0
    assert "warning" not in capsys.readouterr().err


def test_radiance_exr_holds_no_negative_light_and_keeps_the_diffuse_lighting(tmp_path):
    """Issue 23: radiance.exr (the USD dome's texture) was negative in 13-47 % of its pixels on real
    photos while lighting.json said "no visible ringing" (only irradiance was checked)."""
    img = np.full((64, 128, 3), 0.05, np.float32)
    img[18:22, 88:92] = 400.0  # a small sun: its SH series rings
    src = write_image(tmp_path / "sun.exr", img)
    out = tmp_path / "o"
    assert main(["estimate", str(src), "-o", str(out), "--model", "sh", "--lmax", "6", "--resolution",
                 "256x128", "-q"]) == 0
    coeffs, doc = read_lighting(out / "lighting.json")
    model = sh.reconstruct(coeffs, 128, 256)
    assert (model < 0).mean() > 0.05  # the SH radiance rings ...
    emitter = read_image(out / "radiance.exr", negative="error")  # ... the emitter does not
    assert emitter.min() >= 0
    y = sh.basis(sh.pixel_directions(128, 256).reshape(-1, 3), 2)
    w = sh.pixel_solid_angles(128, 256).reshape(-1, 1)
    np.testing.assert_allclose((w * y).T @ emitter.reshape(-1, 3), (w * y).T @ model.reshape(-1, 3),
                               rtol=1e-5, atol=1e-6 * abs(coeffs[0]).max())  # bands 0-2: the same irradiance
    ringing = doc["model"]["ringing"]
    assert "the SH radiance dips to" in ringing["why"] and ringing["emitter"]["negative_fraction"] > 0.05
    assert "nearest non-negative map" in ringing["emitters"]


def test_a_tiny_jpeg_claiming_a_huge_size_and_huge_output_maps_are_refused_at_once(tmp_path, capsys):
    """Issue 23: a 633-byte JPEG whose frame header claims 16000 x 8000 decoded to 5.1 GB of grey (exit 0,
    `project` 7.9 GB); --resolution 16384x8192 on a small JPEG peaked at 4.7 GB."""
    import struct

    from PIL import Image

    Image.fromarray(np.full((8, 16, 3), 120, np.uint8)).save(tmp_path / "small.jpg", quality=90)
    for w, h in ((16000, 8000), (16384, 8192)):
        data = bytearray((tmp_path / "small.jpg").read_bytes())
        struct.pack_into(">HH", data, data.find(b"\xff\xc0") + 5, h, w)
        claim = tmp_path / f"claim{w}.jpg"
        claim.write_bytes(bytes(data))
        for command in ("estimate", "project"):
            assert main([command, str(claim), "-o", str(tmp_path / command), "-q"]) == 1
            err = capsys.readouterr().err
            assert f"the JPEG claims {w} x {h} pixels but holds only" in err and err.count("\n") == 1
            assert not (tmp_path / command).exists()
    Image.fromarray(np.full((256, 512, 3), 120, np.uint8)).save(tmp_path / "ok.jpg", quality=90)
    with pytest.raises(SystemExit):
        main(["estimate", str(tmp_path / "ok.jpg"), "-o", str(tmp_path / "o"), "--resolution", "16384x8192"])
    assert "height 1..2048" in capsys.readouterr().err and not (tmp_path / "o").exists()


def test_estimate_prints_its_steps_unless_quiet(tmp_path, rng, capsys):
    import logging

    src = write_image(tmp_path / "in.exr", (rng.random((32, 64, 3)) * 3).astype(np.float32))
    assert main(["estimate", str(src), "-o", str(tmp_path / "a"), "--resolution", "64x32"]) == 0
    err = capsys.readouterr().err
    assert f"reading {src}" in err and "writing " in err and "done: " in err
    assert main(["estimate", str(src), "-o", str(tmp_path / "b"), "--resolution", "64x32", "-q"]) == 0
    assert capsys.readouterr().err == ""
    core = logging.getLogger("panolight_core")  # the command's handler is gone when it returns
    assert core.propagate and not [h for h in core.handlers if not isinstance(h, logging.NullHandler)]


def test_sun_strength_raises_the_key_light_in_every_output(tmp_path, capsys):
    """--sun-strength X: the key light's intensity in lighting.json and lighting.usda, and its energy in hdr.exr,
    times X, and the setting recorded. The SH stays as it was here: the lamp's light already carries more than its
    region's decided fill, so raising it takes nothing from the fill."""
    pytest.importorskip("pxr")
    from PIL import Image
    from pxr import Usd, UsdLux

    from panolight_core.camera import hdr_to_ldr

    h = 128
    d = sh.pixel_directions(h, 2 * h)
    img = np.full((h, 2 * h, 3), 0.1)
    lamp = np.arccos(np.clip(d @ np.array([0.3, -0.2, 0.93]) / np.linalg.norm([0.3, -0.2, 0.93]), -1, 1))
    core = lamp < np.radians(3.0)
    img[core] += 3.0 / sh.pixel_solid_angles(h, 2 * h)[core].sum()
    img += (0.05 * np.minimum(np.radians(3.0) / np.maximum(lamp, 1e-6), 1.0) ** 2)[..., None]
    src = tmp_path / "lamp.png"
    Image.fromarray(hdr_to_ldr(img, 0.0)).save(src)
    outs = {}
    for x in (1.0, 2.0):
        out = tmp_path / f"x{x:g}"
        assert main(["estimate", str(src), "-o", str(out), "-q", "--sun-strength", f"{x:g}"]) == 0
        coeffs, doc = read_lighting(out / "lighting.json")
        stage = Usd.Stage.Open(str(out / "lighting.usda"))
        usd = sorted(float(UsdLux.LightAPI(p).GetIntensityAttr().Get()) for p in stage.Traverse()
                     if p.HasAPI(UsdLux.LightAPI) and not p.IsA(UsdLux.DomeLight))
        hdr = read_image(out / "hdr.exr").astype(np.float64)
        outs[x] = (doc, coeffs, usd, (hdr * sh.pixel_solid_angles(*hdr.shape[:2])[..., None]).sum(axis=(0, 1)))
    (doc1, c1, usd1, e1), (doc2, c2, usd2, e2) = outs[1.0], outs[2.0]
    key1, key2 = ([light for light in doc["lights"] if light.get("source")] for doc in (doc1, doc2))
    assert len(key1) == len(key2) == 1 and doc1["sun_strength"] == 1.0 and doc2["sun_strength"] == 2.0
    assert key2[0]["intensity"] == pytest.approx(2.0 * key1[0]["intensity"], rel=1e-9)
    assert usd2 and usd2[-1] == pytest.approx(2.0 * usd1[-1], rel=1e-5)
    # hdr.exr gains the second half of the light (its colour's RGB), nothing else
    np.testing.assert_allclose(e2 - e1, key1[0]["intensity"] * np.asarray(key1[0]["color"]), rtol=2e-3)
    np.testing.assert_allclose(c2, c1, atol=1e-3 * np.abs(c1).max())


@pytest.mark.parametrize("command", ["estimate", "batch"])
def test_a_symlinked_lock_never_writes_outside_the_folder(tmp_path, capsys, command):
    """`ln -s ../victim.txt o/.panolight.lock` made the lock write a pid into victim.txt, then remove the link."""
    src = write_image(tmp_path / "in.exr", np.full((16, 32, 3), 0.5, np.float32))
    victim = tmp_path / "victim.txt"
    victim.write_text("precious")
    out = tmp_path / "o"
    out.mkdir()
    (out / ".panolight.lock").symlink_to("../victim.txt")
    assert main([command, str(src), "-o", str(out), "-q"]) == 1
    err = capsys.readouterr().err
    assert ".panolight.lock: is a symbolic link" in err and "Traceback" not in err and len(err.splitlines()) == 1
    assert victim.read_text() == "precious" and (out / ".panolight.lock").is_symlink()
    assert sorted(p.name for p in out.iterdir()) == [".panolight.lock"]


def test_the_next_run_cleans_the_staging_folder_a_killed_estimate_left(tmp_path):
    """A SIGKILLed estimate leaves OUT/.panolight-PID-X/ (MBs); the next run into OUT removes it, as its
    marker proves it PanoLight's, and keeps a look-alike folder of the user's."""
    import signal
    import time

    src = write_image(tmp_path / "in.exr", np.full((64, 128, 3), 0.5, np.float32))
    out = tmp_path / "o"
    code = ("import os, signal, sys\n"
            "from panolight_core.pipeline import job\n"
            "real = job.write_lighting\n"
            "def die(*a, **k): real(*a, **k); os.kill(os.getpid(), signal.SIGKILL)\n"
            "job.write_lighting = die\n"
            f"job.run_estimate({str(src)!r}, {str(out)!r})\n")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert r.returncode == -signal.SIGKILL
    left = [p for p in out.iterdir() if p.name.startswith(".panolight-") and p.is_dir()]
    assert len(left) == 1 and (left[0] / "lighting.json").is_file()
    user = out / ".panolight-4000002"
    user.mkdir()
    (user / "notes.txt").write_text("mine")
    time.sleep(0.01)
    assert main(["estimate", str(src), "-o", str(out), "-q"]) == 0
    assert not left[0].exists() and (user / "notes.txt").read_text() == "mine"


def test_a_hostile_manifest_is_one_line_naming_it(tmp_path, capsys):
    src = write_image(tmp_path / "in.exr", np.full((16, 32, 3), 0.5, np.float32))
    out = tmp_path / "o"
    out.mkdir()
    (out / ".panolight-files.json").write_text("[" * 100000)
    assert main(["estimate", str(src), "-o", str(out), "-q"]) == 1
    err = capsys.readouterr().err
    assert ".panolight-files.json: nested too deeply" in err and "Traceback" not in err
    (out / ".panolight-files.json").write_text(" " * (2 << 20))
    assert main(["estimate", str(src), "-o", str(out), "-q"]) == 1
    assert ".panolight-files.json: is 2097152 bytes, more than PanoLight ever writes" in capsys.readouterr().err
    assert sorted(p.name for p in out.iterdir()) == [".panolight-files.json"]


def test_a_failed_overwrite_leaves_the_folder_as_it_was_and_names_the_users_path(tmp_path, capsys):
    """A folder of the user's named preview.png: the run renamed three files, then failed naming the staging
    path, leaving hdr.exr of one photo beside lighting.json of another."""
    first = write_image(tmp_path / "first.exr", np.full((16, 32, 3), 0.5, np.float32))
    second = write_image(tmp_path / "second.exr", np.full((16, 32, 3), 0.9, np.float32))
    out = tmp_path / "o"
    assert main(["estimate", str(first), "-o", str(out), "-q"]) == 0
    before = {p.name: p.read_bytes() for p in out.iterdir() if p.is_file() and p.name != "preview.png"}
    (out / "preview.png").unlink()
    (out / "preview.png").mkdir()
    (out / "preview.png" / "mine.txt").write_text("mine")
    assert main(["estimate", str(second), "-o", str(out), "-q", "--overwrite"]) == 1
    err = capsys.readouterr().err
    assert f"{out / 'preview.png'}: is a folder" in err and ".panolight-" not in err
    after = {p.name: p.read_bytes() for p in out.iterdir() if p.is_file() and p.name != "preview.png"}
    assert after == before and (out / "preview.png" / "mine.txt").read_text() == "mine"


def test_an_sh_order_and_map_size_that_would_cost_gigabytes_are_refused_up_front(tmp_path, capsys):
    """--lmax 100 --model sh --resolution 4096x2048 took 50 s and 6.7 GB, each value within its own limit."""
    src = write_image(tmp_path / "in.exr", np.full((16, 32, 3), 0.5, np.float32))
    for command in ("estimate", "batch"):
        argv = [command, str(src), "-o", str(tmp_path / command), "-q", "--model", "sh", "--lmax", "100",
                "--resolution", "4096x2048"]
        assert main(argv) == 1
        err = capsys.readouterr().err
        assert "SH order 100 with --resolution 4096x2048 would take several GB" in err
        assert "lower --resolution to 512x256 or below, or the order to 43 or below" in err
        assert not (tmp_path / command).exists()
    assert main(["estimate", str(src), "-o", str(tmp_path / "ok"), "-q", "--model", "sh", "--lmax", "43",
                 "--resolution", "4096x2048", "--outputs", "lighting"]) == 0


def test_the_artist_points_at_the_sun_from_the_command_line(tmp_path, capsys):
    """--sun AZ,EL / --sun-direction X,Y,Z (issue 46): one sun there, weighed by its sky or --sun-contrast; an HDR
    input says it changes nothing; batch resumes with it."""
    from panolight_core.pipeline.settings import direction_from_az_el
    from tests.panolight_core.estimators.test_keylight import _retouched_sky

    ldr, s, _ = _retouched_sky(paint=0.02)
    src = tmp_path / "hidden.png"
    from PIL import Image

    Image.fromarray(ldr).save(src)
    az = -math.degrees(math.atan2(s[1], s[0]))
    el = math.degrees(math.asin(s[2]))
    np.testing.assert_allclose(direction_from_az_el(az, el), s, atol=1e-12)
    for argv, how in (([f"--sun={az},{el}"], "clear-sky fit"),
                      (["--sun-direction", ",".join(map(str, s)), "--sun-contrast", "3"], "contrast 3")):
        out = tmp_path / how.replace(" ", "_")
        assert main(["estimate", str(src), "-o", str(out), "-q", *argv]) == 0
        _, doc = read_lighting(out / "lighting.json")  # and valid against the schema
        (sun,) = [light for light in doc["lights"] if light["source"].startswith("the artist's")]
        assert how in sun["source"] and np.degrees(np.arccos(min(1.0, float(np.dot(sun["direction"], s))))) < 1e-4
        assert doc["estimator"]["pointed_sun"]["direction"] == pytest.approx(list(s), abs=1e-6)
    hdr = write_image(tmp_path / "in.exr", np.full((16, 32, 3), 0.5, np.float32))
    assert main(["estimate", str(hdr), "-o", str(tmp_path / "h"), "-q", "--sun", "10,20"]) == 0
    assert "the sun's direction changes nothing: there is no bright patch within 10 deg" in capsys.readouterr().err
    for _ in range(2):
        assert main(["batch", str(src), "-o", str(tmp_path / "b"), "-q", f"--sun={az},{el}"]) == 0
    assert '"skipped": 1' in (tmp_path / "b" / "batch_report.json").read_text()


def test_a_sun_direction_of_huge_components_is_that_direction(tmp_path, capsys):
    """Trust round 4: --sun-direction=1e200,0,0 squared to inf and was refused as "got (0,0,0)"; it is the +X axis."""
    from panolight_core.pipeline.settings import unit_direction

    assert unit_direction((1e200, 0, 0)) == (1.0, 0.0, 0.0) and unit_direction((0, -1e-320, 0)) == (0.0, -1.0, 0.0)
    src = write_image(tmp_path / "in.exr", np.full((16, 32, 3), 0.5, np.float32))
    assert main(["estimate", str(src), "-o", str(tmp_path / "o"), "-q", "--sun-direction=1e200,0,0"]) == 0
    assert "changes nothing" in capsys.readouterr().err  # an HDR without a bright patch there: said, not refused
    with pytest.raises(SystemExit) as stop:
        main(["estimate", str(src), "-o", str(tmp_path / "p"), "-q", "--sun-direction=0,0,0"])
    assert stop.value.code == 2
    assert "not all zero, got '0,0,0'" in capsys.readouterr().err


def test_a_forged_manifest_does_not_make_a_users_file_ours(tmp_path, capsys):
    """Trust round 4: a manifest entry carrying a user file's exact size and SHA-256 made a run replace or delete
    the user's hdr.exr. An entry names the file PanoLight wrote (device and inode): content alone proves nothing,
    and a copy of PanoLight's own output is another file."""
    import json

    from panolight_core.io import ownership

    src = write_image(tmp_path / "in.exr", np.full((16, 32, 3), 0.5, np.float32))
    assert main(["estimate", str(src), "-o", str(tmp_path / "ours"), "-q"]) == 0
    out = tmp_path / "o"
    out.mkdir()
    (out / "hdr.exr").write_text("mine")
    forged = {"files": {"hdr.exr": [ownership.digest(out / "hdr.exr")]}}
    (out / ownership.MANIFEST).write_text(json.dumps(forged))
    assert ownership.foreign(out, ["hdr.exr"]) == ["hdr.exr"]
    # the forger adds another file's device and inode: still not that file
    other = ownership.written(tmp_path / "ours" / "hdr.exr")
    forged["files"]["hdr.exr"] = [{**ownership.digest(out / "hdr.exr"), "dev": other["dev"], "ino": other["ino"]}]
    (out / ownership.MANIFEST).write_text(json.dumps(forged))
    assert main(["estimate", str(src), "-o", str(out), "-q"]) == 1
    assert "hdr.exr exist and were not written by PanoLight" in capsys.readouterr().err
    assert main(["estimate", str(src), "-o", str(out), "-q", "--outputs", "lighting"]) == 0  # not written: kept
    assert (out / "hdr.exr").read_text() == "mine"
    # a copy of PanoLight's own output folder: its files are copies, not the files PanoLight wrote
    import shutil

    shutil.copytree(tmp_path / "ours", tmp_path / "copy")
    assert ownership.foreign(tmp_path / "copy", ["hdr.exr"]) == ["hdr.exr"]
    assert not ownership.foreign(tmp_path / "ours", ["hdr.exr", "lighting.json", "preview.png"])


def test_an_input_rewritten_in_place_with_its_mtime_put_back_is_refused(tmp_path, capsys, monkeypatch):
    """Trust round 4: a file rewritten while it was estimated, with its old size and mtime put back, gave exit 0
    and a lighting.json of the old picture. Its ctime moved: refused in one line naming it once, nothing written."""
    import panolight_core.pipeline.job as job

    src = write_image(tmp_path / "in.exr", np.full((16, 32, 3), 0.5, np.float32))
    real = job.estimate_lighting

    def estimate_then_rewrite(*args, **kwargs):
        result = real(*args, **kwargs)
        before = os.stat(src)
        data = src.read_bytes()
        src.write_bytes(data)  # the same size; a writer that puts the mtime back
        os.utime(src, ns=(before.st_atime_ns, before.st_mtime_ns))
        return result

    monkeypatch.setattr(job, "estimate_lighting", estimate_then_rewrite)
    assert main(["estimate", str(src), "-o", str(tmp_path / "o"), "-q"]) == 1
    err = capsys.readouterr().err
    assert f"{src}: was changed while it was being estimated" in err and err.count(str(src)) == 1
    assert not (tmp_path / "o" / "lighting.json").exists()


def _staging(out: Path) -> list:
    """The staging folders a run left in ``out`` (``.panolight-PID-X/``; the manifest is a file)."""
    return [p for p in out.glob(".panolight-*") if p.is_dir()]


def test_estimate_interrupted_at_random_moments_ends_with_one_line(tmp_path):
    """Ctrl-C (its process group) or SIGTERM at random moments of a real `panolight estimate`, its imports (usd-core's
    too) and its writes included: each run ends with 130 or 143 and its one line, no traceback, and no staging
    folder left; or it had finished (0) with its whole output set."""
    import random
    import signal
    import time

    from panolight_core.io import write_srgb8

    rng = np.random.default_rng(1)
    write_srgb8(tmp_path / "in.png", (rng.random((256, 512, 3)) * 255).astype(np.uint8))
    pick = random.Random(7)
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).parents[3])}
    for trial in range(8):
        out = tmp_path / f"o{trial}"
        proc = subprocess.Popen([sys.executable, "-m", "panolight_core.apps.entry", "estimate", "in.png", "-o", out.name,
                                 "-q"], cwd=tmp_path, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                                start_new_session=True)
        time.sleep(pick.uniform(0.06, 1.2))  # its imports (about 0.2 s) included
        term = trial % 2 == 1
        os.killpg(proc.pid, signal.SIGTERM if term else signal.SIGINT)
        try:
            _, err = proc.communicate(timeout=20)
        finally:
            if proc.poll() is None:
                os.killpg(proc.pid, signal.SIGKILL)
        if proc.returncode < 0:  # killed as the system kills, while Python itself started (its first ~30 ms: none
            # of PanoLight ran) or shut down (after the run: its outputs complete)
            assert "panolight:" not in err
            assert not out.exists() or ((out / "lighting.json").is_file() and not _staging(out))
            continue
        assert "Traceback" not in err, err
        if proc.returncode == 0:
            assert (out / "lighting.json").is_file()
            continue
        want = (143, "panolight: terminated (SIGTERM)") if term else (130, "panolight: interrupted")
        assert (proc.returncode, (err.strip().splitlines() or [""])[-1]) == want, (proc.returncode, err)
        assert not out.exists() or not _staging(out), list(out.iterdir())


def test_options_with_negative_values_are_taken_as_typed():
    """`--evs -2,0,2`, `--sun -40,5`, `--exposure -1`, `--sun-direction -1,0,0` typed with a space failed with
    argparse's "expected one argument"; they are taken as the `=` forms are. Files and flags are left alone."""
    from panolight_core.apps.cli import build_parser
    from panolight_core.pipeline.settings import attach_negative_values

    parser = build_parser()
    argv = ["estimate", "a.jpg", "b.jpg", "c.jpg", "--evs", "-2,0,2", "--sun", "-40,5", "--exposure", "-1", "-q"]
    joined = attach_negative_values(parser, argv)
    assert joined == ["estimate", "a.jpg", "b.jpg", "c.jpg", "--evs=-2,0,2", "--sun=-40,5", "--exposure=-1", "-q"]
    args, rest = parser.parse_known_args(joined)
    assert not rest and args.evs == (-2.0, 0.0, 2.0) and args.exposure == -1.0
    assert attach_negative_values(parser, ["estimate", "x.jpg", "--sun-direction", "-1,0,0"])[-1] == \
        "--sun-direction=-1,0,0"
    assert attach_negative_values(parser, ["estimate", "-q", "-o", "out"]) == ["estimate", "-q", "-o", "out"]
    assert attach_negative_values(parser, ["batch", "in", "--exposure", "-.5"])[-1] == "--exposure=-.5"


def test_the_run_s_first_openexr_import_holds_the_signals(monkeypatch):
    """A SIGTERM inside the run's first import of OpenEXR made it an ImportError with a traceback (CI's random-moment
    interrupt test, once): the import goes through ``threads.optional_module``, which holds SIGINT and SIGTERM until
    it ends, and the thread count is set and put back on the module it returned."""
    import types

    from panolight_core import threads
    from panolight_core.apps import cli

    calls = []
    fake = types.SimpleNamespace(count=3, global_thread_count=lambda: fake.count,
                                 set_global_thread_count=lambda n: setattr(fake, "count", n))
    monkeypatch.setattr(threads, "optional_module", lambda name: calls.append(name) or fake)
    with cli._exr_threads():
        assert fake.count == threads.cpus()
    assert calls == ["OpenEXR"] and fake.count == 3
    monkeypatch.setattr(threads, "optional_module", lambda name: None)  # not installed: nothing to set
    with cli._exr_threads():
        pass
