"""Command line: ``panolight <command> ...`` (also ``python -m panolight_core``).

The core's commands are estimate, batch, project, eval and demo. Other packages add theirs through the
``panolight.commands`` entry point group (the checkout's training/ adds train, synth, sheet and
render-mitsuba); the core never imports them by name.
"""
from __future__ import annotations

import argparse
import json
import sys
import warnings
from pathlib import Path

from .. import __version__
from ..errors import PanoLightError, PanoLightWarning, printable
from ..pipeline import settings as estimate_settings
from ..pipeline.brackets import BracketSet, group_brackets, group_by_exposure, parse_evs
from .options import HelpFormatter, progress_to_stderr, resolution

PLUGIN_GROUP = "panolight.commands"  # entry points: register(subparsers) adds a plugin's commands

OUTPUTS_HELP = """\
outputs (in OUTDIR; nothing is written anywhere else):
  lighting.json   SH radiance coefficients and explicit lights (Blender world frame, Z up), estimator, input
                  hash, timings, the chosen model/order/deringing and why (schema: panolight_core/schemas)
  hdr.exr         the full-resolution HDR panorama: the input linearised, its clipped sun, lamps and windows
                  filled with their estimated energy (an HDRI for any renderer; SH = lighting.json's model)
  radiance.exr    the SH part's radiance map at --resolution (the lights are in lighting.json)
  irradiance.exr  diffuse irradiance of the whole model (lights + SH) for a surface facing each direction
  preview.png     input | SH radiance | a white diffuse sphere lit by the estimate, each auto-exposed
  clipped.png     a bracket set's only: white where every frame clipped (what the set could not capture)
  lighting.usda   the same lighting as a USD stage (Z up, metersPerUnit 1; needs usd-core): variant
                  "lights" = a DomeLight with radiance.exr + a DistantLight per light (lighting.json's
                  model), variant "hdri" = a DomeLight with hdr.exr (its sources already in the image)
--outputs lighting,hdr,previews picks the groups (lighting.json, radiance.exr, lighting.usda | hdr.exr |
irradiance.exr, preview.png, clipped.png); an earlier run's files outside the chosen groups are removed.
"""

EPILOG_ESTIMATE = f"""\
examples:
  panolight estimate photo.jpg -o out/photo               # lights + the SH order the scene needs (default)
  panolight estimate studio.exr --model sh --lmax 8       # a fixed recipe: 81 SH coefficients, no lights
  panolight estimate room.jpg --tolerance 0.005           # stricter: a higher order if the scene needs it
  panolight estimate sky.hdr --model sh --window auto     # SH only, deringed just enough
  panolight estimate pano.jpg --lux 32000                 # calibrated: a light meter read 32,000 lux facing up

{OUTPUTS_HELP}
models: auto finds compact bright sources (sun, lamps, windows) and stores them as explicit lights (direction,
colour, intensity, angular size, sun/area) in lighting.json; the rest goes to SH at the smallest order whose
diffuse relighting error is within --tolerance. lighting.json records what was chosen and why.
estimators: see --estimator; auto is the best measured on real photographs (docs/accuracy.md).
when unsure: a clipped patch whose energy is unsure gets only what no truth in its 68 % range would make worse
than the photo's own pixels; a key light its evidence cannot weigh surely gets the strength that evidence is sure
of, and a 'note:' line gives its 68 % range and the setting that raises it (--sun-strength); a sun the photo does
not show is not invented from the sky's gradient alone: the note says where the sky puts one and the --sun AZ,EL
that places it (--sky-sun places it by itself). The files and the note say what was done: check the key light
against the photo's own shadows.
units: where the photo's EXIF (exposure time, f-number, ISO), --ev100 or --lux gives the scale, radiance is in cd/m^2
and each light in lux (lighting.json's 'physical' also gives W/m^2); else LDR results are relative to the camera's
clip level (1 = white); --relative keeps them relative; --exposure EV scales them by 2^EV (docs/units.md).
"""

