"""Build the Blender extension: ``python scripts/build_extension.py [-o DIR]`` -> DIR/panolight-<version>.zip.

The zip holds blender_manifest.toml and the add-on (blender_addon/*.py) at its root, and the part of
the bpy-free core the add-on runs as the subpackage panolight_core/ (CORE_FILES: the estimation stages,
their weights and schema; no command-line front ends, no training code, no developer tools). It is
checked with Blender's strict validator when the bpy package is installed. A developer tool: it reads
the checkout this file is in.
"""
from __future__ import annotations

import shutil
import subprocess
import sys
import tempfile
import tomllib
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
# what the add-on imports (blender_addon/core.py) and what that imports, relative to panolight_core/
CORE_FILES = ("__init__.py", "_backend.py", "errors.py", "threads.py", "camera/*.py", "estimators/*.py",
              "estimators/nn/*.py", "estimators/sources/*.py", "lighting/*.py", "pipeline/*.py", "io/*.py", "sh/*.py",
              "schemas/*.json", "models/*.safetensors", "models/*.md")


class BuildError(Exception):
    pass


def build_extension(out_dir="dist") -> Path:
    manifest = ROOT / "blender_manifest.toml"
    addon = ROOT / "blender_addon"
    if not manifest.is_file() or not addon.is_dir():
        raise BuildError(f"{ROOT}: not a PanoLight checkout (blender_manifest.toml and blender_addon/ needed)")
    version = tomllib.loads(manifest.read_text())["version"]
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        stage = Path(tmp) / "panolight"
        stage.mkdir()
        shutil.copy(manifest, stage)
        for f in addon.glob("*.py"):
            shutil.copy(f, stage)
        for f in core_files():
            dst = stage / "panolight_core" / f.relative_to(ROOT / "panolight_core")
            dst.parent.mkdir(parents=True, exist_ok=True)
            shutil.copy(f, dst)
        _validate(stage)
        zpath = out / f"panolight-{version}.zip"
        with zipfile.ZipFile(zpath, "w", zipfile.ZIP_DEFLATED) as z:
            for f in sorted(stage.rglob("*")):
                if f.is_file():
                    z.write(f, f.relative_to(stage))
    return zpath


def core_files() -> list[Path]:
    """The core files the extension bundles (CORE_FILES), sorted."""
    core = ROOT / "panolight_core"
    return sorted({f for pattern in CORE_FILES for f in core.glob(pattern) if f.is_file()})


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
        raise BuildError(f"Blender's validator refused the extension: {(r.stdout + r.stderr).strip()}")


def main(argv=None) -> int:
    import argparse

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("-o", "--output", default="dist", help="output folder (default dist/)")
    args = ap.parse_args(argv)
    try:
        path = build_extension(args.output)
    except (BuildError, OSError) as exc:
        print(f"build_extension: error: {exc}", file=sys.stderr)
        return 1
    print(f"built {path} (install: Blender > Preferences > Get Extensions > Install from Disk, or "
          f"bpy.ops.extensions.package_install_files(filepath=..., repo='user_default'))", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
