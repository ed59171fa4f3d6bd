"""Training pairs by relighting (paper Sec. 3.2): data sources, the lighting pool, a torch Dataset.

Sources of panoramas with normals:
- ``synthetic_sources(root)``: samples written by ``panolight synth``; the "original image" is what the
  camera would have stored of the rendered HDR (EVALUATION.md model at ev 0), linearised.
- ``paired_sources(root)``: real panoramas with aligned normal maps, matched by name (3D60 style
  ``X_color_....png`` + ``X_normal_....exr``, Structured3D style ``rgb_rawlight.png`` + ``normal.png`` in one
  folder). Normal maps are EXR floats in [-1, 1] or 8/16-bit PNGs mapped from [0, 1] to [-1, 1], then turned
  by ``normal_frame`` (3 x 3, dataset axes -> Blender world axes; identity by default: check your dataset).
Lighting pool: SH of procedural environments (panolight_core/synthetic.py) or of a folder of HDR
panoramas (Laval style); Blender's studio HDRIs are refused, they are the public evaluation set.
"""
from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from panolight_core import sh
from panolight_core.camera import hdr_to_ldr, ldr_to_linear
from panolight_core.errors import PanoLightError
from panolight_core.lighting.relight import LDR_SCALE, relight, training_lighting
from training.common.real_hdri import _is_public, hdr_files

COLOR_TOKENS = ("rgb_rawlight", "_color", "color", "rgb")


# ------------------------------------------------------------------------------------------ sources
def synthetic_sources(root) -> list[dict]:
    from training.synth.store import list_samples

    files = list_samples(root)
    if not files:
        raise PanoLightError(f"{root}: no samples (write some with 'panolight synth --out {root}')")
    return [{"kind": "synthetic", "path": f} for f in files]


def paired_sources(root, normal_frame=None) -> list[dict]:
    """Colour panoramas with a normal map beside them (see the module docstring)."""
    root = Path(root)
    out = []
    for f in sorted(root.rglob("*")):
        if f.suffix.lower() not in (".png", ".jpg", ".jpeg", ".exr", ".hdr"):
            continue
        name = f.name
        token = next((t for t in COLOR_TOKENS if t in name), None)
        if token is None:
            continue
        stem = name.replace(token, "normal" if token != "_color" else "_normal", 1)
        for ext in (".exr", ".png", Path(stem).suffix):
            cand = f.with_name(Path(stem).with_suffix(ext).name)
            if cand.is_file() and cand != f:
                out.append({"kind": "paired", "color": f, "normals": cand, "normal_frame": normal_frame})
                break
    if not out:
        raise PanoLightError(f"{root}: no colour panorama with a matching normal map found")
    return out


def _decode_normals(path: Path) -> np.ndarray:
    """(H, W, 3) float32 normal vectors from an EXR (stored as is, negative components included) or an
    8/16-bit PNG (values in [0, 1] mapped to [-1, 1])."""
    if path.suffix.lower() == ".exr":
        import OpenEXR

        try:
            ch = OpenEXR.File(str(path)).channels()
        except Exception as exc:
            raise PanoLightError(f"{path}: cannot read the normal map: {exc}") from None
        key = "RGB" if "RGB" in ch else "RGBA" if "RGBA" in ch else None
        if key is None:
            raise PanoLightError(f"{path}: the normal map has no RGB channels ({sorted(ch)})")
        return ch[key].pixels[..., :3].astype(np.float32)
    from panolight_core.io import read_image

    raw = read_image(path, ldr_as_uint8=True)
    if raw.dtype == np.uint8:
        return raw.astype(np.float32) / 255.0 * 2.0 - 1.0
    from panolight_core.camera.color import linear_to_srgb  # a 16-bit PNG came back sRGB-linearised: undo it

    return linear_to_srgb(raw).astype(np.float32) * 2.0 - 1.0


def load_source(src: dict):
    """(image linear in [0, 1], normals unit or 0, mask bool, hdr radiance or None) of a source."""
    from panolight_core.io import read_image

    if src["kind"] == "synthetic":
        from training.synth.store import read_sample

        s = read_sample(src["path"])
        image = ldr_to_linear(hdr_to_ldr(s["radiance"], 0.0, robust=True)).astype(np.float64)
        return image, s["normals"].astype(np.float64), s["mask"], s["radiance"]
    px = read_image(src["color"], ldr_as_uint8=True)
    image = ldr_to_linear(px) if px.dtype == np.uint8 else np.clip(px / max(np.percentile(px, 99), 1e-9), 0, 1)
    n = _decode_normals(Path(src["normals"])).astype(np.float64)
    if n.shape != image.shape:
        raise PanoLightError(f"{src['normals']}: normal map {n.shape[:2]} does not match {src['color']} "
                             f"{image.shape[:2]}")
    if src.get("normal_frame") is not None:
        n = n @ np.asarray(src["normal_frame"], dtype=np.float64).T
    length = np.linalg.norm(n, axis=-1, keepdims=True)
    mask = (length[..., 0] > 0.5) & (length[..., 0] < 1.5)
    return image.astype(np.float64), np.where(mask[..., None], n / np.maximum(length, 1e-12), 0.0), mask, None


