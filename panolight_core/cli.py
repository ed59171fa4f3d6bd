"""Command line: ``panolight <command> ...`` (also ``python -m panolight_core``)."""
from __future__ import annotations

import argparse
import hashlib
import sys
import time
import warnings
from pathlib import Path

import numpy as np

from . import __version__, sh
from .errors import PanoLightError, PanoLightWarning
from .sh.window import FAMILIES as WINDOW_FAMILIES, default_width

EPILOG_PROJECT = """\
examples:
  panolight project studio.exr -o out/studio            # lmax 2, writes 4 files into out/studio
  panolight project sky.hdr -o out/sky --lmax 8 --window auto
  panolight demo                                         # the same on a Blender studio HDRI

outputs (in OUTDIR, nothing is written elsewhere):
  lighting.json   SH radiance coefficients (Blender world frame, Z up), schema-validated
  radiance.exr    the SH radiance map reconstructed at --resolution
  irradiance.exr  the diffuse irradiance map (what a white Lambertian surface facing each direction receives)
  preview.png     input | SH radiance | irradiance, each auto-exposed (median -> 0.18); black = negative (ringing)

HDR inputs (.exr, .hdr) are projected exactly. LDR inputs (.png, .jpg) are sRGB-linearised only: clipped
highlights (sun, lamps) stay clipped, so their lighting is too dim; the estimator issue adds recovery.
"""


def _log(msg: str, quiet: bool):
    if not quiet:
        print(msg, file=sys.stderr, flush=True)


def _resolution(text: str) -> tuple[int, int]:
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"resolution must look like 256x128, got {text!r}") from None
    if w != 2 * h or h < 1 or h > 8192:
        raise argparse.ArgumentTypeError(f"resolution must be 2:1 with height 1..8192, got {text!r}")
    return w, h


def _window_arg(text: str) -> str:
    if text not in ("none", "auto") + WINDOW_FAMILIES:
        raise argparse.ArgumentTypeError(f"window must be none, auto, sinc4, lanczos or hanning, got {text!r}")
    return text


def run_project(args) -> int:
    from .io import is_hdr, read_image, write_image
    from .lighting import make_lighting, write_lighting
    from .preview import strip

    src = Path(args.input)
    out = Path(args.output)
    t0 = time.perf_counter()
    _log(f"[1/4] reading {src}", args.quiet)
    img = read_image(src, nonfinite="repair" if args.repair_nonfinite else "error")
    hdr = is_hdr(src)
    t_read = time.perf_counter() - t0
    _log(f"[2/4] projecting {img.shape[1]}x{img.shape[0]} onto SH lmax {args.lmax}", args.quiet)
    t1 = time.perf_counter()
    coeffs = sh.project(img.astype(np.float64), args.lmax)
    window = None
    if args.window != "none":
        if args.window == "auto":
            width = sh.auto_window_width(coeffs, target="radiance")
            window = {"kind": "sinc4", "width": None if width == float("inf") else width, "mode": "auto"}
            if width != float("inf"):
                coeffs = sh.window(coeffs, "sinc4", width)
        else:
            width = args.window_width or default_width(args.lmax)
            coeffs = sh.window(coeffs, args.window, width)
            window = {"kind": args.window, "width": width, "mode": "fixed"}
    t_project = time.perf_counter() - t1
    w, h = args.resolution
    _log(f"[3/4] reconstructing radiance and irradiance at {w}x{h}", args.quiet)
    radiance = sh.reconstruct(coeffs, h, w).astype(np.float32)
    irradiance = sh.irradiance_map(coeffs, h, w).astype(np.float32)
    out.mkdir(parents=True, exist_ok=True)
    _log(f"[4/4] writing {out}/", args.quiet)
    digest = hashlib.sha256(src.read_bytes()).hexdigest()
    doc = make_lighting(
        coeffs, units="relative" if not hdr else "input radiance units",
        source={"path": str(src), "sha256": digest, "width": int(img.shape[1]), "height": int(img.shape[0]),
                "dynamic_range": "hdr" if hdr else "ldr-srgb-linearised"},
        estimator={"name": "projection", "version": __version__, "weights": "cell"},
        window=window,
        timings={"read_s": round(t_read, 6), "project_s": round(t_project, 6)},
    )
    write_lighting(out / "lighting.json", doc)
    write_image(out / "radiance.exr", radiance)
    write_image(out / "irradiance.exr", irradiance)
    panels = [("input", img), (f"SH radiance (lmax {args.lmax})", radiance), ("irradiance", irradiance)]
    _write_png(out / "preview.png", strip(panels))
    _log(f"done in {time.perf_counter() - t0:.2f} s: lighting.json, radiance.exr, irradiance.exr, preview.png",
         args.quiet)
    return 0