NO_ALIGN_HELP = ("a bracket set shot on a tripod: merge its frames as they are. By default a hand-held set's frames "
                 "are aligned, each moved only where the move makes it agree better with the middle frame")

EPILOG_BATCH = """\
examples:
  panolight batch shots/ -o out/                         # every .exr .hdr .png .jpg and camera RAW in shots/
  panolight batch --list todo.txt -o out/ --shard 2/4    # second of four farm jobs over the same list
  panolight batch shoot/ -o out/ --brackets auto         # bracket sets of any size, grouped by their EXIF

Each input gets OUTDIR/<name>/ with the files of 'panolight estimate'. Bad files are reported and
skipped; the exit status is 1 if any input failed. A report goes to OUTDIR/batch_report.json
(batch_report-I-of-N.json with --shard). Shards split the sorted input list deterministically: every
N-th input starting at the I-th, so N copies with --shard 1/N .. N/N cover it exactly once.
"""

EPILOG_EVAL = """\
Runs the EVALUATION.md protocol on the eight Blender studio HDRIs (shipped in the bpy package) and
writes OUTDIR/eval.md, eval.json and speed_accuracy.png. Expect about a minute with the defaults.
"""



def _job_kwargs(args) -> dict:
    """pipeline.run_estimate's file options from parsed arguments (the estimate settings go separately)."""
    return {"resolution": args.resolution, "repair_nonfinite": args.repair_nonfinite,
            "max_megapixels": args.max_megapixels, "overwrite": args.overwrite, "outputs": args.outputs}


def run_estimate(args) -> int:
    from ..pipeline import run_estimate as job
    inputs = [args.input] if isinstance(args.input, str) else args.input  # project takes one file
    evs = getattr(args, "evs", None)
    if len(inputs) == 1 and evs is not None:
        raise PanoLightError(f"{inputs[0]}: --evs gives a bracket set's exposures; one file is estimated as it "
                             f"is (give every frame of the set)")
    src = Path(inputs[0]) if len(inputs) == 1 else BracketSet(inputs, evs, getattr(args, "align", True))
    out = Path(args.output) if args.output else Path("out") / Path(inputs[0]).stem
    with _exr_threads():
        doc = job(src, out, estimate_settings.from_args(args), **_job_kwargs(args))
    if not args.quiet:
        t = doc["timings"]
        print(f"done: {out}/ (lmax {doc['lmax']}, {doc['estimator']['name']}; read {t['read_s'] * 1e3:.0f} ms, "
              f"estimate {t['estimate_s'] * 1e3:.0f} ms)", file=sys.stderr)
    return 0


class _exr_threads:
    """One estimate may use every CPU for OpenEXR's compression of a large hdr.exr (PIZ at 16K: 5.4 ->
    4.3 s on 2 CPUs). The pool is stopped afterwards: a process that forks later (batch workers, data
    loaders) must not inherit a library thread pool, which hangs in the child. The run's first import of OpenEXR
    holds Ctrl-C and SIGTERM (``threads.optional_module``): a signal in its initialisation made an ImportError."""

    def __enter__(self):
        from .. import threads

        self.exr = threads.optional_module("OpenEXR")
        if self.exr is not None:
            self.before = self.exr.global_thread_count()
            self.exr.set_global_thread_count(threads.cpus())

    def __exit__(self, *exc):
        if self.exr is not None:
            self.exr.set_global_thread_count(self.before)
        return False


def run_project(args) -> int:
    args.estimator = "naive"
    args.model = "sh"
    return run_estimate(args)


def _bracket_count(text: str):
    """--brackets: "auto", or a set's frame count (2-64)."""
    if text.strip().lower() == "auto":
        return "auto"
    return estimate_settings.number("--brackets", 2, 64, integer=True)(text)


