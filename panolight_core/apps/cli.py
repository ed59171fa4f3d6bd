"""Command line: ``panolight <command> ...`` (also ``python -m panolight_core``)."""
from __future__ import annotations

import argparse
import math
import sys
import warnings
from pathlib import Path

from .. import __version__
from ..errors import PanoLightError, PanoLightWarning
from ..lighting.order import DEFAULT_TOLERANCE
from ..sh.window import FAMILIES as WINDOW_FAMILIES

OUTPUTS_HELP = """\
outputs (in OUTDIR; nothing is written anywhere else):
  lighting.json   SH radiance coefficients and explicit lights (Blender world frame, Z up), estimator, input
                  hash, timings, the chosen model/order/deringing and why (schema: panolight_core/schemas)
  hdr.exr         the full-resolution HDR panorama: the input linearised, its clipped sun, lamps and windows
                  filled with their estimated energy (an HDRI for any renderer; SH = lighting.json's model)
  radiance.exr    the SH part's radiance map at --resolution (the lights are in lighting.json)
  irradiance.exr  diffuse irradiance of the whole model (lights + SH) for a surface facing each direction
  preview.png     input | SH radiance | a white diffuse sphere lit by the estimate, each auto-exposed
"""

EPILOG_ESTIMATE = f"""\
examples:
  panolight estimate photo.jpg -o out/photo               # lights + the SH order the scene needs (default)
  panolight estimate studio.exr --model sh --lmax 8       # a fixed recipe: 81 SH coefficients, no lights
  panolight estimate room.jpg --tolerance 0.005           # stricter: a higher order if the scene needs it
  panolight estimate sky.hdr --model sh --window auto     # SH only, deringed just enough

{OUTPUTS_HELP}
models: auto finds compact bright sources (sun, lamps, windows) and stores them as explicit lights (direction,
colour, intensity, angular size, sun/area) in lighting.json; the rest goes to SH at the smallest order whose
diffuse relighting error is within --tolerance. lighting.json records what was chosen and why.
estimators: analytic (default through 'auto'), naive (sRGB -> linear, no recovery), ambient (constant).
LDR results are relative to the camera's clip level (1 = white); --exposure EV scales them by 2^EV.
"""

EPILOG_BATCH = """\
examples:
  panolight batch shots/ -o out/                         # every .exr .hdr .png .jpg in shots/
  panolight batch --list todo.txt -o out/ --shard 2/4    # second of four farm jobs over the same list

Each input gets OUTDIR/<name>/ with the files of 'panolight estimate'. Bad files are reported and
skipped; the exit status is 1 if any input failed. A report goes to OUTDIR/batch_report.json
(batch_report-I-of-N.json with --shard). Shards split the sorted input list deterministically: every
N-th input starting at the I-th, so N copies with --shard 1/N .. N/N cover it exactly once.
"""

EPILOG_EVAL = """\
Runs the EVALUATION.md protocol on the eight Blender studio HDRIs (shipped in the bpy package) and
writes OUTDIR/eval.md, eval.json and speed_accuracy.png. Expect about a minute with the defaults.
"""


def _log(quiet: bool):
    return (lambda msg: None) if quiet else (lambda msg: print(msg, file=sys.stderr, flush=True))


def _resolution(text: str) -> tuple[int, int]:
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"resolution must look like 512x256, got {text!r}") from None
    if w != 2 * h or h < 1 or h > 8192:
        raise argparse.ArgumentTypeError(f"resolution must be 2:1 with height 1..8192, got {text!r}")
    return w, h


def _lmax(text: str) -> str:
    if text == "auto":
        return text
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"--lmax must be an integer 0..100 or 'auto', got {text!r}") from None
    if not 0 <= v <= 100:
        raise argparse.ArgumentTypeError(f"--lmax must be in 0..100, got {v}")
    return text


def _number(name: str, lo: float, hi: float, integer: bool = False):
    """An argparse type: a finite number in [lo, hi] (NaN, Inf and out-of-range values get one line)."""
    def parse(text: str):
        try:
            v = int(text) if integer else float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{name} must be {'an integer' if integer else 'a number'}, "
                                             f"got {text!r}") from None
        if not (math.isfinite(v) and lo <= v <= hi):
            raise argparse.ArgumentTypeError(f"{name} must be between {lo:g} and {hi:g}, got {text!r}")
        return v
    return parse


