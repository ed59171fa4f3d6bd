"""One panorama in, a lighting folder out: the job behind ``panolight estimate`` and ``batch``."""
from __future__ import annotations

import hashlib
import math
import time
from pathlib import Path

import numpy as np

from .. import sh
from ..camera import ldr_to_linear
from ..estimators import estimate, resolve
from ..estimators.highlights import CLIP_LEVEL
from ..io import read_image, write_image
from ..io.atomic import pid_alive
from ..io.lighting import make_lighting, write_lighting
from ..lighting.adaptive import LightingModel, fit_model
from ..errors import PanoLightError
from ..lighting.order import DEFAULT_MAX_ORDER, DEFAULT_TOLERANCE
from ..sh.window import default_width

OUTPUT_FILES = ("lighting.json", "hdr.exr", "radiance.exr", "irradiance.exr", "preview.png")


def fit_pixels(pixels: np.ndarray, *, lmax=None, estimator: str = "auto", model: str = "auto",
               tolerance: float = DEFAULT_TOLERANCE, deringing: str | None = None):
    """Panorama pixels (uint8 sRGB LDR or float linear HDR) -> (LightingModel, Estimate).

    The one implementation behind ``panolight estimate`` and the Blender add-on. lmax: None (auto for
    model "auto", 2 for "sh"), "auto" or an int. deringing: None = the model's default ("auto" with
    lights, "none" for SH only).
    """
    if model not in ("auto", "sh"):
        raise PanoLightError(f"model must be 'auto' or 'sh', got {model!r}")
    lmax = ("auto" if model == "auto" else "2") if lmax is None else str(lmax)
    est = estimate(pixels, DEFAULT_MAX_ORDER if lmax == "auto" else int(lmax), estimator)
    return fit_radiance(est.radiance, hdr_input=pixels.dtype != np.uint8, lmax=lmax, model=model,
                        tolerance=tolerance, deringing=deringing), est


def fit_radiance(radiance: np.ndarray, *, hdr_input: bool, lmax="auto", model: str = "auto",
                 tolerance: float = DEFAULT_TOLERANCE, deringing: str | None = None) -> LightingModel:
    """The lighting model of an estimator's linear radiance map (the second half of ``fit_pixels``; the
    evaluation scores estimates with it). hdr_input: the map is an HDR file's (lights above the median,
    not above the LDR clip level). lmax: "auto" or an int (as a string or int)."""
    lmax = str(lmax)
    order = DEFAULT_MAX_ORDER if lmax == "auto" else int(lmax)
    return fit_model(radiance, lights=model == "auto", lmax=lmax, tolerance=tolerance, max_order=order,
                     deringing=deringing or ("auto" if model == "auto" else "none"),
                     light_threshold=None if hdr_input else CLIP_LEVEL)