def run_batch(args) -> int:
    import dataclasses
    import functools

    from ..pipeline import run_estimate as job
    from .batch import collect_inputs, parse_shard
    from .batch import run_batch as batch
    from .workers import default_jobs

    shard_spec = parse_shard(args.shard)
    settings = estimate_settings.from_args(args)
    estimate_settings.check_map_cost(settings.order, args.resolution[1])  # refused before any input
    inputs = collect_inputs(args.inputs, args.list, args.recursive, exclude=args.output)
    if not inputs:
        raise PanoLightError("no input panoramas found (give files, folders, or --list FILE)")
    if args.brackets == "auto":
        if args.evs is not None:
            raise PanoLightError("--brackets auto groups the files by their EXIF exposures: give --brackets N with "
                                 "--evs")
        inputs = group_by_exposure(inputs, args.align)
    elif args.brackets:
        inputs = group_brackets(inputs, args.brackets, args.evs, args.align)
    elif args.evs is not None:
        raise PanoLightError("--evs gives each bracket set's exposures: give --brackets N too")
    kwargs = _job_kwargs(args)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PanoLightWarning)
        recorded = {**dataclasses.asdict(settings),  # what the outputs depend on (the resume key)
                    **{k: v for k, v in kwargs.items() if k not in ("overwrite", "max_megapixels")}}
        recorded["align"] = args.align  # how a bracket set is merged
        recorded = json.loads(json.dumps(recorded))  # as the report stores it (tuples as lists): resume compares
        report = batch(inputs, Path(args.output), functools.partial(job, settings=settings, **kwargs), shard_spec,
                       args.quiet, settings=recorded, jobs=args.jobs or default_jobs())
    print(f"batch: {report['ok']} ok, {report['skipped']} up to date, {report['failed']} failed of "
          f"{report['this_shard']} "
          f"(shard {report['shard']} of {report['total_inputs']} inputs); report: {report['report_path']}",
          file=sys.stderr)
    for r in report["results"]:
        if r["status"] == "failed":
            print(f"  failed: {printable(r['error'])}", file=sys.stderr)
        for note in r.get("warnings", ()):
            print(f"  warning: {printable(note)}", file=sys.stderr)
        if r.get("note"):  # a bracket set refused, or frames it left out, estimated alone
            print(f"  note: {printable(r['input'])}: {printable(r['note'])}", file=sys.stderr)
        if r.get("key_light"):  # the note estimate logs: a key light uncertain, kept low or missing
            print(f"  key light: {printable(r['input'])}: {printable(r['key_light'])}", file=sys.stderr)
    return 1 if report["failed"] else 0


def run_eval(args) -> int:
    from ..estimators import available, register_model
    from . import eval_report, evaluation

    base = args.estimators or list(available())
    extra = []
    for spec in args.weights or []:
        label, sep, path = spec.partition("=")
        if not sep or not label or not path:
            raise PanoLightError(f"--weights {spec!r}: write LABEL=PATH, e.g. full-prior=runs/full/model.safetensors")
        extra.append(register_model(label, path))
    names = base + [e for e in extra if e not in base]
    result = evaluation.run(evs=args.evs, estimators=names, lmax=args.lmax, jpeg_quality=args.jpeg or None,
                            repeats=args.repeats)
    if not args.no_adaptive:
        result["adaptive"] = evaluation.run_adaptive()
    paths = eval_report.write(result, args.output)
    print(eval_report.markdown(result))
    if result.get("adaptive"):
        print(eval_report.markdown_adaptive(result["adaptive"]))
    print("wrote " + ", ".join(str(p) for p in paths), file=sys.stderr)
    if not any(p.suffix == ".png" for p in paths):
        print(f"note: {eval_report.PLOT_HINT}", file=sys.stderr)
    return 0


