"""A contact sheet of random synthetic samples: LDR (what the camera stored), normals, HDR, relit LDR.

    panolight sheet DATASET -o sheet.png [--count 6] [--seed 0]
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from panolight_core.io import write_srgb8
from panolight_core.pipeline.preview import exposure_for, tonemap


def contact_sheet(dataset, output, count: int = 6, seed: int = 0, height: int = 96) -> Path:
    from PIL import Image, ImageDraw

    from training.neural.relight_data import load_source, make_pair, procedural_pool, synthetic_sources

    sources = synthetic_sources(dataset)
    rng = np.random.default_rng(seed)
    picks = rng.choice(len(sources), size=min(count, len(sources)), replace=False)
    pool = procedural_pool(32, seed=10 ** 6 + seed)
    rows = []
    for i in picks:
        image, normals, mask, hdr = load_source(sources[i])
        relit, _, lam = make_pair(image, normals, mask, pool, np.random.default_rng([seed, int(i)]))
        tiles = [("LDR", np.round(np.clip(image, 0, 1) ** (1 / 2.2) * 255).astype(np.uint8)),
                 ("normals", np.round((normals * 0.5 + 0.5) * mask[..., None] * 255).astype(np.uint8)),
                 ("HDR", tonemap(hdr, exposure_for(hdr))), (f"relit (blend {lam:.2f})", relit)]
        out = []
        for label, t in tiles:
            im = Image.fromarray(t).resize((2 * height, height), Image.NEAREST)
            d = ImageDraw.Draw(im)
            text = f"{sources[i]['path'].stem} {label}"
            d.rectangle((0, 0, 6 * len(text) + 6, 12), fill=(0, 0, 0))
            d.text((3, 0), text, fill=(255, 255, 255))
            out.append(np.asarray(im))
            out.append(np.full((height, 3, 3), 255, np.uint8))
        rows.append(np.concatenate(out[:-1], axis=1))
        rows.append(np.full((3, rows[-1].shape[1], 3), 255, np.uint8))
    sheet = np.concatenate(rows[:-1], axis=0)
    path = Path(output)
    path.parent.mkdir(parents=True, exist_ok=True)
    write_srgb8(path, sheet)
    return path
