"""Headless PanoLight: load a panorama, estimate its lighting, build the world, optionally render and save.

    blender -b [scene.blend] --python <extension>/batch.py -- --input PANO [PANO ...] [--evs EV,EV,...]
            [--output-blend OUT.blend]
            [--render OUT.png] [--samples 64] [--resolution 640x360] [--light-with sh|hdri]
            [the estimate options of 'panolight estimate': --estimator --model --lmax --tolerance
             --window --window-width --exposure]
The same works with the bpy module: ``python batch.py -- --input PANO ...``. Exits non-zero with one
line on stderr when something fails.
"""
from __future__ import annotations

import argparse
import importlib
import math
import sys
from pathlib import Path


def _addon():
    """The registered add-on package (registered here from this file's folder if it is not yet)."""
    import bpy

    if not hasattr(bpy.types, "PANOLIGHT_OT_load_panorama"):
        here = Path(__file__).resolve().parent
        sys.path.insert(0, str(here.parent))
        importlib.import_module(here.name).register()
    package = bpy.types.PANOLIGHT_OT_load_panorama.__module__.rsplit(".", 1)[0]
    return importlib.import_module(package)


def parse(argv, core):
    argv = argv[argv.index("--") + 1:] if "--" in argv else []
    ap = argparse.ArgumentParser(prog="batch.py", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--input", required=True, nargs="+",
                    help="panorama (.jpg/.png/.exr/.hdr, 2:1); several 8-bit files: a bracket set of one scene, merged "
                         "into one HDR (the panel's Load panorama with several files)")
    ap.add_argument("--evs", default="", metavar="EV,EV,...",
                    help="a bracket set's exposures in stops, one per file in name order (default: each file's EXIF)")
    ap.add_argument("--no-align", dest="align", action="store_false",
                    help="a bracket set shot on a tripod: merged as shot (the panel's Align brackets unticked)")
    ap.add_argument("--output-blend", help="save the .blend here")
    ap.add_argument("--render", help="render the scene's camera to this image (PNG or EXR)")
    ap.add_argument("--samples", type=int, default=64, help="Cycles samples for --render (default 64)")
    ap.add_argument("--resolution", default=None, help="render size WxH (default: the scene's)")
    ap.add_argument("--light-with", choices=("sh", "hdri"), default="sh",
                    help="sh (default): the SH radiance map plus sun lamps; hdri: the reconstructed HDRI")
    settings = core.pipeline.settings
    ap.add_argument("--sun-strength", type=settings.number("--sun-strength", *settings.RANGES["sun_strength"]),
                    default=1.0, metavar="X",
                    help="scale PanoLight's sun lamps alone (the panel's Sun lamp strength; default 1: the "
                         "estimate's strength; lighting.json's energy_68 gives each key light's 68 %% range)")
    settings.add_arguments(ap, sun_strength=False)  # --sun-strength above: the panel's lamps
    ap.add_argument("--sun", type=settings.argparse_type(settings.parse_sun), default=None, metavar="AZ,EL",
                    help="the sun is there (the panel's Sun is here; degrees, azimuth 0 at the panorama's centre, "
                         "positive to the right; --sun -40,5 for a negative azimuth), weighed by the clear sky")
    ap.add_argument("--sun-contrast", type=settings.number("--sun-contrast", 1.0 + 1e-9, settings.SUN_CONTRAST_RANGE[1]),
                    default=None, metavar="R", help="with --sun: weigh it by the photo's lit / shadow ground contrast")
    ap.add_argument("--no-sun-metadata", dest="sun_metadata", action="store_false",
                    help="ignore the photo's GPS position, UTC time and heading (by default they place a sun the "
                         "photo does not place itself; the panel's Sun from the photo's metadata)")
    args = ap.parse_args(settings.attach_negative_values(ap, argv))  # --evs -2,0,2 as typed
    if args.sun_contrast is not None and args.sun is None:
        ap.error("--sun-contrast weighs the sun --sun points at: give --sun too")
    return args


