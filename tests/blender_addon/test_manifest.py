import shutil
import subprocess
import sys
from pathlib import Path

from panolight_core.data import studio_hdri_dir

ROOT = Path(__file__).resolve().parents[2]


def test_manifest_passes_blenders_strict_validator(tmp_path):
    validator = studio_hdri_dir().parents[2] / "scripts/addons_core/bl_pkg/cli/blender_ext.py"
    assert validator.is_file(), validator
    pkg = tmp_path / "panolight"
    pkg.mkdir()
    shutil.copy(ROOT / "blender_manifest.toml", pkg)
    shutil.copy(ROOT / "blender_addon" / "__init__.py", pkg)
    r = subprocess.run([sys.executable, str(validator), "validate", str(pkg)], capture_output=True, text=True)
    assert r.returncode == 0 and "Success" in r.stdout, r.stdout + r.stderr
    text = (ROOT / "blender_manifest.toml").read_text()
    tagline = next(l for l in text.splitlines() if l.startswith("tagline")).split("=", 1)[1].strip().strip('"')
    assert len(tagline) <= 64 and tagline[-1] not in ".!?"