MAX_EXPOSURE_EV = 60.0  # 2^60 keeps any clip-level radiance finite in float32 outputs


def _window(text: str) -> str:
    if text not in ("none", "auto") + WINDOW_FAMILIES:
        raise argparse.ArgumentTypeError(f"window must be none, auto, sinc4, lanczos or hanning, got {text!r}")
    return text


def _estimate_kwargs(args) -> dict:
    return {"lmax": args.lmax, "estimator": args.estimator, "model": args.model, "exposure_ev": args.exposure,
            "window": args.window,
            "window_width": args.window_width, "tolerance": args.tolerance, "resolution": args.resolution,
            "repair_nonfinite": args.repair_nonfinite, "max_megapixels": args.max_megapixels,
            "overwrite": args.overwrite}


def run_estimate(args) -> int:
    from ..pipeline import run_estimate as job

    out = Path(args.output) if args.output else Path("out") / Path(args.input).stem
    doc = job(args.input, out, log=_log(args.quiet), **_estimate_kwargs(args))
    if not args.quiet:
        t = doc["timings"]
        print(f"done: {out}/ (lmax {doc['lmax']}, {doc['estimator']['name']}; read {t['read_s'] * 1e3:.0f} ms, "
              f"estimate {t['estimate_s'] * 1e3:.0f} ms)", file=sys.stderr)
    return 0


def run_project(args) -> int:
    args.estimator = "naive"
    args.model = "sh"
    return run_estimate(args)


def run_batch(args) -> int:
    from .batch import collect_inputs, parse_shard, run_batch as batch
    from ..pipeline import run_estimate as job

    shard_spec = parse_shard(args.shard)
    inputs = collect_inputs(args.inputs, args.list, args.recursive)
    if not inputs:
        raise PanoLightError("no input panoramas found (give files, folders, or --list FILE)")
    kwargs = _estimate_kwargs(args)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PanoLightWarning)
        settings = {k: (list(v) if isinstance(v, tuple) else v) for k, v in kwargs.items()}
        report = batch(inputs, Path(args.output), lambda src, dst: job(src, dst, **kwargs), shard_spec, args.quiet,
                       settings=settings)
    print(f"batch: {report['ok']} ok, {report['skipped']} up to date, {report['failed']} failed of "
          f"{report['this_shard']} "
          f"(shard {report['shard']} of {report['total_inputs']} inputs); report: {report['report_path']}",
          file=sys.stderr)
    for r in report["results"]:
        if r["status"] == "failed":
            print(f"  failed: {r['error']}", file=sys.stderr)
    return 1 if report["failed"] else 0


def run_eval(args) -> int:
    from . import evaluation
    from ..estimators import available, register_model

    base = args.estimators or list(available())
    extra = []
    for spec in args.weights or []:
        label, sep, path = spec.partition("=")
        if not sep or not label or not path:
            raise PanoLightError(f"--weights {spec!r}: write LABEL=PATH, e.g. full-prior=runs/full/model.safetensors")
        extra.append(register_model(label, path))
    names = base + [e for e in extra if e not in base]
    result = evaluation.run(evs=args.evs, estimators=names, lmax=args.lmax, jpeg_quality=args.jpeg or None,
                            repeats=args.repeats, log=_log(args.quiet))
    if not args.no_adaptive:
        result["adaptive"] = evaluation.run_adaptive(log=_log(args.quiet))
    paths = evaluation.write(result, args.output)
    print(evaluation.markdown(result))
    if result.get("adaptive"):
        print(evaluation.markdown_adaptive(result["adaptive"]))
    print("wrote " + ", ".join(str(p) for p in paths), file=sys.stderr)
    return 0