def _write_png(path: Path, rgb8: np.ndarray):
    from PIL import Image

    Image.fromarray(rgb8, "RGB").save(path)


def run_demo(args) -> int:
    from .data import studio_hdri

    args.input = str(studio_hdri(args.scene))
    return run_project(args)


def _add_project_options(p):
    p.add_argument("-o", "--output", default=None, help="output folder (created if missing; default out/<input name>)")
    p.add_argument("--lmax", type=int, default=2, help="SH order, 0..100 (default 2: 9 coefficients per channel)")
    p.add_argument("--window", type=_window_arg, default="none",
                   help="deringing: none (default), auto (weakest sinc^4 window with non-negative radiance), "
                        "or a fixed sinc4 | lanczos | hanning window")
    p.add_argument("--window-width", type=float, default=None, help="width of a fixed window (default 2 (lmax+1))")
    p.add_argument("--resolution", type=_resolution, default=(512, 256),
                   help="size of radiance.exr / irradiance.exr, WxH (default 512x256)")
    p.add_argument("--repair-nonfinite", action="store_true",
                   help="replace NaN/Inf pixels instead of refusing the file")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress messages")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="panolight",
        description="PanoLight: HDR lighting from 360-degree panoramas as spherical harmonics.",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog="Run 'panolight <command> --help' for the options of each command.")
    parser.add_argument("--version", action="version", version=f"panolight {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="command")
    p = sub.add_parser("project", help="project an equirect panorama onto SH and write lighting + previews",
                       description="Project an equirectangular panorama (2:1; .exr/.hdr/.png/.jpg) onto spherical "
                                   "harmonics and write its lighting file, reconstructions and a preview.",
                       epilog=EPILOG_PROJECT, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("input", help="panorama file (equirectangular, width = 2 x height)")
    _add_project_options(p)
    p.set_defaults(func=run_project)
    d = sub.add_parser("demo", help="run 'project' on a Blender studio HDRI shipped in the bpy package",
                       description="Run 'project' on one of the eight HDRIs shipped in the bpy package.",
                       epilog=EPILOG_PROJECT, formatter_class=argparse.RawDescriptionHelpFormatter)
    d.add_argument("--scene", default="courtyard", help="city, courtyard (default), forest, interior, night, "
                                                        "studio, sunrise or sunset")
    _add_project_options(d)
    d.set_defaults(func=run_demo)
    return parser


def main(argv=None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "command", None):
        parser.print_help()
        return 2
    if hasattr(args, "output") and args.output is None:
        name = Path(args.input).stem if getattr(args, "input", None) else args.scene
        args.output = str(Path("out") / name)
    if hasattr(args, "lmax") and not 0 <= args.lmax <= 100:
        parser.error(f"--lmax must be in 0..100, got {args.lmax}")
    with warnings.catch_warnings():
        warnings.simplefilter("always", PanoLightWarning)
        warnings.showwarning = lambda m, c, f, l, file=None, line=None: print(f"warning: {m}", file=sys.stderr)
        try:
            return args.func(args)
        except PanoLightError as exc:
            print(f"panolight: error: {exc}", file=sys.stderr)
            return 1
        except KeyboardInterrupt:
            print("panolight: interrupted", file=sys.stderr)
            return 130


if __name__ == "__main__":
    sys.exit(main())
