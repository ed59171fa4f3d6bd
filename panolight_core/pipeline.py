"""One panorama in, a lighting folder out: the job behind ``panolight estimate`` and ``batch``."""
from __future__ import annotations

import hashlib
import math
import time
from pathlib import Path

import numpy as np

from . import sh
from .camera import ldr_to_linear
from .estimators import Estimate, estimate, resolve
from .io import read_image, write_image
from .lighting import make_lighting, write_lighting
from .order import DEFAULT_MAX_ORDER, DEFAULT_TOLERANCE, select_order
from .sh.window import default_width

OUTPUT_FILES = ("lighting.json", "radiance.exr", "irradiance.exr", "preview.png")


def run_estimate(src, out_dir, *, lmax="2", estimator: str = "auto", exposure_ev: float = 0.0,
                 window: str = "none", window_width: float | None = None, tolerance: float = DEFAULT_TOLERANCE,
                 resolution=(512, 256), repair_nonfinite: bool = False, log=None) -> dict:
    """Estimate the lighting of panorama ``src`` and write OUTPUT_FILES into ``out_dir`` (created).

    lmax: an int (as int or str) or "auto" (smallest order 0..8 within ``tolerance``, see order.py).
    Returns the lighting document written. Raises PanoLightError subclasses on bad input.
    """
    log = log or (lambda msg: None)
    src, out_dir = Path(src), Path(out_dir)
    resolve(estimator)  # a wrong estimator name fails before any reading
    t0 = time.perf_counter()
    log(f"reading {src}")
    pixels = read_image(src, ldr_as_uint8=True, nonfinite="repair" if repair_nonfinite else "error")
    t_read = time.perf_counter() - t0
    auto = str(lmax) == "auto"
    order = int(DEFAULT_MAX_ORDER if auto else lmax)
    log(f"estimating ({estimator}, lmax {'auto' if auto else order}) on {pixels.shape[1]}x{pixels.shape[0]}")
    est: Estimate = estimate(pixels, order, estimator)
    coeffs = est.coeffs
    order_info = {"mode": "fixed", "lmax": order}
    if auto:
        chosen, errs = select_order(coeffs, tolerance)
        coeffs = coeffs[:(chosen + 1) ** 2]
        order_info = {"mode": "auto", "lmax": chosen, "tolerance": tolerance, "max_order": order,
                      "irradiance_error_per_order": [round(e, 6) for e in errs],
                      "why": f"smallest order whose diffuse relighting error is <= {tolerance:g} of the mean"}
    window_info = None
    if window != "none":
        if window == "auto":
            width = sh.auto_window_width(coeffs, target="radiance")
            window_info = {"kind": "sinc4", "mode": "auto", "width": None if math.isinf(width) else width}
            if not math.isinf(width):
                coeffs = sh.window(coeffs, "sinc4", width)
        else:
            width = window_width or default_width(sh.lmax_from_count(coeffs.shape[0]))
            coeffs = sh.window(coeffs, window, width)
            window_info = {"kind": window, "mode": "fixed", "width": width}
    coeffs = coeffs * 2.0 ** exposure_ev
    w, h = resolution
    log(f"reconstructing radiance and irradiance at {w}x{h}")
    radiance = sh.reconstruct(coeffs, h, w).astype(np.float32)
    irradiance = sh.irradiance_map(coeffs, h, w).astype(np.float32)
    out_dir.mkdir(parents=True, exist_ok=True)
    log(f"writing {out_dir}/")
    t1 = time.perf_counter()
    hdr = pixels.dtype != np.uint8
    est_info = {k: v for k, v in est.info.items() if k not in ("clipped_regions", "estimate_s")}
    doc = make_lighting(
        coeffs,
        units="input radiance units" if hdr else "relative: 1 = the LDR camera's clip level (white)",
        source={"path": str(src), "sha256": hashlib.sha256(src.read_bytes()).hexdigest(),
                "width": int(pixels.shape[1]), "height": int(pixels.shape[0]),
                "dynamic_range": "hdr" if hdr else "ldr-8bit-srgb"},
        estimator=est_info, order=order_info, window=window_info, exposure_ev=exposure_ev,
        clipped_regions=est.info.get("clipped_regions", []),
        timings={"read_s": round(t_read, 6), "estimate_s": round(est.info["estimate_s"], 6)},
    )
    from .preview import estimate_preview

    shown = ldr_to_linear(pixels) if not hdr else pixels
    preview = estimate_preview(shown, radiance, coeffs, sh.lmax_from_count(coeffs.shape[0]))
    write_image(out_dir / "radiance.exr", radiance)
    write_image(out_dir / "irradiance.exr", irradiance)
    _write_png(out_dir / "preview.png", preview)
    doc["timings"]["write_s"] = round(time.perf_counter() - t1, 6)
    write_lighting(out_dir / "lighting.json", doc)
    return doc


def _write_png(path: Path, rgb8: np.ndarray):
    from PIL import Image

    Image.fromarray(rgb8, "RGB").save(path)
