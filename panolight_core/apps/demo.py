"""``panolight demo``: a phone-like JPEG made from a bundled HDRI, its lighting estimated and scored."""
from __future__ import annotations

import logging
from pathlib import Path

from .. import metrics
from ..camera import hdr_to_ldr
from ..data import load_studio_hdri
from ..io import read_image, write_srgb8
from ..io.lighting import read_lighting
from ..pipeline import run_estimate

logger = logging.getLogger(__name__)


def run_demo(scene: str, ev: float, out, settings, **job) -> dict:
    """Write out/input.jpg (auto exposure at ev, JPEG q90) from Blender's ``scene`` HDRI, estimate it into
    ``out`` (pipeline.run_estimate with settings and job options) and return metrics.score_lighting's
    comparison with the HDR's exact irradiance."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    hdr = load_studio_hdri(scene)
    src = write_srgb8(out / "input.jpg", hdr_to_ldr(hdr, ev), quality=90)
    logger.info(f"demo: made {src} from Blender's '{scene}' HDRI (auto exposure, ev {ev:+g}, JPEG q90)")
    run_estimate(src, out, settings, **job)
    coeffs, doc = read_lighting(out / "lighting.json")
    return dict(metrics.score_lighting(hdr, coeffs, doc["lights"], read_image(src)), lights=len(doc["lights"]),
                lmax=doc["lmax"], lighting=doc)