def run_demo(args) -> int:
    """Make a phone-like JPEG from a bundled HDRI, estimate its lighting, compare with the HDR truth."""
    import numpy as np

    from .. import metrics, sh
    from ..camera import hdr_to_ldr
    from ..data import studio_hdri
    from ..io import read_image
    from ..io.lighting import read_lighting

    out = Path(args.output or Path("out") / args.scene)
    out.mkdir(parents=True, exist_ok=True)
    log = _log(args.quiet)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PanoLightWarning)
        hdr = read_image(studio_hdri(args.scene)).astype(np.float64)
    from PIL import Image

    src = out / "input.jpg"
    Image.fromarray(hdr_to_ldr(hdr, args.ev)).save(src, quality=90)
    log(f"demo: made {src} from Blender's '{args.scene}' HDRI (auto exposure, ev {args.ev:+g}, JPEG q90)")
    args.input = str(src)
    args.output = str(out)
    run_estimate(args)
    coeffs, doc = read_lighting(out / "lighting.json")
    from ..lighting.adaptive import LightingModel
    from .evaluation import EXACT_ORDER

    grid = (metrics.GRID_H, metrics.GRID_W)
    truth = sh.irradiance_map(sh.project(hdr, EXACT_ORDER), *grid)
    ours = LightingModel(doc["lights"], coeffs).irradiance_map(*grid)
    naive = sh.irradiance_map(sh.project(read_image(src), 2), *grid)
    print(f"demo: diffuse relighting error against the HDR's exact irradiance: irr-RMSE "
          f"{metrics.irr_rmse_maps(truth, ours):.3f} with {len(doc['lights'])} light(s) + SH lmax {doc['lmax']} "
          f"(naive lmax 2: {metrics.irr_rmse_maps(truth, naive):.3f}); see {out}/preview.png")
    return 0


def run_render_mitsuba(args) -> int:
    try:
        from training.mitsuba_render import render_figure
    except ImportError:
        raise PanoLightError("render-mitsuba needs the repository's training/ package (run it from a checkout)") \
            from None
    res = render_figure(args.inputs, args.out, meshes=args.meshes, spp=args.spp, resolution=args.resolution_wh,
                        yaw=args.yaw, pitch=args.pitch, fov=args.fov, materials=args.materials,
                        in_panorama=not args.no_panorama_view, compare_hdr=args.compare_hdr,
                        from_ldr=args.from_ldr, log=_log(args.quiet))
    print(f"render-mitsuba: {len(res['renders'])} EXR renders and {res['figure']} in {res['seconds']:.0f} s "
          f"({res['variant']}, {res['spp']} spp)", file=sys.stderr)
    return 0


def run_synth(args) -> int:
    try:
        from training.synth.store import synthesize
    except ImportError:
        raise PanoLightError("synth needs the repository's training/ package (run it from a checkout)") from None
    from .batch import Progress, parse_shard

    w, h = args.resolution
    shard = parse_shard(args.shard)
    count = len(range(shard[0] - 1, args.count, shard[1]))
    prog = Progress(count, args.quiet)
    res = synthesize(args.out, args.count, h, args.spp, args.seed, shard, progress=prog.step)
    per = res["seconds_per_sample"]
    print(f"synth: {res['rendered']} rendered, {res['skipped']} already there, in {res['seconds']:.0f} s"
          + (f" ({per:.2f} s per sample)" if per else "") + f"; {args.out}", file=sys.stderr)
    return 0


def run_sheet(args) -> int:
    from training.contact_sheet import contact_sheet

    path = contact_sheet(args.dataset, args.output, count=args.count, seed=args.seed)
    print(f"sheet: {path}", file=sys.stderr)
    return 0


def run_build_extension(args) -> int:
    from ..extension import build_extension

    path = build_extension(args.output)
    print(f"build-extension: {path} (install: Blender > Preferences > Get Extensions > Install from Disk, or "
          f"bpy.ops.extensions.package_install_files(filepath=..., repo='user_default'))", file=sys.stderr)
    return 0


def run_train(args) -> int:
    try:
        from training.train import train
    except ImportError as exc:
        raise PanoLightError(f"train needs torch and the repository's training/ package ({exc})") from None
    res = train(args.config, args.data, args.out, epochs=args.epochs, ae_epochs=args.ae_epochs,
                batch_size=args.batch_size, lr=args.lr, seed=args.seed, procedural=args.procedural,
                val_procedural=args.val_procedural, cache=args.cache, max_minutes=args.max_minutes,
                ae_from=args.ae_from, hdr=args.hdr, log=_log(args.quiet))
    print(f"train: weights in {res['weights']}", file=sys.stderr)
    return 0


