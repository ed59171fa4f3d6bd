"""Build the Blender extension: ``python scripts/build_extension.py [-o DIR]`` -> DIR/panolight-<version>.zip.

The zip holds blender_manifest.toml and the add-on (blender_addon/*.py) at its root, and the part of
the bpy-free core the add-on runs as the subpackage panolight_core/: the modules blender_addon/core.py
lists (CORE_MODULES, the one list) and every core module they import, with the weights and schema they
load (CORE_DATA); no command-line front ends, no training code, no developer tools. It is
checked with Blender's strict validator when the bpy package is installed. A developer tool: it reads
the checkout this file is in.
"""
from __future__ import annotations

import ast
import shutil
import subprocess
import sys
import tempfile
import tomllib
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CORE_DATA = ("schemas/*.json", "models/*.safetensors", "models/*.md")  # relative to panolight_core/


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


def addon_core_modules() -> tuple:
    """blender_addon/core.py's CORE_MODULES (read from the file, not imported: it needs bpy's package)."""
    for node in ast.parse((ROOT / "blender_addon" / "core.py").read_text(encoding="utf-8")).body:
        if isinstance(node, ast.Assign) and any(getattr(t, "id", None) == "CORE_MODULES" for t in node.targets):
            return tuple(ast.literal_eval(node.value))
    raise BuildError("blender_addon/core.py: no CORE_MODULES list")


def _module_file(name: str) -> Path | None:
    path = ROOT.joinpath(*name.split("."))
    return path / "__init__.py" if (path / "__init__.py").is_file() else \
        path.with_suffix(".py") if path.with_suffix(".py").is_file() else None


def _core_imports(name: str, path: Path) -> set:
    """The panolight_core modules ``name`` (at ``path``) imports anywhere in its file, and their packages."""
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), str(path))):
        if isinstance(node, ast.Import):
            targets = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parts = package.split(".")[:len(package.split(".")) - node.level + 1]
                base = ".".join(parts + ([node.module] if node.module else []))
            targets = [base] + [f"{base}.{a.name}" for a in node.names]
        else:
            continue
        for t in targets:
            parts = t.split(".")
            for k in range(1, len(parts) + 1):  # a module and every package above it
                if parts[0] == "panolight_core" and _module_file(".".join(parts[:k])) is not None:
                    found.add(".".join(parts[:k]))
    return found


def core_files() -> list[Path]:
    """The core files the extension bundles, sorted: CORE_MODULES and every core module they import,
    transitively (lazy imports inside functions included), and CORE_DATA."""
    todo, seen = ["panolight_core"] + [f"panolight_core.{m}" for m in addon_core_modules()], set()
    while todo:
        name = todo.pop()
        path = _module_file(name)
        if name in seen or path is None:
            continue
        seen.add(name)
        parts = name.split(".")
        todo += [".".join(parts[:k]) for k in range(1, len(parts))] + sorted(_core_imports(name, path))
    core = ROOT / "panolight_core"
    data = {f for pattern in CORE_DATA for f in core.glob(pattern) if f.is_file()}
    return sorted({_module_file(n) for n in seen} | data)


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
