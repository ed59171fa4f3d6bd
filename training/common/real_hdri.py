"""The real HDR panoramas every study and fit reads (../shared/data/hdri): where they are, their MANIFEST, and
reading one. Blender's studio HDRIs, the public evaluation set, are refused as training data."""
from __future__ import annotations

import csv
import warnings
from pathlib import Path

import numpy as np

from panolight_core.errors import PanoLightError
from panolight_core.io import read_image

DEFAULT_HDRI = Path(__file__).resolve().parents[3] / "shared" / "data" / "hdri"


def manifest(folder) -> list[dict]:
    """The rows of a real-HDR folder's MANIFEST.csv (file, size, kind, sun, ...), in its order."""
    with open(Path(folder) / "MANIFEST.csv", newline="", encoding="utf-8") as f:
        return list(csv.DictReader(f))


def scene_files(folder=DEFAULT_HDRI) -> list[Path]:
    """The HDR panoramas of a training folder (its MANIFEST.csv order when it has one)."""
    folder = Path(folder)
    if not folder.is_dir():
        raise PanoLightError(f"{folder}: no such folder of HDR panoramas")
    files = hdr_files(folder)  # refuses Blender's studio HDRIs (the public set)
    if (folder / "MANIFEST.csv").is_file():
        listed = [folder.resolve() / row["file"] for row in manifest(folder)]
        files = [p for p in listed if p.is_file()] or files
    return files


def load_hdr(path) -> np.ndarray:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return np.maximum(read_image(path).astype(np.float64), 0.0)


def _is_public(path) -> bool:
    """Whether a file or folder is (inside) Blender's studio-HDRI folder, the public evaluation set."""
    from panolight_core.data import studio_hdri_dir

    try:
        public = studio_hdri_dir().resolve()
    except PanoLightError:
        return False
    path = Path(path).resolve()
    return path == public or public in path.parents


def hdr_files(root) -> list[Path]:
    """Every .exr/.hdr panorama under a folder, sorted. Refuses the public set (Blender's studio HDRIs)."""
    root = Path(root).resolve()
    if _is_public(root):
        raise PanoLightError(f"{root}: these are Blender's studio HDRIs, the public evaluation set; never train on them")
    files = sorted(p for p in root.rglob("*") if p.suffix.lower() in (".exr", ".hdr"))
    if not files:
        raise PanoLightError(f"{root}: no .exr or .hdr panoramas")
    return files


def clipped_truth(folder: Path) -> set:
    """Scene files whose own source is clipped (MANIFEST ``sun`` column): their energy is a lower bound."""
    return {row["file"] for row in manifest(folder)
            if row["sun"].startswith("clipped") or "lower bound" in row["sun"]}