def _add_estimate_options(p, default_estimator="auto"):
    p.add_argument("-o", "--output", default=None, help="output folder (created; default out/<input name>)")
    p.add_argument("--model", choices=("auto", "sh"), default="auto",
                   help="auto (default): explicit lights for compact bright sources (sun, lamps) plus the SH "
                        "order the rest needs, deringed only if ringing would show; sh: SH only")
    p.add_argument("--lmax", type=_lmax, default=None,
                   help="SH order 0..100, or 'auto': the smallest order 0..8 within --tolerance "
                        "(default: auto with --model auto, 2 with --model sh)")
    p.add_argument("--tolerance", type=_number("--tolerance", 0.0, 1.0), default=DEFAULT_TOLERANCE,
                   help=f"with --lmax auto: allowed diffuse relighting error relative to order 8 "
                        f"(default {DEFAULT_TOLERANCE})")
    from ..estimators import AUTO, DESCRIPTIONS

    p.add_argument("--estimator", default=default_estimator,
                   help="; ".join(f"{n}: {text}" for n, (_, text) in DESCRIPTIONS.items())
                   + f"; auto (default): {AUTO}, the best measured")
    p.add_argument("--exposure", type=_number("--exposure", -MAX_EXPOSURE_EV, MAX_EXPOSURE_EV), default=0.0,
                   metavar="EV",
                   help="scale the estimated lighting by 2^EV (default 0)")
    p.add_argument("--window", type=_window, default="none",
                   help="force deringing: auto (weakest sinc^4 window with non-negative radiance) or a fixed "
                        "sinc4 | lanczos | hanning; default none leaves it to --model")
    p.add_argument("--window-width", type=_number("--window-width", 1e-6, 1e6), default=None,
                   help="width of a fixed window (default 2 (lmax+1))")
    p.add_argument("--resolution", type=_resolution, default=(512, 256),
                   help="size of radiance.exr / irradiance.exr, WxH (default 512x256)")
    p.add_argument("--repair-nonfinite", action="store_true", help="replace NaN/Inf pixels instead of refusing")
    from ..io.images import DEFAULT_MAX_MEGAPIXELS, MAX_PIXELS

    p.add_argument("--max-megapixels", type=_number("--max-megapixels", 0.001, MAX_PIXELS / 1e6),
                   default=DEFAULT_MAX_MEGAPIXELS, metavar="MP",
                   help=f"decode budget: refuse larger images before decoding them (default "
                        f"{DEFAULT_MAX_MEGAPIXELS:g}, which fits 16384 x 8192)")
    p.add_argument("--overwrite", action="store_true",
                   help="replace output-named files in the output folder that PanoLight did not write "
                        "(an earlier run's outputs are always replaced)")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress messages")


