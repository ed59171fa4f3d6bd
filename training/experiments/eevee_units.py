"""Blender's physical build rendered by Cycles and EEVEE: a white plane's irradiance against lighting.json's.

For each photo whose EXIF gives its scale (``../shared/data/ldr/tunnel.jpg``, and Blender's city panorama shot as a
JPEG at f/8, 1/100 s, ISO 200 with that EXIF), the add-on estimates it and builds the world with *Physical units*
(W/m^2/sr and W/m^2), once as "SH lighting + sun lamps" and once as "Reconstructed HDRI". A white diffuse plane
(albedo 0.8) facing up is rendered from above by Cycles (one bounce) and by EEVEE; its irradiance,
pi x radiance / 0.8 (luminance-weighted), is set against lighting.json's ``physical.upward_illuminance_lux`` / 683
W/m^2. Rows also split the SH build into its world and its sun lamps, and render the HDRI build with EEVEE's
``World.sun_threshold`` at 0 (no sun taken out of the world) and at EEVEE's default 10 camera whites (the rule before
the threshold was put above everything beside the brightest light) beside the threshold the build sets.

    python -m training.experiments.eevee_units [--photos PATH ...] [--samples 16] [--out docs/studies/eevee_units.json]

Needs the bpy module (EEVEE renders through EGL; a machine without it gets Cycles rows only, and says so).
"""
from __future__ import annotations

import argparse
import json
import math
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
DEFAULT_PHOTOS = (ROOT.parent / "shared" / "data" / "ldr" / "tunnel.jpg",)
ALBEDO = 0.8


def _city_with_exif(folder: Path) -> Path:
    """Blender's city panorama as the JPEG a camera at f/8, 1/100 s, ISO 200 takes (EXIF written)."""
    from PIL import Image
    from PIL.TiffImagePlugin import IFDRational

    from panolight_core.camera import hdr_to_ldr
    from panolight_core.camera.resample import area_downsample
    from panolight_core.data import load_studio_hdri

    exif = Image.Exif()
    ifd = exif.get_ifd(0x8769)
    ifd[0x829A], ifd[0x829D], ifd[0x8827] = IFDRational(1, 100), IFDRational(80, 10), 200
    path = folder / "city_f8_100_iso200.jpg"
    Image.fromarray(hdr_to_ldr(area_downsample(load_studio_hdri("city"), 256), 0.0)).save(path, quality=95, exif=exif)
    return path


def white_diffuse(bpy, obj, albedo: float = ALBEDO) -> None:
    """Give ``obj`` a white diffuse material (``albedo``, one node pair); the bpy tests' white sphere and plane too."""
    mat = bpy.data.materials.new("white")
    if bpy.app.version < (5, 0, 0):
        mat.use_nodes = True
    nt = mat.node_tree
    nt.nodes.clear()
    diffuse = nt.nodes.new("ShaderNodeBsdfDiffuse")
    diffuse.inputs["Color"].default_value = (albedo, albedo, albedo, 1)
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    nt.links.new(diffuse.outputs["BSDF"], out.inputs["Surface"])
    obj.data.materials.append(mat)


def plane_and_camera(bpy, scene):
    """(plane, camera): a 200 m white diffuse plane at z = 0 and an orthographic camera 1 m above looking down (a
    camera casts no shadow), made the scene's camera; the bpy tests' white plane too."""
    bpy.ops.mesh.primitive_plane_add(size=200.0, location=(0, 0, 0))
    plane = bpy.context.active_object
    white_diffuse(bpy, plane)
    cam_data = bpy.data.cameras.new("down")
    cam_data.type, cam_data.ortho_scale = "ORTHO", 1.0
    cam = bpy.data.objects.new("down", cam_data)
    scene.collection.objects.link(cam)
    cam.location = (0, 0, 1.0)
    scene.camera = cam
    return plane, cam


def plane_irradiance(img: np.ndarray, albedo: float = ALBEDO) -> float:
    """The luminance-weighted irradiance (W/m^2) on a diffuse plane of ``albedo`` from a render of it (H, W, 3):
    pi x its mean radiance / albedo."""
    from panolight_core.camera.color import LUMINANCE_WEIGHTS

    return float(np.asarray(img, dtype=np.float64).reshape(-1, 3).mean(0) @ LUMINANCE_WEIGHTS) * math.pi / albedo


def _irradiance(bpy, scene, engine: str, path: Path, samples: int) -> float:
    """The plane's luminance-weighted irradiance (W/m^2) in a render by ``engine``."""
    from panolight_core.io import read_image

    scene.render.engine = engine
    if engine == "CYCLES":
        scene.cycles.device, scene.cycles.samples, scene.cycles.use_denoising = "CPU", samples, False
        scene.cycles.max_bounces = 1
    else:
        scene.eevee.taa_render_samples = samples
    scene.render.resolution_x = scene.render.resolution_y = 16
    scene.view_settings.view_transform, scene.view_settings.look = "Standard", "None"
    scene.render.image_settings.file_format, scene.render.image_settings.color_depth = "OPEN_EXR", "32"
    scene.render.filepath = str(path)
    bpy.ops.render.render(write_still=True)
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the render's alpha channel
        img = read_image(path, equirect=False)
    return plane_irradiance(img)