def run_demo(args) -> int:
    """Make a phone-like JPEG from a bundled HDRI, estimate its lighting, compare with the HDR truth."""
    from .demo import run_demo as demo

    out = Path(args.output or Path("out") / args.scene)
    res = demo(args.scene, args.ev, out, estimate_settings.from_args(args), **_job_kwargs(args))
    print(f"demo: diffuse relighting error against the HDR's exact irradiance: irr-RMSE {res['irr_rmse']:.3f} "
          f"with {res['lights']} light(s) + SH lmax {res['lmax']} (naive lmax 2: {res['naive_irr_rmse']:.3f}); "
          f"see {out}/preview.png")
    return 0


def _add_estimate_options(p, default_estimator="auto"):
    p.add_argument("-o", "--output", default=None, help="output folder (created; default out/<input name>)")
    estimate_settings.add_arguments(p, default_estimator)
    p.add_argument("--resolution", type=resolution, default=(512, 256),
                   help="size of radiance.exr / irradiance.exr, WxH (default 512x256)")
    from ..pipeline.job import OUTPUT_GROUPS, parse_outputs

    p.add_argument("--outputs", type=estimate_settings.argparse_type(parse_outputs), default=tuple(OUTPUT_GROUPS),
                   metavar="GROUPS",
                   help="what to write: all (the default), or groups comma-separated: " + "; ".join(
                       f"{g}: {', '.join(files)}" for g, files in OUTPUT_GROUPS.items())
                   + " (lighting.usda needs usd-core; lighting is always written)")
    p.add_argument("--repair-nonfinite", action="store_true", help="replace NaN/Inf pixels instead of refusing")
    from ..io.images import DEFAULT_MAX_MEGAPIXELS, MAX_PIXELS

    p.add_argument("--max-megapixels", type=estimate_settings.number("--max-megapixels", 0.001, MAX_PIXELS / 1e6),
                   default=DEFAULT_MAX_MEGAPIXELS, metavar="MP",
                   help=f"decode budget: refuse larger images before decoding them (default "
                        f"{DEFAULT_MAX_MEGAPIXELS:g}, which fits 16384 x 8192)")
    p.add_argument("--overwrite", action="store_true",
                   help="replace output-named files in the output folder that PanoLight did not write "
                        "(an earlier run's outputs are always replaced)")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress messages")


def _command(sub, name, func, *, help, description, epilog=None, estimate_options=None):
    """A sub-command: its parser (with the estimate options when estimate_options names the default
    estimator) and the function that runs it."""
    p = sub.add_parser(name, help=help, formatter_class=HelpFormatter, description=description, epilog=epilog)
    if estimate_options:
        _add_estimate_options(p, estimate_options)
    p.set_defaults(func=func)
    return p