def run_estimate(src, out_dir, *, lmax=None, estimator: str = "auto", model: str = "auto",
                 exposure_ev: float = 0.0, window: str = "none", window_width: float | None = None,
                 tolerance: float = DEFAULT_TOLERANCE, resolution=(512, 256), repair_nonfinite: bool = False,
                 max_megapixels: float | None = None, overwrite: bool = False, log=None) -> dict:
    """Estimate the lighting of panorama ``src`` and write OUTPUT_FILES into ``out_dir`` (created).

    model: "auto" (explicit lights for compact sources + the SH order the scene needs, deringed only if
    ringing would show; see adaptive.py) or "sh" (SH only). lmax: None (auto for model "auto", 2 for
    "sh"), "auto", or an int (a fixed order). window: "none" leaves deringing to the model; "auto" or a
    family name forces it. Returns the lighting document written. Raises PanoLightError on bad input.
    """
    log = log or (lambda msg: None)
    src, out_dir = Path(src), Path(out_dir)
    resolve(estimator)  # a wrong estimator name fails before any reading
    if model not in ("auto", "sh"):
        raise PanoLightError(f"--model must be 'auto' or 'sh', got {model!r}")
    for name in OUTPUT_FILES:  # an output never replaces the input (estimate hdr.exr -o . would)
        if (out_dir / name).resolve() == src.resolve():
            raise PanoLightError(f"{src}: the output {name} in {out_dir} would overwrite the input; "
                                 f"choose another output folder (-o)")
    if not overwrite:
        _check_foreign_outputs(out_dir)
    t0 = time.perf_counter()
    log(f"reading {src}")
    budget = {} if max_megapixels is None else {"max_megapixels": max_megapixels}
    pixels = read_image(src, ldr_as_uint8=True, nonfinite="repair" if repair_nonfinite else "error", **budget)
    t_read = time.perf_counter() - t0
    log(f"estimating ({estimator}, model {model}, lmax {lmax or 'default'}) on {pixels.shape[1]}x{pixels.shape[0]}")
    t1 = time.perf_counter()
    fitted, est = fit_pixels(pixels, lmax=lmax, estimator=estimator, model=model, tolerance=tolerance,
                             deringing=None if window == "none" else "none")
    t_est = est.info["estimate_s"]
    hdr = pixels.dtype != np.uint8
    coeffs, lights = fitted.coeffs, fitted.lights
    window_info = fitted.info["ringing"]["window"]
    if window != "none":
        if window == "auto":
            width = sh.auto_window_width(coeffs, target="radiance")
            window_info = {"kind": "sinc4", "mode": "auto", "target": "radiance",
                           "width": None if math.isinf(width) else width}
            if not math.isinf(width):
                coeffs = sh.window(coeffs, "sinc4", width)
        else:
            width = window_width or default_width(sh.lmax_from_count(coeffs.shape[0]))
            coeffs = sh.window(coeffs, window, width)
            window_info = {"kind": window, "mode": "fixed", "width": width}
    scale = 2.0 ** exposure_ev
    coeffs = coeffs * scale
    lights = [dict(light, intensity=light["intensity"] * scale) for light in lights]
    fitted = LightingModel(lights, coeffs, fitted.info)
    t_model = time.perf_counter() - t1 - t_est
    w, h = resolution
    log(f"reconstructing radiance and irradiance at {w}x{h}" + (f" ({len(lights)} light(s))" if lights else ""))
    from .hdri import hdr_panorama

    with np.errstate(over="ignore", invalid="ignore"):
        radiance = sh.reconstruct(coeffs, h, w).astype(np.float32)
        irradiance = fitted.irradiance_map(h, w).astype(np.float32)
        hdri = hdr_panorama(pixels, est)
        if scale != 1.0:  # scaled in place by row blocks: a 16K HDRI is 1.6 GB, one copy is enough
            if hdri is pixels:
                hdri = hdri.copy()
            for r in range(0, hdri.shape[0], 256):
                hdri[r:r + 256] *= np.float32(scale)
    outputs = {"the SH coefficients": coeffs, "radiance.exr": radiance, "irradiance.exr": irradiance,
               "hdr.exr": hdri, "the lights": np.array([light["intensity"] for light in lights], dtype=np.float64)}
    bad = [name for name, a in outputs.items()
           if not all(np.isfinite(a[r:r + 256]).all() for r in range(0, max(len(a), 1), 256))]
    if bad:  # refuse before writing anything: an all-Inf EXR is a silent wrong answer
        raise PanoLightError(f"{src}: {', '.join(bad)} would not be finite (the input's radiance times "
                             f"2^{exposure_ev:g} overflows 32-bit floats); lower --exposure or rescale the input")
    out_dir.mkdir(parents=True, exist_ok=True)
    log(f"writing {out_dir}/")
    with _folder_lock(out_dir):
        return _write_outputs(out_dir, src, pixels, hdr, est, fitted, coeffs, lights, window_info, exposure_ev,
                              radiance, irradiance, hdri, t_read, t_model)