def photo_rows(photo: Path, work: Path, samples: int, engines: list[str], log=print) -> list[dict]:
    """The rows of one photo: each build x engine (and the splits), irradiance over lighting.json's."""
    import bpy

    import blender_addon
    from blender_addon import store
    from blender_addon.operators import EEVEE_SUN_THRESHOLD
    from panolight_core.camera import units

    bpy.ops.wm.read_factory_settings(use_empty=False)
    blender_addon.register()
    try:
        scene = bpy.context.scene
        s = scene.panolight
        s.create_lights, s.sun_strength, s.lighting_strength, s.physical_units = True, 1.0, 1.0, True
        if bpy.ops.panolight.load_panorama(filepath=str(photo)) != {"FINISHED"}:
            raise SystemExit(f"{photo}: the add-on could not load it")
        if bpy.ops.panolight.estimate_lighting() != {"FINISHED"}:
            raise SystemExit(f"{photo}: the add-on could not estimate it")
        for obj in [o for o in scene.objects if o.type == "MESH" or (o.type == "LIGHT" and not o.get(store.TAG))]:
            bpy.data.objects.remove(obj)
        plane_and_camera(bpy, scene)
        doc = store.stored_lighting(scene.world)
        if not (doc.get("physical") or {}).get("absolute"):
            raise SystemExit(f"{photo}: its EXIF gives no exposure, so there are no physical units to check")
        want = doc["physical"]["upward_illuminance_lux"] / 683.0
        rows = []

        def row(build: str, part: str, engine: str):
            t = time.perf_counter()
            got = _irradiance(bpy, scene, engine, work / f"{photo.stem}_{build}_{part}_{engine}.exr", samples)
            rows.append({"photo": photo.name, "build": build, "part": part, "engine": engine.replace("BLENDER_", ""),
                         "irradiance_w_m2": got, "lighting_json_w_m2": want, "ratio": got / want,
                         "sun_threshold": scene.world.sun_threshold, "seconds": time.perf_counter() - t})
            log(f"{photo.name:28s} {build:5s} {part:16s} {rows[-1]['engine']:6s} {got:9.4g} W/m^2 = "
                f"{got / want:5.3f} x lighting.json")

        for build in ("SH", "HDRI"):
            s.lighting_source = build
            if bpy.ops.panolight.build_environment() != {"FINISHED"}:
                raise SystemExit(f"{photo}: Build environment failed")
            for engine in engines:
                row(build, "all", engine)
            lamps = [o for o in bpy.data.objects if o.get(store.TAG) and o.type == "LIGHT"]
            if build == "SH" and lamps:  # the world alone, then the sun lamps alone
                energies = [lamp.data.energy for lamp in lamps]
                for lamp in lamps:
                    lamp.data.energy = 0.0
                for engine in engines:
                    row(build, "world only", engine)
                for lamp, energy in zip(lamps, energies):
                    lamp.data.energy = energy
                backgrounds = [n for n in scene.world.node_tree.nodes if n.type == "BACKGROUND"]
                strengths = [n.inputs["Strength"].default_value for n in backgrounds]
                for n in backgrounds:
                    n.inputs["Strength"].default_value = 0.0
                for engine in engines:
                    row(build, "sun lamps only", engine)
                for n, v in zip(backgrounds, strengths):
                    n.inputs["Strength"].default_value = v
            if build == "HDRI" and "BLENDER_EEVEE" in engines:
                kept = scene.world.sun_threshold
                scene.world.sun_threshold = 0.0  # EEVEE takes no sun out of the world
                row(build, "threshold 0", "BLENDER_EEVEE")
                scene.world.sun_threshold = EEVEE_SUN_THRESHOLD * units.blender_factor(doc["physical"])
                row(build, "threshold 10", "BLENDER_EEVEE")  # EEVEE's default (in camera whites): the rule before
                scene.world.sun_threshold = kept
        return rows
    finally:
        blender_addon.unregister()


def _eevee_works(work: Path) -> bool:
    """Whether EEVEE renders here (it needs an EGL or OpenGL context), tried in a child process."""
    import subprocess

    code = ("import bpy; s = bpy.context.scene; s.render.engine = 'BLENDER_EEVEE'; "
            "s.render.resolution_x = s.render.resolution_y = 8; "
            f"s.render.filepath = {str(work / 'probe.png')!r}; bpy.ops.render.render(write_still=True); print('ok')")
    try:
        r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    except (OSError, subprocess.TimeoutExpired):
        return False
    return r.returncode == 0 and "ok" in r.stdout


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="panolight dev eevee-units", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--photos", nargs="*", type=Path, default=None,
                    help="photos with exposure EXIF (default: ../shared/data/ldr/tunnel.jpg, and the city JPEG made "
                         "here)")
    ap.add_argument("--samples", type=int, default=16, help="samples per pixel of each render (default 16)")
    ap.add_argument("--out", type=Path, default=None, help="write the rows as JSON here")
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        photos = list(args.photos) if args.photos is not None else [p for p in DEFAULT_PHOTOS if p.is_file()]
        if args.photos is None:
            photos.append(_city_with_exif(work))
        engines = ["CYCLES"]
        if _eevee_works(work):
            engines.append("BLENDER_EEVEE")
        else:
            print("EEVEE does not render on this machine (no EGL or OpenGL context): Cycles rows only", file=sys.stderr)
        rows = [r for photo in photos for r in photo_rows(photo, work, args.samples, engines)]
    if args.out:
        args.out.write_text(json.dumps({"samples": args.samples, "rows": rows}, indent=1) + "\n")
        print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
