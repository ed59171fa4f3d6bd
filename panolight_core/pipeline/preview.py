"""Tone-mapped preview strips (PNG) so people can look rather than read numbers."""
from __future__ import annotations

import math

import numpy as np

from ..camera.color import linear_to_srgb, luminance
from ..camera.resample import area_downsample, sample_equirect

PREVIEW_HEIGHT = 256  # rows of each preview tile
SH_PEAK_PERCENTILE = 99.0  # the SH panel is darkened (and labelled so) until this percentile's luminance is white


def exposure_for(image: np.ndarray) -> float:
    """Scale putting the median luminance at 0.18 (the EVALUATION.md auto-exposure), 1 if degenerate."""
    med = float(np.median(luminance(image)))
    return 0.18 / med if med > 0 and np.isfinite(med) else 1.0


def tonemap(image: np.ndarray, scale: float) -> np.ndarray:
    """(H, W, 3) linear -> uint8 sRGB after multiplying by ``scale`` and clipping."""
    return np.round(linear_to_srgb(np.asarray(image, dtype=np.float64) * scale) * 255).astype(np.uint8)


def strip(panels: list[tuple[str, np.ndarray]], height: int = 256, scale: float | None = None,
          lights: list | None = None) -> np.ndarray:
    """Side-by-side uint8 image of labelled (name, linear image) panels resized to a common height (plus the
    CAPTION_ROWS band above each that holds its name).

    scale: one exposure for every panel (so they compare); None: each panel auto-exposed on its own (median
    luminance -> 0.18). lights: lighting-file light dicts, marked on every panel (``mark_lights``).
    """
    from PIL import Image

    tiles = []
    for name, img in panels:
        img = area_downsample(np.asarray(img), height)  # average in linear light before tone mapping
        tile = Image.fromarray(tonemap(img, exposure_for(img) if scale is None else scale))
        tile = tile.resize((2 * height, height), Image.BILINEAR)
        if lights:
            mark_lights(tile, lights)
        tiles.append(_labelled(tile, name))
    gap = np.full((height + CAPTION_ROWS, 4, 3), 255, dtype=np.uint8)
    out = [tiles[0]]
    for t in tiles[1:]:
        out += [gap, t]
    return np.concatenate(out, axis=1)


CAPTION_ROWS = 16  # the band above each tile that holds its label: a label never covers the picture