def configure(scene, args, core) -> None:
    """Put the command line's settings on the panel (scene.panolight), as a user would."""
    max_order = core.lighting.order.DEFAULT_MAX_ORDER
    if args.lmax not in (None, "auto") and int(args.lmax) > max_order:
        raise SystemExit(f"panolight batch: --lmax: Blender offers auto or 0..{max_order}, got {args.lmax}")
    s = scene.panolight
    s.estimator, s.model, s.lmax, s.tolerance = args.estimator, args.model, args.lmax or "auto", args.tolerance
    s.window, s.window_width, s.exposure = args.window, args.window_width or 0.0, args.exposure
    s.lighting_source = args.light_with.upper()
    s.sun_strength = args.sun_strength
    s.sun_pointed = args.sun is not None
    s.sun_metadata = args.sun_metadata
    s.sky_sun = args.sky_sun
    s.restore_clipped = args.restore != "none"
    s.physical_units = args.absolute  # --relative: the relative setup (1 = the camera's white)
    s.ev100_given, s.ev100 = args.ev100 is not None, args.ev100 if args.ev100 is not None else s.ev100
    s.meter_lux = args.lux or 0.0
    if args.sun is not None:  # the panel keeps angles: azimuth to the right in the image, elevation up
        x, y, z = args.sun
        s.sun_azimuth, s.sun_elevation = math.atan2(-y, x), math.asin(max(-1.0, min(1.0, z)))
        s.sun_contrast = args.sun_contrast or 0.0


def run(args, addon) -> None:
    import bpy

    configure(bpy.context.scene, args, addon.core.core)
    paths = [str(Path(p).resolve()) for p in args.input]
    load = ({"filepath": paths[0]} if len(paths) == 1 else
            {"directory": str(Path(paths[0]).parent), "files": [{"name": p} for p in paths], "evs": args.evs,
             "align": args.align})
    for op, kwargs in ((bpy.ops.panolight.load_panorama, load),
                       (bpy.ops.panolight.estimate_lighting, {}),
                       (bpy.ops.panolight.build_environment, {})):
        try:
            result = op(**kwargs)
        except RuntimeError as exc:  # the operator's report({"ERROR"}) arrives as RuntimeError
            raise SystemExit(f"panolight batch: {str(exc).strip()}") from None
        if "FINISHED" not in result:
            raise SystemExit(f"panolight batch: {op.idname()} did not finish")
    scene = bpy.context.scene
    if args.render:
        if scene.camera is None:
            raise SystemExit("panolight batch: --render needs a camera in the scene")
        scene.render.engine = "CYCLES"
        scene.cycles.device = "CPU"
        scene.cycles.samples = args.samples
        if args.resolution:
            w, h = (int(v) for v in args.resolution.lower().split("x"))
            scene.render.resolution_x, scene.render.resolution_y = w, h
            scene.render.resolution_percentage = 100
        out = Path(args.render).resolve()
        scene.render.filepath = str(out)
        scene.render.image_settings.file_format = "OPEN_EXR" if out.suffix.lower() == ".exr" else "PNG"
        bpy.ops.render.render(write_still=True)
        print(f"panolight batch: rendered {out}")
    if args.output_blend:
        out = Path(args.output_blend).resolve()
        bpy.ops.wm.save_as_mainfile(filepath=str(out))
        print(f"panolight batch: saved {out}")


def main(argv=None):
    addon = _addon()
    args = parse(sys.argv if argv is None else argv, addon.core.core)
    for path in args.input:
        if not Path(path).is_file():
            raise SystemExit(f"panolight batch: {path}: file not found")
    if args.evs and len(args.input) == 1:
        raise SystemExit(f"panolight batch: {args.input[0]}: --evs gives a bracket set's exposures; give every frame")
    run(args, addon)


if __name__ == "__main__":
    main()
