"""Packaging the Blender extension: ``panolight build-extension [-o DIR]`` -> DIR/panolight-<version>.zip.

The zip holds blender_manifest.toml and the add-on (blender_addon/*.py) at its root, and the bpy-free
core as the subpackage panolight_core/ (code and JSON schema only: no tests, no training code). It is
checked with Blender's strict validator when the bpy package is installed.
"""
from __future__ import annotations

import shutil
import subprocess
import sys
import tempfile
import tomllib
import zipfile
from pathlib import Path

from .errors import PanoLightError

ROOT = Path(__file__).resolve().parents[1]


def build_extension(out_dir="dist") -> Path:
    manifest = ROOT / "blender_manifest.toml"
    addon = ROOT / "blender_addon"
    if not manifest.is_file() or not addon.is_dir():
        raise PanoLightError(f"{ROOT}: not a PanoLight checkout (blender_manifest.toml and blender_addon/ needed)")
    version = tomllib.loads(manifest.read_text())["version"]
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        stage = Path(tmp) / "panolight"
        stage.mkdir()
        shutil.copy(manifest, stage)
        for f in addon.glob("*.py"):
            shutil.copy(f, stage)
        core = stage / "panolight_core"
        for f in (ROOT / "panolight_core").rglob("*"):
            if f.is_file() and "__pycache__" not in f.parts and f.suffix in (".py", ".json", ".safetensors", ".md"):
                dst = core / f.relative_to(ROOT / "panolight_core")
                dst.parent.mkdir(parents=True, exist_ok=True)
                shutil.copy(f, dst)
        _validate(stage)
        zpath = out / f"panolight-{version}.zip"
        with zipfile.ZipFile(zpath, "w", zipfile.ZIP_DEFLATED) as z:
            for f in sorted(stage.rglob("*")):
                if f.is_file():
                    z.write(f, f.relative_to(stage))
    return zpath


def _validate(stage: Path) -> None:
    """Blender's own strict manifest validator (from the bpy wheel), when bpy is installed."""
    import importlib.util

    spec = importlib.util.find_spec("bpy")
    if spec is None or not spec.submodule_search_locations:
        return
    hits = sorted(Path(p) for root in spec.submodule_search_locations
                  for p in Path(root).glob("*/scripts/addons_core/bl_pkg/cli/blender_ext.py"))
    if not hits:
        return
    r = subprocess.run([sys.executable, str(hits[-1]), "validate", str(stage)], capture_output=True, text=True)
    if r.returncode != 0:
        raise PanoLightError(f"Blender's validator refused the extension: {(r.stdout + r.stderr).strip()}")
