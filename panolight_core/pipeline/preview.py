"""Tone-mapped preview strips (PNG) so people can look rather than read numbers."""
from __future__ import annotations

import numpy as np

from ..camera.color import linear_to_srgb, luminance
from ..camera.resample import area_downsample, sample_equirect


PREVIEW_HEIGHT = 256  # rows of each preview tile


def exposure_for(image: np.ndarray) -> float:
    """Scale putting the median luminance at 0.18 (the EVALUATION.md auto-exposure), 1 if degenerate."""
    med = float(np.median(luminance(image)))
    return 0.18 / med if med > 0 and np.isfinite(med) else 1.0


def tonemap(image: np.ndarray, scale: float) -> np.ndarray:
    """(H, W, 3) linear -> uint8 sRGB after multiplying by ``scale`` and clipping."""
    return np.round(linear_to_srgb(np.asarray(image, dtype=np.float64) * scale) * 255).astype(np.uint8)


def strip(panels: list[tuple[str, np.ndarray]], height: int = 256) -> np.ndarray:
    """Side-by-side uint8 image of labelled (name, linear image) panels resized to a common height.

    Each panel is auto-exposed on its own (median luminance -> 0.18): SH maps spread a sun's energy
    over the sphere, so one shared exposure would clip them to white.
    """
    from PIL import Image

    tiles = []
    for name, img in panels:
        img = area_downsample(np.asarray(img), height)  # average in linear light before tone mapping
        tile = Image.fromarray(tonemap(img, exposure_for(img))).resize((2 * height, height), Image.BILINEAR)
        tiles.append(_labelled(tile, name))
    gap = np.full((height, 4, 3), 255, dtype=np.uint8)
    out = [tiles[0]]
    for t in tiles[1:]:
        out += [gap, t]
    return np.concatenate(out, axis=1)


def diffuse_sphere(model, size: int = 256, albedo: float = 0.8, irradiance_map=None) -> np.ndarray:
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
        shade = albedo / np.pi * sample_equirect(irradiance_map, normals)
    elif hasattr(model, "irradiance"):
        shade = albedo / np.pi * model.irradiance(normals)
    else:
        shade = albedo / np.pi * sh.irradiance(np.asarray(model, dtype=np.float64), normals)
    out[inside] = shade
    bg = np.median(shade, axis=0) if shade.size else np.zeros(3)
    out[~inside] = np.clip(bg.mean(), 0.0, None) * 0.5
    return out


def estimate_preview(image: np.ndarray, radiance: np.ndarray, model, lmax: int,
                     height: int = 256, irradiance_map=None) -> np.ndarray:
    """uint8 strip: input | SH radiance | diffuse sphere under the estimated light (each auto-exposed).

    model: SH coefficients or an adaptive.LightingModel (its lights then light the sphere too)."""
    n_lights = len(getattr(model, "lights", []))
    label = f"SH radiance (lmax {lmax})" + (f" + {n_lights} light(s)" if n_lights else "")
    panels = strip([("input", image), (label, radiance)], height)
    sphere = diffuse_sphere(model, height, irradiance_map=irradiance_map)
    from PIL import Image

    tile = _labelled(Image.fromarray(tonemap(sphere, exposure_for(sphere))), "diffuse sphere (view +X)")
    gap = np.full((height, 4, 3), 255, dtype=np.uint8)
    return np.concatenate([panels, gap, tile], axis=1)


def _labelled(tile, name: str) -> np.ndarray:
    """A PIL tile with ``name`` written top left, white on black, as a uint8 array."""
    from PIL import ImageDraw

    draw = ImageDraw.Draw(tile)
    draw.rectangle((0, 0, 8 + 7 * len(name), 16), fill=(0, 0, 0))
    draw.text((4, 2), name, fill=(255, 255, 255))
    return np.asarray(tile)
