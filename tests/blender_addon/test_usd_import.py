"""lighting.usda imported with Blender's own USD importer gives the world and sun lamps of lighting.json.

Blender 5.0's importer reads a DistantLight's normalised intensity as a quarter of the sun's strength
and its angle as the sun's half-angle (its exporter writes strength / 4 and angle / 2); the stage follows
the UsdLux specification (intensity = irradiance, angle = angular diameter), so those two factors are
checked here as Blender's, not corrected in the file."""
import json
import math
import subprocess
import sys

import numpy as np
import pytest

pytest.importorskip("bpy")
pytest.importorskip("pxr")

from panolight_core.apps.cli import main  # noqa: E402
from panolight_core.io import write_srgb8  # noqa: E402

BLENDER_STRENGTH_PER_INTENSITY = 4.0  # Blender 5.0.1 USD import, measured (see the module docstring)
BLENDER_ANGLE_PER_USD_ANGLE = 2.0

IMPORT = """
import json, sys
import bpy
bpy.ops.wm.read_factory_settings(use_empty=False)
assert bpy.ops.wm.usd_import(filepath=sys.argv[1]) == {"FINISHED"}
world = bpy.context.scene.world
nodes = {n.bl_idname: n for n in world.node_tree.nodes}
env, mapping = nodes["ShaderNodeTexEnvironment"], nodes.get("ShaderNodeMapping")
suns = [o for o in bpy.data.objects if o.type == "LIGHT" and o.name.startswith("Light_")]  # not the default lamp
print(json.dumps({"image": bpy.path.abspath(env.image.filepath),
                  "rotation": list(mapping.inputs["Rotation"].default_value) if mapping else [0, 0, 0],
                  "strength": nodes["ShaderNodeBackground"].inputs["Strength"].default_value,
                  "suns": [{"type": o.data.type, "energy": o.data.energy, "color": list(o.data.color),
                            "angle": o.data.angle, "axis": list(o.matrix_world.col[2][:3])} for o in suns]}))
"""


def test_blenders_usd_import_matches_lighting_json(tmp_path):
    from panolight_core import sh

    h, w = 64, 128
    dirs = sh.pixel_directions(h, w)
    sun = np.array([-0.5, 0.6, 0.62]) / np.linalg.norm([-0.5, 0.6, 0.62])
    hdr = np.broadcast_to(0.3 + 0.2 * np.clip(dirs[..., 2:3], 0, 1), (h, w, 3)).copy()
    hdr[dirs @ sun > math.cos(math.radians(4))] = [80.0, 60.0, 40.0]
    src = write_srgb8(tmp_path / "sky.png", np.round(np.clip(hdr, 0, 1) ** (1 / 2.2) * 255).astype(np.uint8))
    out = tmp_path / "out"
    assert main(["estimate", str(src), "-o", str(out), "-q"]) == 0
    doc = json.loads((out / "lighting.json").read_text())
    r = subprocess.run([sys.executable, "-c", IMPORT, str(out / "lighting.usda")], capture_output=True, text=True,
                       timeout=300)
    assert r.returncode == 0, r.stderr[-3000:]
    got = json.loads(r.stdout.strip().splitlines()[-1])
    # the world: lighting.json's SH map, unrotated (the dome's frame lands on Blender's equirect exactly)
    assert got["image"] == str(out / "radiance.exr")
    assert np.allclose(got["rotation"], 0.0, atol=1e-6) and got["strength"] == pytest.approx(1.0)
    # the sun lamps: direction, colour, energy and size of each explicit light
    assert len(got["suns"]) == len(doc["lights"]) > 0
    for want, lamp in zip(doc["lights"], got["suns"]):
        assert lamp["type"] == "SUN"
        cos = np.clip(np.dot(lamp["axis"], want["direction"]), -1, 1)
        assert math.degrees(math.acos(cos)) < 0.5
        energy = np.asarray(lamp["color"]) * lamp["energy"] / BLENDER_STRENGTH_PER_INTENSITY
        np.testing.assert_allclose(energy, want["intensity"] * np.asarray(want["color"]), rtol=0.01)
        assert lamp["angle"] / BLENDER_ANGLE_PER_USD_ANGLE == pytest.approx(want["angle"], rel=0.01, abs=1e-6)