def _write_outputs(out_dir, src, pixels, hdr, est, fitted, coeffs, lights, window_info, exposure_ev,
                   radiance, irradiance, hdri, t_read, t_model) -> dict:
    t2 = time.perf_counter()
    est_info = {k: v for k, v in est.info.items() if k not in ("clipped_regions", "estimate_s")}
    model_info = dict(fitted.info, window=window_info)
    doc = make_lighting(
        coeffs, lights=lights,
        units="input radiance units" if hdr else "relative: 1 = the LDR camera's clip level (white)",
        source={"path": str(src), "sha256": hashlib.sha256(src.read_bytes()).hexdigest(),
                "width": int(pixels.shape[1]), "height": int(pixels.shape[0]),
                "dynamic_range": "hdr" if hdr else "ldr-8bit-srgb"},
        estimator=est_info, model=model_info, order=model_info["order"], window=window_info,
        exposure_ev=exposure_ev, clipped_regions=est.info.get("clipped_regions", []),
        timings={"read_s": round(t_read, 6), "estimate_s": round(est.info["estimate_s"], 6),
                 "model_s": round(t_model, 6)},
    )
    from .preview import estimate_preview

    shown = ldr_to_linear(pixels) if not hdr else pixels
    preview = estimate_preview(shown, radiance, fitted, sh.lmax_from_count(coeffs.shape[0]))
    import os
    import shutil

    # the whole set is written into a private folder and renamed into place, lighting.json last: an
    # interrupted run leaves nothing half-done, and readers never see a mix of two runs
    stage = out_dir / f".panolight-{os.getpid()}"
    stage.mkdir(exist_ok=True)
    try:
        write_image(stage / "hdr.exr", hdri)
        write_image(stage / "radiance.exr", radiance)
        write_image(stage / "irradiance.exr", irradiance)
        _write_png(stage / "preview.png", preview)
        doc["timings"]["write_s"] = round(time.perf_counter() - t2, 6)
        write_lighting(stage / "lighting.json", doc)
        for name in OUTPUT_FILES[1:] + OUTPUT_FILES[:1]:  # lighting.json (first in the list) moves last
            os.replace(stage / name, out_dir / name)
    finally:
        shutil.rmtree(stage, ignore_errors=True)
    return doc


def _check_foreign_outputs(out_dir: Path) -> None:
    """Refuse to replace files PanoLight did not write: output names that exist in a folder without a
    valid lighting.json of an earlier run (``overwrite=True`` / --overwrite replaces them)."""
    present = [n for n in OUTPUT_FILES if (out_dir / n).exists()]
    if not present:
        return
    from ..io.lighting import read_lighting

    try:
        read_lighting(out_dir / "lighting.json")
        return  # an earlier PanoLight run: its outputs are ours to replace
    except PanoLightError:
        pass
    raise PanoLightError(f"{out_dir}: {', '.join(present)} exist and were not written by PanoLight; "
                         f"choose another folder (-o) or pass --overwrite to replace them")


class _folder_lock:
    """One writer per output folder: OUT/.panolight.lock holds the writer's pid (created exclusively). A
    second writer is refused in one line; a lock left by a process that no longer runs is taken over."""

    def __init__(self, folder: Path):
        self.path = Path(folder) / ".panolight.lock"

    def __enter__(self):
        import os

        for _ in range(2):
            try:
                fd = os.open(self.path, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
            except FileExistsError:
                try:
                    pid = int(self.path.read_text().strip() or 0)
                except (OSError, ValueError):
                    pid = 0
                if pid and pid_alive(pid):
                    raise PanoLightError(f"{self.path.parent}: another PanoLight process (pid {pid}) is writing "
                                         f"there; wait for it or choose another folder (-o)") from None
                self.path.unlink(missing_ok=True)  # stale: its writer is gone
                continue
            with os.fdopen(fd, "w") as f:
                f.write(str(os.getpid()))
            return self
        raise PanoLightError(f"{self.path.parent}: cannot take the output folder's lock {self.path.name}")

    def __exit__(self, *exc):
        self.path.unlink(missing_ok=True)
        return False


def _write_png(path: Path, rgb8: np.ndarray):
    """8-bit RGB PNG (into the private staging folder, which is what makes the output set atomic)."""
    from PIL import Image

    Image.fromarray(rgb8, "RGB").save(path)
