"""Locating data that installed packages ship (nothing is downloaded).

The eight Blender studio-light HDRIs (1024 x 512 EXR) are in the bpy wheel; they are the public
evaluation set (never train on them). Found without importing bpy (which takes seconds).
"""
from __future__ import annotations

import importlib.util
from pathlib import Path

from .errors import PanoLightError

STUDIO_HDRIS = ("city", "courtyard", "forest", "interior", "night", "studio", "sunrise", "sunset")


def studio_hdri_dir() -> Path:
    """Folder holding Blender's studio-light world HDRIs; PanoLightError if bpy is not installed."""
    spec = importlib.util.find_spec("bpy")
    if spec is None or not spec.submodule_search_locations:
        raise PanoLightError("the Blender studio HDRIs come with the bpy package, which is not installed "
                             "(run scripts/setup.sh, or pip install bpy==5.0.1)")
    for root in spec.submodule_search_locations:
        hits = sorted(Path(root).glob("*/datafiles/studiolights/world"))
        if hits:
            return hits[-1]
    raise PanoLightError("bpy is installed but its datafiles/studiolights/world folder was not found")


def studio_hdri(name: str) -> Path:
    """Path of one Blender studio HDRI by name (city, courtyard, forest, interior, night, studio, sunrise, sunset)."""
    if name not in STUDIO_HDRIS:
        raise PanoLightError(f"unknown studio HDRI {name!r}; choose from {', '.join(STUDIO_HDRIS)}")
    return studio_hdri_dir() / f"{name}.exr"


def load_studio_hdri(name: str):
    """One Blender studio HDRI as (H, W, 3) float64 linear radiance (Blender world frame). The files hold
    a few tiny negative values (down to -0.0008), clamped to 0 without the warning a user's file gets."""
    import warnings

    import numpy as np

    from .errors import PanoLightWarning
    from .io import read_image

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PanoLightWarning)
        return read_image(studio_hdri(name)).astype(np.float64)


def main(argv=None) -> int:
    """``python -m panolight_core.data [NAME ...]``: the paths of the bundled studio HDRIs, one per line (all
    eight, or those named), to try PanoLight on a real HDRI without looking for one."""
    import argparse
    import sys

    ap = argparse.ArgumentParser(prog="python -m panolight_core.data", description=main.__doc__.split(": ", 1)[1])
    ap.add_argument("names", nargs="*", metavar="NAME", help=f"any of {', '.join(STUDIO_HDRIS)} (default: all)")
    args = ap.parse_args(argv)
    try:
        print("\n".join(str(studio_hdri(n)) for n in args.names or STUDIO_HDRIS))
    except PanoLightError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
