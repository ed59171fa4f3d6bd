"""The shared HDRIs that clip their own sun (MANIFEST's ``sun`` column), each estimated as it is and with the artist's
click on its sun (``--sun``: on an HDR whose plateau was resampled away, the bright patch there is restored): a white
sphere under each, seen from the side so the sun's light and shadow sides show, and the shadow contrast C a surface
facing the sun gets (EVALUATION.md; 1: no shadow).

The click is the file's brightest pixel, as an artist clicks the bright patch; a file whose plateau is exact
(found without a click) is shown restored as found, the click changing nothing but the light's place.

    python -m training.experiments.clicked_hdris [--out docs/studies/clicked_hdris.jpg]
"""
from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

from panolight_core import metrics, sh
from panolight_core.camera.color import LUMINANCE_WEIGHTS
from panolight_core.pipeline.estimate import estimate_lighting
from panolight_core.pipeline.preview import diffuse_sphere, exposure_for, tonemap
from panolight_core.pipeline.settings import Settings
from training.common.real_hdri import DEFAULT_HDRI, manifest

SIZE = 200


def side_sphere(model, sun: np.ndarray, size: int = SIZE) -> np.ndarray:
    """(size, size, 3) linear image of a white Lambertian sphere (albedo 0.8) lit by ``model`` (an
    adaptive.LightingModel), seen from the horizon 90 degrees round from the sun: the sun lights its left half.
    The preview's sphere (``preview.diffuse_sphere``, camera along +X), its normals turned about Z to that view."""
    yaw = math.atan2(sun[1], sun[0]) - math.pi / 2  # the camera looks along this azimuth, the sun to its left
    turn = np.array([[math.cos(yaw), -math.sin(yaw), 0.0], [math.sin(yaw), math.cos(yaw), 0.0], [0.0, 0.0, 1.0]])

    class Turned:  # the model as the turned camera's sphere sees it
        @staticmethod
        def irradiance(normals):
            return model.irradiance(normals @ turn.T)

    return diffuse_sphere(Turned, size)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m training.experiments.clicked_hdris", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--hdri", type=Path, default=DEFAULT_HDRI, help="folder of real HDR panoramas (default: %(default)s)")
    ap.add_argument("--out", type=Path, default=None, help="write the contact sheet here (JPEG)")
    args = ap.parse_args(argv)
    from PIL import Image, ImageDraw

    from training.common.real_hdri import load_hdr

    rows = []
    print("| file | kind | click (az, el) | C as it is | C clicked | restored | key light |")
    print("|---|---|---|---:|---:|---|---|")
    for row in manifest(args.hdri):
        if not (row["sun"].startswith("clipped") or "lower bound" in row["sun"]):
            continue
        hdr = load_hdr(args.hdri / row["file"]).astype(np.float32)
        lum = hdr @ LUMINANCE_WEIGHTS.astype(np.float32)
        y, x = np.unravel_index(int(np.argmax(lum)), lum.shape)
        sun = sh.pixel_directions(*lum.shape)[y, x]
        az, el = -math.degrees(math.atan2(sun[1], sun[0])), math.degrees(math.asin(sun[2]))
        as_is = estimate_lighting(hdr)
        clicked = estimate_lighting(hdr, Settings(sun_direction=tuple(float(v) for v in sun)))
        c0, c1 = (metrics.model_shadow_contrast(r.model, sun) for r in (as_is, clicked))
        restored = clicked.document["estimator"].get("restoration", {})
        how = ("declared by the click" if restored.get("declared") else "found" if restored.get("restored")
               else "not restored: " + "; ".join(clicked.warnings))
        key = metrics.brightest_light(clicked.model.lights)
        print(f"| {row['file']} | {row['kind']} | {az:.0f}, {el:.0f} | {c0:.2f} | {c1:.2f} | {how} | "
              f"{key['source'] if key else 'none'} |")
        scale = exposure_for(hdr)
        tiles = [tonemap(hdr[::2, ::2], scale)] + [tonemap(side_sphere(r.model, sun), scale)
                                                   for r in (as_is, clicked)]
        rows.append((row["file"], tiles, (c0, c1)))
    if args.out and rows:
        pano_w = rows[0][1][0].shape[1] * SIZE // rows[0][1][0].shape[0]
        sheet = Image.new("RGB", (pano_w + 2 * SIZE + 8, len(rows) * (SIZE + 18)), "white")
        draw = ImageDraw.Draw(sheet)
        for i, (name, (pano, left, right), (c0, c1)) in enumerate(rows):
            top = i * (SIZE + 18)
            sheet.paste(Image.fromarray(pano).resize((pano_w, SIZE)), (0, top + 18))
            sheet.paste(Image.fromarray(left), (pano_w + 4, top + 18))
            sheet.paste(Image.fromarray(right), (pano_w + SIZE + 8, top + 18))
            draw.text((2, top + 3), name, fill="black")
            draw.text((pano_w + 6, top + 3), f"as it is: C {c0:.2f}", fill="black")
            draw.text((pano_w + SIZE + 10, top + 3), f"sun clicked: C {c1:.2f}", fill="black")
        args.out.parent.mkdir(parents=True, exist_ok=True)
        sheet.save(args.out, quality=88)
        print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