def build_parser() -> argparse.ArgumentParser:
    fmt = argparse.RawDescriptionHelpFormatter
    parser = argparse.ArgumentParser(
        prog="panolight", formatter_class=fmt,
        description="PanoLight: HDR lighting from 360-degree panoramas, as spherical harmonics.",
        epilog="start with:  panolight demo      then:  panolight estimate YOUR_PANORAMA.jpg\n"
               "Run 'panolight <command> --help' for the options of each command.")
    parser.add_argument("--version", action="version", version=f"panolight {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="command")

    p = sub.add_parser("estimate", help="estimate the lighting of one panorama", formatter_class=fmt,
                       description="Estimate the lighting of an equirectangular panorama (2:1; .jpg/.png LDR or "
                                   ".exr/.hdr HDR) and write it with reconstructions and a preview.",
                       epilog=EPILOG_ESTIMATE)
    p.add_argument("input", help="panorama file (equirectangular, width = 2 x height)")
    _add_estimate_options(p)
    p.set_defaults(func=run_estimate)

    b = sub.add_parser("batch", help="estimate many panoramas (folders, lists, render-farm shards)",
                       formatter_class=fmt, description="Run 'estimate' over many panoramas.", epilog=EPILOG_BATCH)
    b.add_argument("inputs", nargs="*", help="panorama files and/or folders")
    b.add_argument("--list", help="a text file with one input path per line ('#' comments allowed)")
    b.add_argument("--recursive", action="store_true", help="also search sub-folders of the given folders")
    b.add_argument("--shard", help="run only shard I of N, written I/N (1 <= I <= N)")
    _add_estimate_options(b)
    b.set_defaults(func=run_batch)

    e = sub.add_parser("eval", help="score every estimator on the eight Blender studio HDRIs", formatter_class=fmt,
                       description="Evaluate estimators with the EVALUATION.md metrics and protocol.",
                       epilog=EPILOG_EVAL)
    e.add_argument("-o", "--output", default="out/eval", help="output folder (default out/eval)")
    e.add_argument("--evs", type=float, nargs="+", default=[-2.0, 0.0, 2.0], help="exposures (default -2 0 2)")
    e.add_argument("--estimators", nargs="+", default=None, help="default: every available estimator")
    e.add_argument("--weights", nargs="+", metavar="LABEL=PATH", default=None,
                   help="also evaluate trained models (model.safetensors from 'panolight train'), one "
                        "column each, e.g. the ablation variants")
    e.add_argument("--lmax", type=int, default=2, help="SH order of the comparison (default 2)")
    e.add_argument("--jpeg", type=int, default=90, metavar="QUALITY",
                   help="JPEG quality of the inputs (default 90, as EVALUATION.md's reference numbers; 0 = none)")
    e.add_argument("--repeats", type=int, default=3, help="timed runs per estimate (median reported; default 3)")
    e.add_argument("--no-adaptive", action="store_true", help="skip the adaptive-model table (lights + auto order)")
    e.add_argument("-q", "--quiet", action="store_true", help="no progress messages")
    e.set_defaults(func=run_eval)

    d = sub.add_parser("demo", help="estimate the lighting of a JPEG made from a bundled HDRI, against the truth",
                       formatter_class=fmt,
                       description="Make an auto-exposed JPEG from one of the eight HDRIs shipped in the bpy "
                                   "package, estimate its lighting, and compare with the HDR's exact SH.",
                       epilog=OUTPUTS_HELP)
    d.add_argument("--scene", default="courtyard",
                   help="city, courtyard (default), forest, interior, night, studio, sunrise or sunset")
    d.add_argument("--ev", type=float, default=0.0, help="exposure of the made JPEG in stops (default 0)")
    _add_estimate_options(d)
    d.set_defaults(func=run_demo)

    m = sub.add_parser("render-mitsuba", help="render the paper's bunny/armadillo figure with Mitsuba 3",
                       formatter_class=fmt,
                       description="Render meshes with a mirror, rough plastic (ior 1.9) and gold material under the "
                                   "lighting estimated from each INPUT (a panorama or a lighting.json), composited "
                                   "over the panorama by differential rendering, and assemble figure.png.",
                       epilog="examples:\n"
                              "  panolight render-mitsuba city.jpg --out out/fig --spp 16       # quick look\n"
                              "  panolight render-mitsuba a.exr b.jpg --out out/fig              # 512 spp, the paper's\n"
                              "  panolight render-mitsuba s.exr --out o --compare-hdr            # add the HDR-lit row\n"
                              "Uses llvm_ad_rgb when LLVM 19 is installed (apt-get install libllvm19), else scalar_rgb.")
    m.add_argument("inputs", nargs="+", help="panoramas (estimated here) or lighting.json files")
    m.add_argument("--out", required=True, help="output folder (created)")
    m.add_argument("--meshes", nargs="+", default=None,
                   help=".ply/.obj meshes with +Y up (default: ../shared/data/meshes/bunny.ply and armadillo.obj)")
    m.add_argument("--spp", type=_number("--spp", 1, 1 << 20, integer=True), default=512,
                   help="samples per pixel (default 512, the paper's)")
    m.add_argument("--resolution", dest="resolution_wh", type=lambda t: tuple(int(v) for v in t.lower().split("x")),
                   default=(320, 240), help="perspective render size WxH (default 320x240)")
    m.add_argument("--yaw", type=float, default=0.0, help="view azimuth in degrees, 0 = panorama centre, 90 = "
                                                          "a quarter width to the left (default 0)")
    m.add_argument("--pitch", type=float, default=-12.0, help="view elevation in degrees (default -12)")
    m.add_argument("--fov", type=float, default=50.0, help="horizontal field of view in degrees (default 50)")
    m.add_argument("--materials", nargs="+", default=["mirror", "plastic", "gold"], help="columns of the figure")
    m.add_argument("--compare-hdr", action="store_true", help="add a row lit by the input HDR itself")
    m.add_argument("--from-ldr", type=float, default=None, metavar="EV",
                   help="estimate each HDR input from the JPEG an auto-exposing camera takes of it at this ev "
                        "(EVALUATION.md, q90), as the paper's figure estimates from photographs; with "
                        "--compare-hdr the ground-truth row is the HDR in the JPEG's units")
    m.add_argument("--no-panorama-view", action="store_true", help="skip the objects-in-the-panorama renders")
    m.add_argument("-q", "--quiet", action="store_true", help="no progress messages")
    m.set_defaults(func=run_render_mitsuba)

    sy = sub.add_parser("synth", help="render synthetic training panoramas (HDR, normals, albedo) with Mitsuba",
                        formatter_class=fmt,
                        description="Render N random rooms and outdoor scenes into 360-degree panoramas with "
                                    "normals and albedo, into a sharded, resumable dataset folder.",
                        epilog="examples:\n"
                               "  panolight synth --count 2000 --out data/synth                # 256x128, 64 spp\n"
                               "  panolight synth --count 2000 --out data/synth --shard 1/2 &  # two processes\n"
                               "  panolight synth --count 2000 --out data/synth --shard 2/2\n"
                               "  panolight sheet data/synth -o sheet.png                      # look at samples\n"
                               "Sample i is seeded by SEED + i, so re-runs skip finished samples and shards never "
                               "collide.")
    sy.add_argument("--count", type=int, required=True, help="number of samples (indices 0..count-1)")
    sy.add_argument("--out", required=True, help="dataset folder (created)")
    sy.add_argument("--resolution", type=_resolution, default=(256, 128), help="panorama size WxH (default 256x128)")
    sy.add_argument("--spp", type=int, default=64,
                    help="samples per pixel (default 64: about 40 %% slower than 16 and far less noisy)")
    sy.add_argument("--seed", type=int, default=0, help="base seed (default 0)")
    sy.add_argument("--shard", help="render only shard I of N, written I/N")
    sy.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    sy.set_defaults(func=run_synth)

    sc = sub.add_parser("sheet", help="contact sheet of random dataset samples (LDR, normals, HDR, relit)",
                        formatter_class=fmt, description="Save a PNG contact sheet of random samples of a synthetic "
                                                         "dataset: LDR, normals, HDR and a relit version.")
    sc.add_argument("dataset", help="dataset folder written by 'panolight synth'")
    sc.add_argument("-o", "--output", default="sheet.png", help="PNG path (default sheet.png)")
    sc.add_argument("--count", type=int, default=6, help="samples shown (default 6)")
    sc.add_argument("--seed", type=int, default=0, help="which samples and lights (default 0)")
    sc.set_defaults(func=run_sheet)

    be = sub.add_parser("build-extension", help="build the installable Blender extension zip",
                        formatter_class=fmt, description="Build panolight-<version>.zip: the Blender 4.2+ extension "
                                                         "with the bpy-free core inside (checked with Blender's "
                                                         "validator when bpy is installed).")
    be.add_argument("-o", "--output", default="dist", help="output folder (default dist/)")
    be.set_defaults(func=run_build_extension)

    tr = sub.add_parser("train", help="train the learned estimator (paper: autoencoder, then lighting encoder)",
                        formatter_class=fmt,
                        description="Train the paper's two networks: the LDR-to-HDR autoencoder first, then the "
                                    "lighting encoder with it frozen. Data: procedural environments plus, with "
                                    "--data, Mitsuba panoramas from 'panolight synth' and their relit versions "
                                    "(paper Eq. 5), prepared once into a cached array file.",
                        epilog="examples:\n"
                               "  panolight train small --data data/synth --out runs/small --max-minutes 60\n"
                               "  panolight train small --procedural 500 --epochs 3 --out /tmp/try   # no Mitsuba data\n"
                               "  torchrun --nproc_per_node 4 -m training.train paper --data data/synth --out runs/paper\n"
                               "A run folder holds checkpoint.pt (resumed automatically), metrics.csv, "
                               "model.safetensors and config.json.")
    tr.add_argument("config", help="small | paper | ablation/VARIANT (e.g. ablation/full-prior) | a JSON config path")
    tr.add_argument("--data", default=None, help="dataset folder written by 'panolight synth' (optional)")
    tr.add_argument("--hdr", default=None, metavar="DIR",
                    help="a folder of real HDR panoramas (.exr/.hdr, e.g. Laval) added as training examples; "
                         "Blender's studio HDRIs are refused (they are the evaluation set)")
    tr.add_argument("--procedural", type=int, default=4000,
                    help="procedural environments in the training set (default 4000)")
    tr.add_argument("--val-procedural", type=int, default=400, help="procedural validation environments (default 400)")
    tr.add_argument("--cache", default=None, help="folder for the prepared arrays (default: --data, else --out)")
    tr.add_argument("--max-minutes", type=float, default=None,
                    help="stop after the epoch that crosses this training time budget")
    tr.add_argument("--ae-from", default=None, metavar="WEIGHTS",
                    help="start from the autoencoder of this model.safetensors (with --ae-epochs 0: train "
                         "only the lighting encoder, as the ablation variants do)")
    tr.add_argument("--out", required=True, help="run folder")
    tr.add_argument("--epochs", type=int, default=10)
    tr.add_argument("--ae-epochs", type=int, default=2, help="autoencoder-only epochs first (default 2)")
    tr.add_argument("--batch-size", type=int, default=16)
    tr.add_argument("--lr", type=float, default=None,
                    help="Adam learning rate (default: the config's; paper 1e-4, small 1e-3)")
    tr.add_argument("--seed", type=int, default=0)
    tr.add_argument("-q", "--quiet", action="store_true")
    tr.set_defaults(func=run_train)

    pr = sub.add_parser("project", help="exact SH projection of a panorama (estimate --estimator naive)",
                        formatter_class=fmt, description="Project a panorama onto SH without any recovery: "
                                                         "the same as 'estimate --estimator naive'.",
                        epilog=OUTPUTS_HELP)
    pr.add_argument("input", help="panorama file (equirectangular, width = 2 x height)")
    _add_estimate_options(pr, default_estimator="naive")
    pr.set_defaults(func=run_project)
    return parser


def _terminate(signum, frame):
    """SIGTERM (a render farm cancelling a job, ``kill``) unwinds like Ctrl-C: the writers' ``finally``
    blocks remove their temporary files, and the exit status says why (128 + 15)."""
    raise _Terminated()


class _Terminated(KeyboardInterrupt):
    pass


def main(argv=None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "command", None):
        parser.print_help()
        return 2
    import signal
    import threading

    previous = None
    if threading.current_thread() is threading.main_thread():
        previous = signal.signal(signal.SIGTERM, _terminate)
    try:
        return _run(args)
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)


def _run(args) -> int:
    with warnings.catch_warnings():
        warnings.simplefilter("always", PanoLightWarning)
        warnings.showwarning = lambda m, c, f, l, file=None, line=None: print(f"warning: {m}", file=sys.stderr)
        try:
            return args.func(args)
        except PanoLightError as exc:
            print(f"panolight: error: {exc}", file=sys.stderr)
            return 1
        except OSError as exc:  # a path the user gave cannot be read or written (permissions, missing folders)
            where = f"{exc.filename}: " if getattr(exc, "filename", None) else ""
            print(f"panolight: error: {where}{exc.strerror or exc}", file=sys.stderr)
            return 1
        except MemoryError:
            print("panolight: error: out of memory (the image is too large for this machine's memory limit; "
                  "lower --max-megapixels to refuse such files up front, or downsample the panorama)",
                  file=sys.stderr)
            return 1
        except _Terminated:
            print("panolight: terminated (SIGTERM)", file=sys.stderr)
            return 143
        except KeyboardInterrupt:
            print("panolight: interrupted", file=sys.stderr)
            return 130


if __name__ == "__main__":
    sys.exit(main())