# ----------------------------------------------------------------------------------- lighting pool
def procedural_pool(count: int = 256, lmax: int = 2, seed: int = 10 ** 6, height: int = 64) -> np.ndarray:
    """(count, K, 3) SH of procedural environments (seeds seed .. seed + count - 1)."""
    from panolight_core.synthetic import environment

    return np.stack([sh.project(environment(seed + i, height)[0], lmax) for i in range(count)])


def hdr_pool(files, lmax: int = 2, yaws: int = 8, mirror: bool = True, height: int = 128) -> np.ndarray:
    """(len(files) x yaws x (2 if mirror), K, 3) SH of real HDR panoramas as a relighting pool: each one
    area-averaged to ``height`` rows, then turned about the up axis by yaws equal steps (whole columns, so
    exact) and mirrored left-right (paper: Laval lightings with rotation augmentation). Refuses the public set."""
    from panolight_core.camera.resample import area_downsample
    from panolight_core.io import read_image

    out = []
    for f in files:
        if _is_public(f):
            raise PanoLightError(f"{f}: a Blender studio HDRI, the public evaluation set; never train on it")
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            p = np.maximum(read_image(f).astype(np.float64), 0.0)
        p = area_downsample(p, min(height, p.shape[0]))
        for flip in ((False, True) if mirror else (False,)):
            q = p[:, ::-1] if flip else p
            for k in range(yaws):
                out.append(sh.project(np.roll(q, (k * q.shape[1]) // yaws, axis=1), lmax))
    if not out:
        raise PanoLightError("an HDR relighting pool needs at least one panorama")
    return np.stack(out)


def folder_pool(root, lmax: int = 2) -> np.ndarray:
    """(N, K, 3) SH of every .exr/.hdr panorama in a folder (Laval-style lighting). Refuses the public set."""
    from panolight_core.io import read_image

    return np.stack([sh.project(read_image(f).astype(np.float64), lmax) for f in hdr_files(root)])


# -------------------------------------------------------------------------------------- the dataset
def make_pair(image, normals, mask, pool, rng, scale: float = LDR_SCALE, ev: float = 0.0, jpeg_quality=None,
              window_width=None, details: bool = False):
    """One training pair: (relit LDR uint8, target SH (K, 3), lambda). Blends two pool lightings.

    details: also return (exposed relit HDR (H, W, 3), the coefficients that relight ``image`` into it):
    the camera's auto exposure k is folded in, so they are in the units the LDR shows.
    """
    from panolight_core.camera import auto_exposure, hdr_to_ldr

    ia, ib = rng.integers(len(pool), size=2)
    lam = float(rng.uniform())
    target, used = training_lighting(pool[ia], pool[ib], lam, scale, window_width)
    relit = np.maximum(relight(image, normals, used) * mask[..., None], 0.0)
    k = auto_exposure(relit, ev, robust=True)
    ldr = hdr_to_ldr(relit, ev, jpeg_quality, scale=k)
    if details:
        return ldr, target, lam, relit * k, used * k
    return ldr, target, lam


def relight_dataset(sources, pool, *, scale: float = LDR_SCALE, ev: float = 0.0, jpeg_quality=None,
                    window_width=None, seed: int = 0):
    """A torch Dataset yielding dicts of float32 tensors: input (3, H, W) relit LDR in [0, 1], target_sh
    (K, 3) the blended lighting, train_sh (K, 3) the coefficients that relit the image in the LDR's
    exposure units (x100, deringed, times the camera's auto exposure), relit_hdr (3, H, W) the relit image
    in those units, normals (3, H, W), image (3, H, W) the original image, mask (1, H, W), blend.
    Deterministic per (seed, index), so it works with any number of DataLoader workers."""
    import torch

    class RelightDataset(torch.utils.data.Dataset):
        def __len__(self):
            return len(sources)

        def __getitem__(self, index):
            image, normals, mask, _ = load_source(sources[index])
            rng = np.random.default_rng([seed, index])
            ldr, target, lam, relit_hdr, train_sh = make_pair(image, normals, mask, pool, rng, scale, ev,
                                                              jpeg_quality, window_width, details=True)

            def chw(a):
                return torch.from_numpy(np.ascontiguousarray(np.moveaxis(np.asarray(a, np.float32), -1, 0)))

            return {"input": chw(ldr.astype(np.float32) / 255.0), "target_sh": torch.from_numpy(target.astype(np.float32)),
                    "train_sh": torch.from_numpy(train_sh.astype(np.float32)), "relit_hdr": chw(relit_hdr),
                    "normals": chw(normals), "image": chw(image), "mask": chw(mask[..., None].astype(np.float32)),
                    "blend": torch.tensor(lam, dtype=torch.float32)}

    return RelightDataset()
