"""Tone-mapped preview strips (PNG) so people can look rather than read numbers."""
from __future__ import annotations

import numpy as np

from .color import linear_to_srgb, luminance


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
    from PIL import Image, ImageDraw

    tiles = []
    for name, img in panels:
        tile = Image.fromarray(tonemap(img, exposure_for(img))).resize((2 * height, height), Image.BILINEAR)
        draw = ImageDraw.Draw(tile)
        draw.rectangle((0, 0, 8 + 7 * len(name), 16), fill=(0, 0, 0))
        draw.text((4, 2), name, fill=(255, 255, 255))
        tiles.append(np.asarray(tile))
    gap = np.full((height, 4, 3), 255, dtype=np.uint8)
    out = [tiles[0]]
    for t in tiles[1:]:
        out += [gap, t]
    return np.concatenate(out, axis=1)