def _load_plugins(sub) -> None:
    """Commands of installed plugins (entry point group PLUGIN_GROUP). A plugin whose package is absent
    here (a wheel without the checkout's training/) is skipped; one that fails otherwise gets a warning."""
    from importlib.metadata import entry_points

    for ep in entry_points(group=PLUGIN_GROUP):
        try:
            register = ep.load()
        except Exception as exc:  # a broken plugin must not take the core's commands down with it
            if isinstance(exc, ModuleNotFoundError) and exc.name and \
                    ep.value.split(":")[0].split(".")[0] == exc.name.split(".")[0]:
                continue
            print(f"warning: the '{ep.name}' commands could not be loaded ({exc})", file=sys.stderr)
            continue
        register(sub)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="panolight", formatter_class=HelpFormatter,
        description="PanoLight: HDR lighting from 360-degree panoramas, as spherical harmonics.",
        epilog="start with:  panolight demo      then:  panolight estimate YOUR_PANORAMA.jpg\n"
               "Run 'panolight <command> --help' for the options of each command.")
    parser.add_argument("--version", action="version", version=f"panolight {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="command")

    p = _command(sub, "estimate", run_estimate, estimate_options="auto", epilog=EPILOG_ESTIMATE,
                 help="estimate the lighting of one panorama",
                 description="Estimate the lighting of an equirectangular panorama (2:1; .jpg/.png LDR, "
                             ".exr/.hdr HDR, or a camera RAW: .dng, .cr3, .nef, .arw ...) and write it with "
                             "reconstructions and a preview.")
    p.add_argument("input", nargs="+",
                   help="panorama file (equirectangular, width = 2 x height; a stitched one, not two fisheye "
                        "circles); several 8-bit files or several RAWs: a bracket set of one scene at different "
                        "exposures, merged into one HDR first (exposures from the EXIF, a phone's from its bias, or "
                        "--evs; 8-bit frames through the camera's own curve where it differs from sRGB). A frame of "
                        "another scene amid the set is left out and named, where the rest hold without it")
    p.add_argument("--evs", type=estimate_settings.argparse_type(parse_evs), default=None, metavar="EV,EV,...",
                   help="a bracket set's exposures in stops, one per file in their order (e.g. -2,0,2), where the "
                        "files' EXIF lacks or misstates them")
    p.add_argument("--no-align", dest="align", action="store_false", help=NO_ALIGN_HELP)

    b = _command(sub, "batch", run_batch, estimate_options="auto", epilog=EPILOG_BATCH,
                 help="estimate many panoramas (folders, lists, render-farm shards)",
                 description="Run 'estimate' over many panoramas.")
    b.set_defaults(log_steps=False)  # batch shows its own line per input, not each estimate's steps
    b.add_argument("inputs", nargs="*", help="panorama files and/or folders")
    b.add_argument("--list", help="a text file with one input path per line ('#' comments allowed)")
    b.add_argument("--recursive", action="store_true", help="also search sub-folders of the given folders")
    b.add_argument("--shard", help="run only shard I of N, written I/N (1 <= I <= N)")
    b.add_argument("--brackets", type=_bracket_count, default=None, metavar="N|auto",
                   help="the inputs are bracket sets of N frames: sorted by name, each N consecutive files one scene, "
                        "merged into one HDR (its folder named after the first frame); auto: sets of any size by the "
                        "files' EXIF, in the order taken, a new set where an exposure repeats or a frame comes 5 s "
                        "after the last (2 min for a set exposed by hand); a lone frame is estimated alone")
    b.add_argument("--evs", type=estimate_settings.argparse_type(parse_evs), default=None, metavar="EV,EV,...",
                   help="with --brackets: every set's exposures in stops, in name order (default: each file's EXIF)")
    b.add_argument("--no-align", dest="align", action="store_false", help=NO_ALIGN_HELP)
    b.add_argument("--jobs", type=estimate_settings.number("--jobs", 0, 256, integer=True), default=0, metavar="N",
                   help="worker processes (default 0: one more than the CPUs this process may use; 1: no pool). "
                        "Each holds one panorama: at 16K, about 1.3 GB")

    e = _command(sub, "eval", run_eval, help="score every estimator on the eight Blender studio HDRIs",
                 description="Evaluate estimators with the EVALUATION.md metrics and protocol.", epilog=EPILOG_EVAL)
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

    d = _command(sub, "demo", run_demo, estimate_options="auto", epilog=OUTPUTS_HELP,
                 help="estimate the lighting of a JPEG made from a bundled HDRI, against the truth",
                 description="Make an auto-exposed JPEG from one of the eight HDRIs shipped in the bpy "
                             "package, estimate its lighting, and compare with the HDR's exact SH.")
    d.add_argument("--scene", default="courtyard",
                   help="city, courtyard (default), forest, interior, night, studio, sunrise or sunset")
    d.add_argument("--ev", type=float, default=0.0, help="exposure of the made JPEG in stops (default 0)")

    pr = _command(sub, "project", run_project, estimate_options="naive", epilog=OUTPUTS_HELP,
                  help="exact SH projection of a panorama (estimate --estimator naive)",
                  description="Project a panorama onto SH without any recovery: the same as "
                              "'estimate --estimator naive'.")
    pr.add_argument("input", help="panorama file (equirectangular, width = 2 x height)")
    _load_plugins(sub)
    return parser


def _unknown_arguments(parser, args, rest) -> None:
    """Exit 2 with the usage of the command that was given (not the top level's) and, for an option that
    looks like a mistyped one, the nearest of that command's options ("did you mean --exposure?")."""
    import difflib

    command = parser
    while True:  # down the sub-commands that were chosen: panolight dev TOOL ...
        subs = [a for a in command._actions if isinstance(a, argparse._SubParsersAction)]
        chosen = subs and getattr(args, subs[0].dest, None)
        if not chosen or chosen not in subs[0].choices:
            break
        command = subs[0].choices[chosen]
    options = [o for a in command._actions for o in a.option_strings if o.startswith("--")]
    hints = []
    for word in rest:
        if word.startswith("-"):
            close = difflib.get_close_matches(word.split("=", 1)[0], options, n=1, cutoff=0.6)
            if close:
                hints.append(f"{word}: did you mean {close[0]}?")
    command.error(f"unrecognized arguments: {' '.join(rest)}" + ("\n  " + "\n  ".join(hints) if hints else ""))


def terminate(signum, frame):
    """SIGTERM (a render farm cancelling a job, ``kill``) unwinds like Ctrl-C: the writers' ``finally``
    blocks remove their temporary files, and the exit status says why (128 + 15)."""
    raise _Terminated()


class _Terminated(KeyboardInterrupt):
    pass


def main(argv=None) -> int:
    """The ``panolight`` command (argv: its arguments; None: sys.argv's). SIGTERM unwinds like Ctrl-C while it
    runs, and either ends it with one line (143, 130), wherever it comes."""
    import signal
    import threading

    previous = None
    if threading.current_thread() is threading.main_thread():
        previous = signal.signal(signal.SIGTERM, terminate)
    try:
        return _main(argv)
    except _Terminated:
        print("panolight: terminated (SIGTERM)", file=sys.stderr)
        return 143
    except KeyboardInterrupt:
        print("panolight: interrupted", file=sys.stderr)
        return 130
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)