def mark_lights(tile, lights: list) -> None:
    """Draw each light of ``lights`` (lighting-file dicts, in lighting.json's ``lights[]`` order) on a PIL
    equirect ``tile`` (Blender world frame, CONVENTIONS.md) as a ring, black outside white, labelled with its
    index in ``lights[]``: visible on sky and ground. Labels are placed beside their ring where they cover no
    other ring or label (``label_boxes``), so overlapping rings keep readable numbers."""
    from PIL import ImageDraw

    from ..sh.grid import pixel_coordinates

    draw = ImageDraw.Draw(tile)
    h, w = tile.height, tile.width
    r = max(4, h // 40)
    centres = []
    for light in lights:
        y, x = pixel_coordinates(np.asarray(light["direction"], dtype=np.float64), h, w)
        centres.append((float(x) + 0.5, float(y) + 0.5))
    for cx, cy in centres:
        for dx in (-w, 0, w):  # a ring at the seam shows on both edges
            draw.ellipse((cx + dx - r - 1, cy - r - 1, cx + dx + r + 1, cy + r + 1), outline=(0, 0, 0), width=2)
            draw.ellipse((cx + dx - r + 1, cy - r + 1, cx + dx + r - 1, cy + r - 1), outline=(255, 255, 255), width=1)
    for n, (x0, y0, x1, y1) in enumerate(label_boxes(centres, r, w, h)):
        draw.rectangle((x0, y0, x1, y1), fill=(0, 0, 0))
        draw.text((x0 + 2, y0 + 1), str(n), fill=(255, 255, 255))


LABEL_CHAR_W, LABEL_BOX_H = 7, 12  # a light's index label: pixels per digit, and its height


def label_boxes(centres, r: float, width: int, height: int) -> list[tuple]:
    """(x0, y0, x1, y1) of each light's index label (its position in ``centres``: ``lights[]`` order), inside
    the tile: the first of the places right, left, above and below its ring (then further out) that overlaps
    no ring and no label placed before it; the nearest place right of its ring when none is free."""
    boxes: list[tuple] = []
    rings = [(cx - r - 1, cy - r - 1, cx + r + 1, cy + r + 1) for cx, cy in centres]

    def hits(a, b):
        return a[0] < b[2] and b[0] < a[2] and a[1] < b[3] and b[1] < a[3]

    for n, (cx, cy) in enumerate(centres):
        bw = LABEL_CHAR_W * len(str(n)) + 4
        choice = None
        for step in (0, 1, 2, 3, 4):
            gap = r + 3 + step * (LABEL_BOX_H + 2)
            for x0, y0 in ((cx + gap, cy - LABEL_BOX_H / 2), (cx - gap - bw, cy - LABEL_BOX_H / 2),
                           (cx - bw / 2, cy - gap - LABEL_BOX_H), (cx - bw / 2, cy + gap)):
                x0 = min(max(x0, 0), width - bw - 1)
                y0 = min(max(y0, 0), height - LABEL_BOX_H - 1)
                box = (x0, y0, x0 + bw, y0 + LABEL_BOX_H)
                if choice is None:
                    choice = box  # the fallback: right of the ring
                if not any(hits(box, o) for o in rings + boxes):
                    choice = box
                    break
            else:
                continue
            break
        boxes.append(tuple(int(round(v)) for v in choice))
    return boxes


SPHERE_ALBEDO = 0.8  # the preview sphere's white: a real white paint, not a perfect reflector


def diffuse_sphere(model, size: int = 256, irradiance_map=None) -> np.ndarray:
    """(size, size, 3) linear image of a white Lambertian sphere lit by ``model``: SH radiance
    coefficients (K, 3), or anything with an ``irradiance(normals)`` method (adaptive.LightingModel).
    irradiance_map: the model's (H, W, 3) equirect irradiance, if already made (irradiance.exr): the
    sphere then looks it up (bilinear) instead of evaluating the model again.

    The camera sits at the panorama's centre looking along +X (the middle of the panorama) with +Z up,
    so image right is -Y: the sphere is what an object placed in front of the viewer would look like.
    Outside the sphere the pixels are a neutral grey at the sphere's median brightness.
    """
    from .. import sh

    t = (np.arange(size) + 0.5) / size * 2.0 - 1.0
    a, b = np.meshgrid(t, -t)
    r2 = a * a + b * b
    inside = r2 < 1.0
    c = np.sqrt(np.clip(1.0 - r2, 0.0, 1.0))
    normals = np.stack([-c, -a, b], axis=-1)[inside]
    out = np.zeros((size, size, 3))
    if irradiance_map is not None:
        shade = SPHERE_ALBEDO / np.pi * sample_equirect(irradiance_map, normals)
    elif hasattr(model, "irradiance"):
        shade = SPHERE_ALBEDO / np.pi * model.irradiance(normals)
    else:
        shade = SPHERE_ALBEDO / np.pi * sh.irradiance(np.asarray(model, dtype=np.float64), normals)
    out[inside] = shade
    bg = np.median(shade, axis=0) if shade.size else np.zeros(3)
    out[~inside] = np.clip(bg.mean(), 0.0, None) * 0.5
    return out


def estimate_preview(image: np.ndarray, radiance: np.ndarray, model, lmax: int,
                     height: int = 256, irradiance_map=None, exposure: float | None = None,
                     model_gain: float = 1.0) -> np.ndarray:
    """uint8 strip: input | SH radiance | diffuse sphere under the estimated light, all at one exposure, with
    the model's explicit lights marked (labelled with their ``lights[]`` index) on the input and the SH
    radiance; each tile's label is in a band above it (CAPTION_ROWS), never over the picture.

    image: the input, linear (H, W, 3); exposure: its display scale (an LDR photo's own is 1: it shows as
    shot; None: its median luminance -> 0.18, for HDR). The sphere shares it, so it looks as a white object
    composited into the photo would; so does the SH radiance, darkened where the recovered light would clip
    it (its SH_PEAK_PERCENTILE luminance -> white; the label gives the offset in EV). An SH map that is zero
    over most of the sphere (its non-negative emitter) thus never sets its exposure from that zero.
    model_gain: the factor the model carries over the input (2^exposure_ev). model: SH coefficients or an
    adaptive.LightingModel (its lights then light the sphere too)."""
    lights = list(getattr(model, "lights", []))  # lighting.json's order: the preview's numbers are its indices
    label = f"SH radiance (lmax {lmax})" + (f" + {len(lights)} light(s)" if lights else "")
    scale = exposure_for(image) if exposure is None else float(exposure)
    panels = strip([("input", image)], height, scale, lights)
    sh_scale = scale / model_gain
    peak = float(np.percentile(luminance(np.asarray(radiance, dtype=np.float64)), SH_PEAK_PERCENTILE))
    if np.isfinite(peak) and peak * sh_scale > 1.0:  # a recovered sun spread over the sphere: darker, not clipped
        label += f", {math.log2(1.0 / (peak * sh_scale)):+.1f} EV"
        sh_scale = 1.0 / peak
    shown = strip([(label, radiance)], height, sh_scale, lights)
    sphere = diffuse_sphere(model, height, irradiance_map=irradiance_map)
    from PIL import Image

    tile = _labelled(Image.fromarray(tonemap(sphere, scale / model_gain)), "diffuse sphere (view +X)")
    gap = np.full((height + CAPTION_ROWS, 4, 3), 255, dtype=np.uint8)
    return np.concatenate([panels, gap, shown, gap, tile], axis=1)


def _labelled(tile, name: str) -> np.ndarray:
    """A PIL tile with ``name`` written in a black band of CAPTION_ROWS above it, as a uint8 array."""
    from PIL import Image, ImageDraw

    out = Image.new("RGB", (tile.width, tile.height + CAPTION_ROWS), (0, 0, 0))
    out.paste(tile, (0, CAPTION_ROWS))
    ImageDraw.Draw(out).text((4, 2), name, fill=(255, 255, 255))
    return np.asarray(out)