def _main(argv) -> int:
    parser = build_parser()
    argv = estimate_settings.attach_negative_values(parser, sys.argv[1:] if argv is None else list(argv))  # --evs -2,0,2 as typed
    # a plugin's tool with its own command line (set_defaults(forward=True)) gets every argument after its
    # name in args.forwarded; any other command refuses arguments it does not know, as parse_args would
    args, rest = parser.parse_known_args(argv)
    if rest and not getattr(args, "forward", False):
        _unknown_arguments(parser, args, rest)
    args.forwarded = rest
    if not getattr(args, "command", None):
        parser.print_help()
        return 2
    with progress_to_stderr(getattr(args, "quiet", False) or not getattr(args, "log_steps", True)):
        return _run(args)


def _run(args) -> int:
    with warnings.catch_warnings():
        warnings.simplefilter("always", PanoLightWarning)
        warnings.showwarning = lambda m, c, f, l, file=None, line=None: print(f"warning: {printable(m)}",
                                                                               file=sys.stderr)
        try:
            return args.func(args)
        except PanoLightError as exc:
            print(f"panolight: error: {printable(exc)}", file=sys.stderr)
            return 1
        except OSError as exc:  # a path the user gave cannot be read or written (permissions, missing folders)
            where = f"{exc.filename}: " if getattr(exc, "filename", None) else ""
            print(f"panolight: error: {printable(where)}{exc.strerror or exc}", file=sys.stderr)
            return 1
        except MemoryError:
            print("panolight: error: out of memory (the image is too large for this machine's memory limit; "
                  "lower --max-megapixels to refuse such files up front, or downsample the panorama)",
                  file=sys.stderr)
            return 1


if __name__ == "__main__":
    sys.exit(main())
